!> Lyapunov orbits of S12 against independent references: periodicity by a separate
!> integration, Floquet identities, single vs multiple shooting, the dE -> 0 limits (period ->
!> T_po linearly, MacKay's action/(T_po dE) -> 1 linearly, ln(mu)/T -> lambda), the action
!> against the integral of 2 (E - V), and the end of the family against E(R1) - E_e.
program test_orbits
  use tubes_kinds, only: wp
  use tubes_ball, only: ball_t, make_ball
  use tubes_fourwell, only: fourwell_t
  use tubes_equilibria, only: equilibrium_t, find_equilibria
  use tubes_orbits, only: orbit_t, orbit_opts_t, orbit_family, END_NONE
  use tubes_dop853, only: dop853_t
  use tubes_integrator, only: propagate
  use tubes_check, only: check_close, check_rel, check_true, check_eq, finish
  use tubes_test_models, only: PI
  implicit none
  type(ball_t) :: ball
  type(equilibrium_t), allocatable :: eqs(:)
  type(orbit_opts_t) :: single, multi
  type(orbit_t) :: os(5), om(5), oe(4)
  type(dop853_t) :: ig
  real(wp) :: des(5), end_de, t_po, lam, x(4), e, r1, r2, slope1, slope2, a_int, de_r1, d
  integer :: k, j, stat, isad, ir1, reason
  character(80) :: lbl

  call make_ball(ball, fourwell_t(), 981.0_wp)
  call find_equilibria(ball, [-20.0_wp, -20.0_wp], [20.0_wp, 20.0_wp], 41, eqs, stat)
  isad = 0; ir1 = 0
  do k = 1, size(eqs)
    if (eqs(k)%name == 'S12') isad = k
    if (eqs(k)%morse == 2) ir1 = k
  end do
  t_po = 2*PI/eqs(isad)%omega
  lam = eqs(isad)%lambda
  des = [0.01_wp, 0.02_wp, 1.0_wp, 10.0_wp, 100.0_wp]
  single%n_samples = 2001
  multi = single
  multi%n_segments = 6
  call orbit_family(ball, eqs, isad, des, single, os, end_de, reason, stat)
  call check_eq('single shooting family: status', stat, 0)
  call check_eq('single shooting family: no end below dE = 100', reason, END_NONE)
  call orbit_family(ball, eqs, isad, des, multi, om, end_de, reason, stat)
  call check_eq('multiple shooting family: status', stat, 0)

  do k = 1, 5
    write (lbl, '(a,es8.1)') 'dE =', des(k)
    call check_true('converged (single), '//trim(lbl), os(k)%converged)
    call check_true('converged (multiple), '//trim(lbl), om(k)%converged)
    ! corrector residual: the tolerance (1e-11), or its noise-floor acceptance 100 tol
    call check_true('residual <= 1e-10 (single), '//trim(lbl), os(k)%residual <= 1.0e-10_wp)
    call check_true('residual <= 1e-10 (multiple), '//trim(lbl), om(k)%residual <= 1.0e-10_wp)
    ! energy of the initial state, evaluated independently of the corrector's equations
    call check_rel('H(state0) = E (single), '//trim(lbl), ball%energy(os(k)%x0), os(k)%energy, 1.0e-10_wp)
    call check_rel('H(state0) = E (multiple), '//trim(lbl), ball%energy(om(k)%x0), om(k)%energy, 1.0e-10_wp)
    ! periods of the two methods: both at residual 1e-11 with dT/dx ~ 1/|v| ~ 1e-2: 1e-9
    call check_close('period: single = multiple, '//trim(lbl), os(k)%period, om(k)%period, 1.0e-9_wp)
    ! periodicity by a separate integration at tighter tolerance: the closure error is the
    ! residual amplified by at most mu_u (~1e3) plus integration error 1e-14 mu_u |x|
    call ig%init(ball, 0.0_wp)
    ig%rtol = 1.0e-14_wp
    ig%atol = 1.0e-14_wp
    x = om(k)%x0
    call propagate(ig, x, om(k)%period, stat)
    call check_true('periodic by an independent integration, '//trim(lbl), &
                    maxval(abs(x - om(k)%x0)) <= om(k)%mu_unstable*(1.0e-11_wp + 1.0e-14_wp*20))
    ! Floquet: mu_u mu_s = 1; relative error of mu_s ~ delta mu_u^2 with delta ~ 1e-13
    call check_close('mu_unstable * mu_stable = 1, '//trim(lbl), os(k)%mu_unstable*os(k)%mu_stable, &
                     1.0_wp, 1.0e-13_wp*os(k)%mu_unstable**2)
    ! trivial pair: a Jordan block, perturbed by ~sqrt(delta mu_u)
    do j = 1, 2
      call check_close('trivial multiplier = 1, '//trim(lbl), os(k)%mu_trivial(j), 1.0_wp, &
                       10*sqrt(1.0e-13_wp*os(k)%mu_unstable))
    end do
    ! action = integral of p.dq/dt = integral of 2 T = integral of 2 (E - V): Simpson's rule
    ! on the 2001 samples (error ~ (T/2000)^4 |d4 V| T ~ 1e-9 of the action)
    a_int = 0
    do j = 1, 2001
      e = 2*(os(k)%energy - ball%potential_xy(os(k)%x(1, j), os(k)%x(2, j)))
      if (j == 1 .or. j == 2001) then
        a_int = a_int + e
      else if (mod(j, 2) == 0) then
        a_int = a_int + 4*e
      else
        a_int = a_int + 2*e
      end if
    end do
    a_int = a_int*(os(k)%period/2000)/3
    call check_rel('action = integral of 2 (E - V) dt, '//trim(lbl), os(k)%action, a_int, 1.0e-7_wp)
  end do
  ! dE -> 0 limits (T_po = 2 pi/omega, lambda from the linearisation, MacKay 1990)
  r1 = (os(1)%period - t_po)/des(1)
  r2 = (os(2)%period - t_po)/des(2)
  call check_rel('period -> T_po linearly: (T - T_po)/dE the same at dE = 0.01, 0.02', r1, r2, 0.05_wp)
  ! Richardson extrapolation to dE = 0 cancels the linear term: what is left is the quadratic
  ! term 2e-4 b (b = d2T/dE2 / 2, ~1e-7 from the measured curvature) and the corrector noise on
  ! the period (~1e-11 / |v| ~ 1e-11 s): allow 1e-9 s
  call check_close('period extrapolated to dE = 0 is T_po', 2*os(1)%period - os(2)%period, t_po, 1.0e-9_wp)
  slope1 = (os(1)%action/(t_po*des(1)) - 1)/des(1)
  slope2 = (os(2)%action/(t_po*des(2)) - 1)/des(2)
  call check_rel('action/(T_po dE) -> 1 at dE = 0.01', os(1)%action/(t_po*des(1)), 1.0_wp, 1.0e-5_wp)
  call check_rel('action/(T_po dE) - 1 shrinks linearly in dE', slope1, slope2, 0.05_wp)
  call check_rel('ln(mu_u)/T -> lambda at dE = 0.01', log(os(1)%mu_unstable)/os(1)%period, lam, 1.0e-5_wp)
  ! the end of the family: the inner turning point runs into the rank-2 saddle R1, so the
  ! family ends at E(R1) - E_e; past it an orbit is refused (not converged) and the end is
  ! reported. The estimate extrapolates T ~ a - b ln(L - dE): allow 1e-4 relative.
  de_r1 = eqs(ir1)%energy - eqs(isad)%energy
  call orbit_family(ball, eqs, isad, [100.0_wp, 700.0_wp, 770.0_wp, 800.0_wp], single, oe, end_de, &
                    reason, stat)
  call check_true('orbits below the end converge', oe(1)%converged .and. oe(2)%converged .and. oe(3)%converged)
  call check_true('dE = 800 past the end is refused', .not. oe(4)%converged)
  call check_true('an end is reported', reason /= END_NONE)
  call check_rel('family end = E(R1) - E_e', end_de, de_r1, 1.0e-4_wp)
  d = oe(3)%min_eq_distance
  call check_true('approach to R1 shrinks towards the end', d < oe(2)%min_eq_distance .and. &
                  oe(2)%min_eq_distance < oe(1)%min_eq_distance)
  call finish('test_orbits')
end program test_orbits
