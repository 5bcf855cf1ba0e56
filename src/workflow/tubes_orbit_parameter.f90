!> Orbits of a family asked for by Jacobi constant or by period instead of dE (docs/orbits.md,
!> "Orbits by Jacobi constant or period"; &orbits jacobi, periods): each value becomes the excess
!> energy dE of its orbit, and the orbits are then those of that dE (family_at, bit for bit the
!> orbits of `de` = those energies).
!>
!> - Jacobi constant C: dE = E(C) - E_e with E(C) the model's (energy_of_jacobi: the CR3BP's
!>   C = -2 H); a model without a Jacobi constant is refused (PARAM_NOJACOBI).
!> - Period T: the family is parametrised by dE; T(dE) is followed from the saddle's limit
!>   T_po = 2 pi / omega (dE -> 0) upwards on the grid dE_1 2^j (dE_1: the linear orbit's amplitude
!>   1e-3 of the distance to the nearest other equilibrium), each T an orbit of the family at that
!>   energy alone, to the first grid interval where T - T* changes sign (the first crossing from the
!>   saddle; a T that passes T* and comes back inside one grid interval is not seen); where the
!>   family ends first, the interval up to its end is searched on 30 points that close in on it.
!>   In the bracket, GSL's Brent (tubes_quad quad_root) on T(dE) - T* to |bracket| <= 1e-14 dE;
!>   the orbit at the root must have |T - T*| <= PERIOD_RTOL T* (else PARAM_NOCONV). A period the
!>   family does not reach between T_po and its end: PARAM_NOT_REACHED. The Lyapunov families
!>   (opts%family 1..N-1, or 'vertical' / 'lyapunov' by name) only: a guess's, a branch's, a halo or
!>   the axial family is refused (stat TUBES_EINPUT).
module tubes_orbit_parameter
  use, intrinsic :: iso_c_binding, only: c_double, c_ptr, c_loc, c_f_pointer, c_funloc
  use tubes_kinds, only: wp, PI
  use tubes_status, only: TUBES_OK, TUBES_EINPUT, TUBES_ENOCONV, TUBES_EUNRESOLVED
  use tubes_hamiltonian, only: hamiltonian_t, energy_of_jacobi
  use tubes_equilibria, only: equilibrium_t
  use tubes_orbits, only: orbit_t, orbit_opts_t, linear_guess, named_mode, FAMILY_VERTICAL, FAMILY_PLANAR
  use tubes_study, only: study_t, seed_stores_t, setup_model, family_at
  use tubes_quad, only: quad_root
  implicit none
  private

  integer, parameter, public :: PARAM_DE = 0, PARAM_JACOBI = 1, PARAM_PERIOD = 2   !! which parameter
  !> per value: its dE found; the family does not reach it; the root finder or the orbit at the root
  !> failed; the model has no Jacobi constant
  integer, parameter, public :: PARAM_FOUND = 0, PARAM_NOT_REACHED = 1, PARAM_NOCONV = 2, PARAM_NOJACOBI = 3
  real(wp), parameter, public :: PERIOD_RTOL = 1.0e-12_wp   !! |T - T*| <= PERIOD_RTOL T* at the root
  real(wp), parameter :: BRENT_XTOL = 1.0e-14_wp            !! Brent's bracket, relative to dE
  real(wp), parameter :: GRID_AMP = 1.0e-3_wp               !! the grid's first dE: this linear amplitude
  integer, parameter :: GRID_MAX = 200, CLOSE_IN = 30

  !> The family whose period is sought (the root finder's user data).
  type :: period_ctx_t
    type(study_t) :: st
    class(hamiltonian_t), allocatable :: model
    type(equilibrium_t), allocatable :: eqs(:)
    integer :: isad = 0
    type(orbit_opts_t) :: opts
    type(seed_stores_t), pointer :: stores => null()
    real(wp) :: target = 0, t_po = 0
    integer :: stat = TUBES_OK
  end type period_ctx_t

  public :: family_parameter_des

contains

  !> The excess energies des(k) of the orbits of the study's family (opts) at values(k), a Jacobi
  !> constant (kind PARAM_JACOBI) or a period (PARAM_PERIOD); found(k) one of PARAM_FOUND, ...
  !> (des(k) = 0 where not PARAM_FOUND). t_po: the saddle's limit 2 pi / omega of the family;
  !> t_reach, de_reach: where the period search went furthest (the last converged orbit before the
  !> family's end; 0 for Jacobi); e_saddle: E_e. stat < 0: the study could not be set up, or the
  !> family or kind is not one this takes (TUBES_EINPUT).
  subroutine family_parameter_des(st, opts, kind, values, des, found, t_po, t_reach, de_reach, e_saddle, stat, &
                                  stores)
    type(study_t), intent(in) :: st
    type(orbit_opts_t), intent(in) :: opts
    integer, intent(in) :: kind
    real(wp), intent(in) :: values(:)
    real(wp), intent(out) :: des(size(values)), t_po, t_reach, de_reach, e_saddle
    integer, intent(out) :: found(size(values)), stat
    type(seed_stores_t), intent(inout), target, optional :: stores
    type(period_ctx_t), target :: c
    integer :: k, mode
    des = 0
    found = PARAM_NOCONV
    t_po = 0
    t_reach = 0
    de_reach = 0
    e_saddle = 0
    if (kind /= PARAM_JACOBI .and. kind /= PARAM_PERIOD) then
      stat = TUBES_EINPUT
      return
    end if
    call setup_model(trim(st%system), st%params, st%lo, st%hi, st%n_grid, trim(st%saddle), c%model, c%eqs, &
                     c%isad, stat, stores=stores)
    if (stat /= TUBES_OK) return
    e_saddle = c%eqs(c%isad)%energy
    if (kind == PARAM_JACOBI) then
      do k = 1, size(values)
        if (c%model%jacobi_factor() == 0) then
          found(k) = PARAM_NOJACOBI
        else
          des(k) = energy_of_jacobi(c%model, values(k)) - e_saddle
          found(k) = PARAM_FOUND
        end if
      end do
      return
    end if
    ! periods: the Lyapunov families of a saddle only (by number, or 'vertical' / 'lyapunov' by name:
    ! their centre mode's, named_mode)
    mode = opts%family
    if (mode == FAMILY_VERTICAL .or. mode == FAMILY_PLANAR) &
      mode = named_mode(c%eqs(c%isad), c%model%ndof(), opts%family)
    if (allocated(opts%guess) .or. opts%branch > 0 .or. mode < 1 .or. &
        mode > size(c%eqs(c%isad)%omegas)) then
      stat = TUBES_EINPUT
      return
    end if
    c%st = st
    c%opts = opts
    if (present(stores)) c%stores => stores
    c%t_po = 2*PI/c%eqs(c%isad)%omegas(mode)
    t_po = c%t_po
    do k = 1, size(values)
      c%target = values(k)
      call period_de(c, des(k), found(k), t_reach, de_reach)
      if (c%stat < 0 .and. c%stat /= TUBES_ENOCONV) then
        stat = c%stat
        return
      end if
    end do
    stat = TUBES_OK
  end subroutine family_parameter_des

  !> The dE of the first crossing of T(dE) = c%target from the saddle (family_parameter_des).
  subroutine period_de(c, de, found, t_reach, de_reach)
    type(period_ctx_t), intent(inout), target :: c
    real(wp), intent(out) :: de
    integer, intent(out) :: found
    real(wp), intent(inout) :: t_reach, de_reach
    real(wp) :: a, b, ga, gb, t, root, x0(c%model%dim()), tau, amp, dist, last_ok, end_de
    integer :: j, gst
    logical :: ok, bracketed
    de = 0
    found = PARAM_NOT_REACHED
    c%stat = TUBES_OK
    if (.not. (c%target > 0)) return
    ga = c%t_po - c%target
    if (ga == 0) return                     ! the limit itself: no orbit (dE = 0)
    ! the grid's first energy: the linear orbit's amplitude GRID_AMP of the saddle's distance to
    ! the nearest other equilibrium (the model's length scale if none)
    dist = huge(1.0_wp)
    do j = 1, size(c%eqs)
      if (j /= c%isad) dist = min(dist, norm2(c%eqs(j)%q - c%eqs(c%isad)%q))
    end do
    if (dist == huge(1.0_wp)) dist = c%model%length_scale()
    call linear_guess(c%model, c%eqs(c%isad), 1.0_wp, x0, tau)
    amp = norm2(x0(1:size(c%eqs(c%isad)%q)) - c%eqs(c%isad)%q)
    b = 1.0e-6_wp
    if (amp > 0) b = (GRID_AMP*dist/amp)**2
    a = 0
    last_ok = 0
    bracketed = .false.
    do j = 1, GRID_MAX
      call period_at(c, b, t, ok, end_de)
      if (.not. ok) exit
      last_ok = b
      t_reach = t
      de_reach = b
      gb = t - c%target
      if (sign(1.0_wp, gb) /= sign(1.0_wp, ga) .or. gb == 0) then
        bracketed = .true.
        exit
      end if
      a = b
      ga = gb
      b = 2*b
    end do
    if (.not. bracketed .and. .not. ok) then   ! the family ends between a and b: close in on its end
      if (end_de > last_ok .and. end_de < b) b = end_de
      do j = 1, CLOSE_IN
        root = last_ok + (b - last_ok)*(1 - 0.5_wp**j)
        call period_at(c, root, t, ok, end_de)
        if (.not. ok) cycle
        t_reach = t
        de_reach = root
        gb = t - c%target
        if (sign(1.0_wp, gb) /= sign(1.0_wp, ga) .or. gb == 0) then
          b = root
          bracketed = .true.
          exit
        end if
        a = root
        ga = gb
      end do
    end if
    if (.not. bracketed) return
    if (gb == 0) then
      root = b
    else
      gst = quad_root(c_funloc(period_gap), c_loc(c), a, b, 0.0_wp, BRENT_XTOL, root)
      if (gst /= 0 .or. c%stat /= TUBES_OK) then
        found = PARAM_NOCONV
        c%stat = TUBES_ENOCONV
        return
      end if
    end if
    call period_at(c, root, t, ok, end_de)
    if (.not. ok .or. abs(t - c%target) > PERIOD_RTOL*c%target) then
      found = PARAM_NOCONV
      c%stat = TUBES_ENOCONV
      return
    end if
    de = root
    found = PARAM_FOUND
  end subroutine period_de

  !> The period t of the family's orbit at de alone (family_at); de <= 0: the saddle's limit T_po.
  !> ok: the orbit converged; end_de: the family's end where it did not (else -1).
  subroutine period_at(c, de, t, ok, end_de)
    type(period_ctx_t), intent(inout) :: c
    real(wp), intent(in) :: de
    real(wp), intent(out) :: t, end_de
    logical, intent(out) :: ok
    type(orbit_t) :: orbs(1)
    integer :: reason, st
    end_de = -1
    t = c%t_po
    ok = .true.
    if (de <= 0) return
    call family_at(c%st, c%model, c%eqs, c%isad, [de], c%opts, orbs, end_de, reason, st, c%stores)
    ok = st == TUBES_OK .and. orbs(1)%converged
    if (st < 0 .and. st /= TUBES_EUNRESOLVED) c%stat = st   ! below the energy's resolution: no orbit
    if (ok) t = orbs(1)%period
  end subroutine period_at

  !> T(dE) - T* for Brent (the user pointer: a period_ctx_t); a failed orbit inside the bracket
  !> sets the context's stat and answers 0, which ends the search.
  real(c_double) function period_gap(x, user) bind(C)
    real(c_double), value :: x
    type(c_ptr), value :: user
    type(period_ctx_t), pointer :: c
    real(wp) :: t, end_de
    logical :: ok
    call c_f_pointer(user, c)
    call period_at(c, x, t, ok, end_de)
    if (.not. ok) then
      if (c%stat == TUBES_OK) c%stat = TUBES_ENOCONV
      period_gap = 0
      return
    end if
    period_gap = t - c%target
  end function period_gap

end module tubes_orbit_parameter
