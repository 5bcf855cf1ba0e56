!> The flux scene's 3-DOF tube cut for one energy, for the program (src/capi) and for Python
!> (python/tubes_f2py.f90): the call's set-up (the model and its saddle, tubes_study) around the
!> numerics of src/orbits/tubes_cut3.f90 (the cut, its half grid, the Monte Carlo points placed).
module tubes_flux3
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
  use tubes_kinds, only: wp
  use tubes_status, only: TUBES_OK, TUBES_EINPUT
  use tubes_hamiltonian, only: hamiltonian_t
  use tubes_methods, only: integ_choice_t
  use tubes_normal_form, only: nf_result_t, nf_change_t, normal_form
  use tubes_ensemble, only: ens_agree
  use tubes_equilibria, only: equilibrium_t
  use tubes_cut3, only: cut3_t, CUT3_NDIAG, cut3_compute, cut3_half, cut3_inside, bcast_normal_form
  use tubes_study, only: setup_model
  implicit none
  private

  public :: cut3_study

contains

  !> The whole 3-DOF tube computation of the flux scene for one energy, for the program and for
  !> Python: the model and its saddle, the normal form of order `order` of the Taylor expansion
  !> (expo(6, :), coef) at zs, the cut (cut3_compute) on n_cut + 1 rings of (2 n_cut)^2 seeds, its
  !> half grid, and the section's Monte Carlo points pts(6, :) (NaN: outside the shell) with their
  !> weights w and classes cls (1 transit, -1 return, 2 undecided, 3 outside) placed inside or
  !> outside it: inside (smooth crossings), inside_pl (piecewise linear), -1 for no point; diag
  !> (CUT3_NDIAG, above). msg says why when stat is TUBES_EINPUT.
  subroutine cut3_study(system, params, lo, hi, n_grid, saddle, order, expo, coef, zs, de, k, c, dir, n_cut, &
                        eps, t_max, tol, integ, pts, w, cls, inside, inside_pl, cut, diag, msg, stat)
    character(*), intent(in) :: system, saddle
    real(wp), intent(in) :: params(:), lo(:), hi(:), coef(:), zs(:), de, c, eps, t_max, tol, pts(:, :), w(:)
    integer, intent(in) :: n_grid, order, expo(:, :), k, dir, n_cut, cls(:)
    type(integ_choice_t), intent(in) :: integ
    integer, intent(out) :: inside(:), inside_pl(:), stat
    type(cut3_t), intent(out) :: cut
    real(wp), intent(out) :: diag(CUT3_NDIAG)
    character(*), intent(out) :: msg
    class(hamiltonian_t), allocatable :: model
    type(equilibrium_t), allocatable :: eqs(:)
    type(nf_result_t) :: nf
    type(nf_change_t) :: ch
    type(cut3_t) :: half
    logical :: ins(size(pts, 2)), ok(size(pts, 2)), unres(size(pts, 2)), dec(size(pts, 2))
    integer :: isad
    real(wp) :: wall, z0(size(zs)), es
    inside = -1
    inside_pl = -1
    diag = ieee_value(1.0_wp, ieee_quiet_nan)
    msg = ''
    call setup_model(system, params, lo, hi, n_grid, saddle, model, eqs, isad, stat, des=[de])
    if (stat /= TUBES_OK) return
    call normal_form(3, order, expo, coef, nf, stat, change=ch)
    if (stat /= TUBES_OK) then
      msg = nf%message
      return
    end if
    call bcast_normal_form(nf, ch)
    z0 = zs
    call ens_agree(z0)
    es = model%energy(z0)
    call ens_agree(es)
    call cut3_compute(model, nf, ch, z0, es, de, n_cut, 2*n_cut, eps, k, c, dir, t_max, tol, integ, cut, stat)
    if (stat == TUBES_EINPUT) then
      msg = 'the plane is parallel to the direction in which the tube leaves the saddle, or passes through it'
      return
    end if
    if (.not. allocated(cut%x)) return
    diag(1:3) = [cut%seed_energy_error, cut%volume, real(cut%n_failed, wp)]
    if (stat /= TUBES_OK) return
    call cut3_half(cut, half, stat)
    if (stat /= TUBES_OK) return
    diag(4:5) = [half%volume, cut%volume + (cut%volume - half%volume)/3]
    ok = .not. any(pts /= pts, dim=1) .and. cls /= 3
    call cut3_inside(cut, pts(cut%axes, :), ins)
    where (ok) inside_pl = merge(1, 0, ins)
    call cut3_inside(cut, pts(cut%axes, :), ins, smooth=.true., unresolved=unres)
    where (ok) inside = merge(1, 0, ins)
    dec = ok .and. (cls == 1 .or. cls == -1)
    wall = sum(w, mask=ok)
    diag(6:12) = [real(count(unres .and. ok), wp), real(count(dec .and. (inside == 1 .neqv. cls == 1)), wp), &
                  real(count(dec .and. (inside_pl == 1 .neqv. cls == 1)), wp), real(count(dec), wp), &
                  real(count(inside == 1), wp), sum(w, mask=inside == 1)/wall, sum(w, mask=ok .and. cls == 1)/wall]
    if (.not. wall > 0) diag(11:12) = ieee_value(1.0_wp, ieee_quiet_nan)     ! no points
  end subroutine cut3_study
end module tubes_flux3
