!> The parameter scan's core (src/workflow/tubes_scan.f90, docs/scan.md) without the front ends:
!> (1) continue_equilibria from find_equilibria's own positions returns them (names, order, the
!> origin map the identity) and, from the positions at alpha = 0.07, the rolling ball's equilibria
!> at alpha = 0.0705 as find_equilibria finds them from its grid (Newton from another start: the
!> positions agree to roundoff, ~1e-14 cm; asserted 1e-12 cm); (2) scan_table on the coupled quartic
!> with omega = 1.5, eps = 0.3 locates the fold where its two wells meet the saddle at the origin,
!> alpha_c = eps omega/(omega + eps) = 0.25 (grad V = 0 on y = eps x/(omega + eps) with
!> x (beta x^2 - alpha + alpha_c) = 0), to 1e-8 (measured ~1e-12: the equilibria's merge distance);
!> the saddle's lambda^2 omega^2 = -det Hess V(0) = -(eps - alpha)(omega + eps) + eps^2 (unit
!> masses) at every step before it, to 1e-12 relative; (3) bad arguments give TUBES_EINPUT; (4) p_trans
!> along the scan (the optional arguments) on the uncoupled quartic (eps = 0), where x = 0 is invariant
!> and the saddle's orbit is the y oscillator: the cut's area is its action T dE and the energy
!> surface on x = 1/2 an ellipse of area T (E - V_x(1/2)), so p_trans = dE/(dE + alpha/8 - beta/64)
!> (measured 7e-12 relative with DOP853; asserted 1e-9); mismatched p_trans arrays give TUBES_EINPUT.
program test_scan
  use tubes_kinds, only: wp
  use tubes_status, only: TUBES_OK, TUBES_EINPUT
  use tubes_hamiltonian, only: hamiltonian_t
  use tubes_models, only: make_model, MAX_PARAMS, MAX_DOF
  use tubes_equilibria, only: equilibrium_t, find_equilibria, continue_equilibria
  use tubes_orbits, only: orbit_opts_t
  use tubes_study, only: study_t, section_choice_t
  use tubes_manifold, only: tube_opts_t
  use tubes_scan, only: scan_table, SCAN_MAXEQ, FOLD_MEET, SCAN_CONSTANT
  use tubes_check, only: check_close, check_rel, check_true, check_eq, finish
  implicit none

  class(hamiltonian_t), allocatable :: model
  type(equilibrium_t), allocatable :: eqs(:), cont(:), direct(:)
  integer, allocatable :: origin(:)
  real(wp), allocatable :: starts(:, :)
  real(wp) :: params(MAX_PARAMS), lo(2), hi(2)
  integer :: stat, k

  ! (1) the rolling ball: its defaults (the paper's) in the table's order
  params = 0
  params(1:6) = [0.07_wp, 1.017_wp, 15.103_wp, 0.00656_wp, 12.065_wp, 981.0_wp]
  lo = -20
  hi = 20
  call make_model('rolling_ball', params, model, stat)
  call check_eq('ball model', stat, TUBES_OK)
  call find_equilibria(model, lo, hi, 41, eqs, stat)
  call check_eq('ball equilibria', size(eqs), 9)
  allocate (starts(2, size(eqs)))
  do k = 1, size(eqs)
    starts(:, k) = eqs(k)%q
  end do
  call continue_equilibria(model, lo, hi, 41, starts, cont, origin, stat)
  call check_eq('continued from themselves: status', stat, TUBES_OK)
  call check_eq('continued from themselves: count', size(cont), size(eqs))
  call check_true('continued from themselves: origin is the identity', all(origin == [(k, k = 1, size(eqs))]))
  call check_same_equilibria('continued from themselves', '', cont, eqs)
  params(1) = 0.0705_wp
  call make_model('rolling_ball', params, model, stat)
  call continue_equilibria(model, lo, hi, 41, starts, cont, origin, stat)
  call find_equilibria(model, lo, hi, 41, direct, stat)
  call check_eq('alpha 0.0705: continued count', size(cont), size(direct))
  call check_true('alpha 0.0705: each start its own equilibrium', all(origin > 0) .and. &
                  all([(count(origin == origin(k)) == 1, k = 1, size(origin))]))
  call check_same_equilibria('alpha 0.0705', ' as the search', cont, direct)
  call check_rel('alpha 0.0705: S12 lambda as the search', cont(5)%lambda, direct(5)%lambda, 1.0e-12_wp)

  call fold_case()
  call bad_arguments()
  call p_trans_case()
  call finish('test_scan')

contains

  subroutine fold_case()
    integer, parameter :: N = 9
    real(wp), parameter :: OMG = 1.5_wp, EPS_C = 0.3_wp, ALPHA_C = EPS_C*OMG/(OMG + EPS_C)
    type(study_t) :: st
    type(orbit_opts_t) :: opts
    real(wp) :: value(N + 1), eq_q(MAX_DOF, SCAN_MAXEQ, N + 1), eq_energy(SCAN_MAXEQ, N + 1), &
                saddle_q(MAX_DOF, N + 1), saddle_energy(N + 1), lambda(N + 1), omega(MAX_DOF - 1, N + 1), &
                period(1, N + 1), action(1, N + 1), stability(1, N + 1), fold_value(8), fold_width(8), &
                fold_q(MAX_DOF, 8), det
    integer :: n_eq(N + 1), researched(N + 1), eq_index(SCAN_MAXEQ, N + 1), eq_name(8, SCAN_MAXEQ, N + 1), &
               eq_det(SCAN_MAXEQ, N + 1), saddle_found(N + 1), converged(1, N + 1), restarted(1, N + 1), &
               n_fold, fold_step(8), fold_kind(8), fold_name(8, 8), fold_partner(8, 8), stat, i
    st%system = 'coupled_quartic'
    st%params = 0
    st%params(1:6) = [1.0_wp, 1.0_wp, 1.0_wp, 1.0_wp, OMG, EPS_C]
    st%lo = -2
    st%hi = 2
    st%n_grid = 41
    st%saddle = 'S1'
    call scan_table(st, 3, 0.1_wp, N, [0.01_wp], opts, value, n_eq, researched, eq_q, eq_energy, eq_index, &
                    eq_name, eq_det, saddle_found, saddle_q, saddle_energy, lambda, omega, period, action, &
                    stability, converged, restarted, n_fold, fold_step, fold_value, fold_width, fold_kind, fold_q, &
                    fold_name, fold_partner, stat)
    call check_eq('fold: status', stat, TUBES_OK)
    call check_true('fold: found', n_fold >= 1)
    do i = 1, min(n_fold, 8)
      call check_rel('fold: alpha_c = eps omega/(omega + eps)', fold_value(i), ALPHA_C, 1.0e-8_wp)
      call check_eq('fold: the wells meet the saddle', fold_kind(i), FOLD_MEET)
      call check_true('fold: between the steps on either side of it', value(fold_step(i) - 1) > ALPHA_C .and. &
                      value(fold_step(i)) < ALPHA_C)
    end do
    do i = 1, N + 1
      if (value(i) > ALPHA_C) then
        call check_eq('fold: three equilibria before it', n_eq(i), 3)
        det = (EPS_C - value(i))*(OMG + EPS_C) - EPS_C**2
        call check_rel('fold: lambda^2 omega^2 = -det Hess V(0)', (lambda(i)*omega(1, i))**2, -det, 1.0e-12_wp)
        call check_eq('fold: the orbit continued', converged(1, i), 1)
      else
        call check_eq('fold: one equilibrium after it', n_eq(i), 1)
        call check_eq('fold: no saddle after it', saddle_found(i), 0)
      end if
    end do
    call check_eq('fold: the first step continues the orbit in energy', restarted(1, 1), 1)
    call check_eq('fold: later steps correct the previous orbit', sum(restarted(1, 2:)), 0)
  end subroutine fold_case

  subroutine bad_arguments()
    type(study_t) :: st
    type(orbit_opts_t) :: opts
    integer :: stat
    st%system = 'coupled_quartic'
    st%params = 0
    st%params(1:6) = [1.0_wp, 1.0_wp, 1.0_wp, 1.0_wp, 1.0_wp, 0.1_wp]
    st%lo = -2
    st%hi = 2
    st%saddle = 'S1'
    call try(st, opts, 0, 0.5_wp, 2, stat)
    call check_eq('bad: parameter index 0', stat, TUBES_EINPUT)
    call try(st, opts, 3, 0.5_wp, 0, stat)
    call check_eq('bad: n = 0', stat, TUBES_EINPUT)
    call try(st, opts, 3, 1.0_wp, 2, stat)
    call check_eq('bad: to equal to the start', stat, TUBES_EINPUT)
    call try(st, opts, 1, -1.0_wp, 2, stat)
    call check_eq('bad: a mass the model refuses on the way', stat, TUBES_EINPUT)
    call try(st, opts, MAX_PARAMS + 1, 0.5_wp, 2, stat)
    call check_eq('bad: an index past the table', stat, TUBES_EINPUT)
    call try(st, opts, SCAN_CONSTANT + 1, 0.5_wp, 2, stat)
    call check_eq('bad: a formula constant of a built-in system', stat, TUBES_EINPUT)
  end subroutine bad_arguments

  subroutine p_trans_case()
    integer, parameter :: N = 4, NDE = 2
    real(wp), parameter :: DES(NDE) = [0.01_wp, 0.05_wp]
    type(study_t) :: st
    type(orbit_opts_t) :: opts
    type(section_choice_t) :: sec
    real(wp) :: value(N + 1), eq_q(MAX_DOF, SCAN_MAXEQ, N + 1), eq_energy(SCAN_MAXEQ, N + 1), &
                saddle_q(MAX_DOF, N + 1), saddle_energy(N + 1), lambda(N + 1), omega(MAX_DOF - 1, N + 1), &
                period(NDE, N + 1), action(NDE, N + 1), stability(NDE, N + 1), fold_value(8), fold_width(8), &
                fold_q(MAX_DOF, 8), a_tube(NDE, N + 1), a_e(NDE, N + 1), p(NDE, N + 1), short(NDE, N), closed
    integer :: n_eq(N + 1), researched(N + 1), eq_index(SCAN_MAXEQ, N + 1), eq_name(8, SCAN_MAXEQ, N + 1), &
               eq_det(SCAN_MAXEQ, N + 1), saddle_found(N + 1), converged(NDE, N + 1), restarted(NDE, N + 1), &
               n_fold, fold_step(8), fold_kind(8), fold_name(8, 8), fold_partner(8, 8), stat, p_stat(NDE, N + 1), &
               i, j
    real(wp) :: worst
    st%system = 'coupled_quartic'
    st%params = 0
    st%params(1:6) = [1.0_wp, 1.0_wp, 1.0_wp, 1.0_wp, 1.0_wp, 0.0_wp]   ! eps = 0: uncoupled
    st%lo = -2
    st%hi = 2
    st%n_grid = 41
    st%saddle = 'S1'
    sec = section_choice_t(kind=2, index=1, level=0.5_wp, dir=-1)   ! the plane x = 1/2, dx/dt < 0
    call scan_table(st, 3, 1.5_wp, N, DES, opts, value, n_eq, researched, eq_q, eq_energy, eq_index, &
                    eq_name, eq_det, saddle_found, saddle_q, saddle_energy, lambda, omega, period, action, &
                    stability, converged, restarted, n_fold, fold_step, fold_value, fold_width, fold_kind, fold_q, &
                    fold_name, fold_partner, stat, sec, tube_opts_t(kind=-1, area_tol=1.0e-8_wp), a_tube, a_e, p, &
                    p_stat)
    call check_eq('p_trans: status', stat, TUBES_OK)
    call check_true('p_trans: every cut', all(p_stat == TUBES_OK))
    worst = 0
    do i = 1, N + 1
      do j = 1, NDE
        closed = DES(j)/(DES(j) + value(i)/8 - 1.0_wp/64)
        worst = max(worst, abs(p(j, i)/closed - 1))
      end do
    end do
    call check_close('p_trans: dE/(dE + alpha/8 - beta/64), relative', worst, 0.0_wp, 1.0e-9_wp)
    call check_true('p_trans: A_tube/A_E', all(p == a_tube/a_e))
    call scan_table(st, 3, 1.5_wp, N, DES, opts, value, n_eq, researched, eq_q, eq_energy, eq_index, &
                    eq_name, eq_det, saddle_found, saddle_q, saddle_energy, lambda, omega, period, action, &
                    stability, converged, restarted, n_fold, fold_step, fold_value, fold_width, fold_kind, fold_q, &
                    fold_name, fold_partner, stat, sec, tube_opts_t(kind=-1), a_tube, a_e, short, p_stat)
    call check_eq('p_trans: arrays of another shape', stat, TUBES_EINPUT)
    call scan_table(st, 3, 1.5_wp, N, DES, opts, value, n_eq, researched, eq_q, eq_energy, eq_index, &
                    eq_name, eq_det, saddle_found, saddle_q, saddle_energy, lambda, omega, period, action, &
                    stability, converged, restarted, n_fold, fold_step, fold_value, fold_width, fold_kind, fold_q, &
                    fold_name, fold_partner, stat, p_trans=p)
    call check_eq('p_trans: without its section and areas', stat, TUBES_EINPUT)
  end subroutine p_trans_case

  !> got holds want's equilibria (the first size(want) of got, in want's order): the same names, and
  !> the same positions to 1e-12 cm (the Newton of another start: ~1e-14 cm, header). The checks are
  !> named what // ': names' // how and what // ': positions' // how // ' [cm]'.
  subroutine check_same_equilibria(what, how, got, want)
    character(*), intent(in) :: what, how
    type(equilibrium_t), intent(in) :: got(:), want(:)
    real(wp) :: dmax
    integer :: k
    call check_true(what // ': names' // how, all([(got(k)%name == want(k)%name, k = 1, size(want))]))
    dmax = 0
    do k = 1, size(want)
      dmax = max(dmax, maxval(abs(got(k)%q - want(k)%q)))
    end do
    call check_close(what // ': positions' // how // ' [cm]', dmax, 0.0_wp, 1.0e-12_wp)
  end subroutine check_same_equilibria

  !> scan_table of st with (ipar, to, n), dE = 0.01: its status.
  subroutine try(st, opts, ipar, to, n, stat)
      type(study_t), intent(in) :: st
      type(orbit_opts_t), intent(in) :: opts
      integer, intent(in) :: ipar, n
      real(wp), intent(in) :: to
      integer, intent(out) :: stat
      real(wp) :: value(3), eq_q(MAX_DOF, SCAN_MAXEQ, 3), eq_energy(SCAN_MAXEQ, 3), saddle_q(MAX_DOF, 3), &
                  saddle_energy(3), lambda(3), omega(MAX_DOF - 1, 3), period(1, 3), action(1, 3), &
                  stability(1, 3), fold_value(8), fold_width(8), fold_q(MAX_DOF, 8)
      integer :: n_eq(3), researched(3), eq_index(SCAN_MAXEQ, 3), eq_name(8, SCAN_MAXEQ, 3), &
                 eq_det(SCAN_MAXEQ, 3), saddle_found(3), converged(1, 3), restarted(1, 3), n_fold, fold_step(8), &
                 fold_kind(8), fold_name(8, 8), fold_partner(8, 8)
      call scan_table(st, ipar, to, n, [0.01_wp], opts, value, n_eq, researched, eq_q, eq_energy, eq_index, &
                      eq_name, eq_det, saddle_found, saddle_q, saddle_energy, lambda, omega, period, action, &
                      stability, converged, restarted, n_fold, fold_step, fold_value, fold_width, fold_kind, fold_q, &
                      fold_name, fold_partner, stat)
  end subroutine try
end program test_scan
