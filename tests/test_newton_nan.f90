!> The orbit correctors on a non-finite residual: a NaN must stop the Newton iteration as not
!> converged (Fortran's max() may drop a NaN: gfortran's max(0, NaN) is 0, and a residual norm
!> built from it read an all-NaN energy row as converged). A converged S12 Lyapunov orbit is
!> corrected again on a ball whose energy is NaN (its field and gradient are the ball's):
!> the other residual components are already below tol, so only the NaN decides.
module nan_ball_m
  use tubes_kinds, only: wp
  use tubes_ball, only: ball_t
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
  implicit none
  type, extends(ball_t) :: nan_ball_t
  contains
    procedure :: energy => nan_energy
  end type nan_ball_t
contains
  pure real(wp) function nan_energy(self, x)
    class(nan_ball_t), intent(in) :: self
    real(wp), intent(in) :: x(:)
    nan_energy = ieee_value(1.0_wp, ieee_quiet_nan)
  end function nan_energy
end module nan_ball_m

program test_newton_nan
  use tubes_kinds, only: wp
  use tubes_ball, only: ball_t, make_ball
  use tubes_fourwell, only: fourwell_t
  use tubes_equilibria, only: equilibrium_t, find_equilibria
  use tubes_orbits, only: orbit_t, orbit_opts_t, orbit_family, correct_symmetric, correct_multiple
  use tubes_status, only: TUBES_OK, TUBES_ENOCONV
  use tubes_check, only: check_eq, check_true, finish
  use nan_ball_m, only: nan_ball_t
  implicit none
  type(ball_t) :: ball
  type(nan_ball_t) :: nb
  type(equilibrium_t), allocatable :: eqs(:)
  type(orbit_opts_t) :: opts
  type(orbit_t) :: fam(1), orb
  real(wp) :: end_de, x0(4), tau, nodes(4, 1), period
  integer :: k, stat, isad, reason

  call make_ball(ball, fourwell_t(), 981.0_wp)
  call find_equilibria(ball, [-20.0_wp, -20.0_wp], [20.0_wp, 20.0_wp], 41, eqs, stat)
  isad = 0
  do k = 1, size(eqs)
    if (eqs(k)%name == 'S12') isad = k
  end do
  opts%n_samples = 201
  call orbit_family(ball, eqs, isad, [1.0_wp], opts, fam, end_de, reason, stat)
  call check_eq('the S12 orbit at dE = 1 converges on the ball', stat, TUBES_OK)
  nb%ball_t = ball

  ! the sane model first: the converged orbit is accepted again (the test's control)
  x0 = fam(1)%x0
  tau = fam(1)%period/2
  call correct_symmetric(ball, fam(1)%energy, 1.0_wp, x0, tau, opts, orb, stat)
  call check_eq('control: re-correcting the converged orbit on the ball', stat, TUBES_OK)
  call check_true('control: converged', orb%converged)

  x0 = fam(1)%x0
  tau = fam(1)%period/2
  call correct_symmetric(nb, fam(1)%energy, 1.0_wp, x0, tau, opts, orb, stat)
  call check_eq('single shooting, NaN energy row: not converged', stat, TUBES_ENOCONV)
  call check_true('single shooting, NaN energy row: converged flag false', .not. orb%converged)
  call check_true('single shooting, NaN energy row: the residual recorded is not finite', &
                  .not. (orb%history(size(orb%history)) <= huge(1.0_wp)))

  nodes(:, 1) = fam(1)%x0
  period = fam(1)%period
  call correct_multiple(ball, fam(1)%energy, 1.0_wp, nodes, period, opts, orb, stat)
  call check_eq('control: multiple shooting re-corrects the orbit on the ball', stat, TUBES_OK)
  nodes(:, 1) = fam(1)%x0
  period = fam(1)%period
  call correct_multiple(nb, fam(1)%energy, 1.0_wp, nodes, period, opts, orb, stat)
  call check_eq('multiple shooting, NaN energy row: not converged', stat, TUBES_ENOCONV)
  call check_true('multiple shooting, NaN energy row: converged flag false', .not. orb%converged)
  call finish('test_newton_nan')
end program test_newton_nan
