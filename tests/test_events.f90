!> Test models for test_events: the harmonic oscillator x'' = -x (state (x, v)), free fall
!> x'' = -1 (its solution is a quadratic, which DOP853 and its dense output reproduce exactly),
!> the 2-D isotropic oscillator in canonical form (x, y, px, py) (p_theta conserved), and a
!> tilted plane H = a x for the rolling ball (p = (7/5) M v with M /= I, quadratic motion).
module test_events_models
  use tubes_kinds, only: wp
  use tubes_test_models, only: oscillator_t, rotate, fall_field, iso_field
  use tubes_surface, only: surface_t
  implicit none
  private
  public :: oscillator_t, fall_field, iso_field, tilt_t, rotate

  !> The plane z = a x: gradient (a, 0), no curvature.
  type, extends(surface_t) :: tilt_t
    real(wp) :: a = 1   !! slope [1]
  contains
    procedure :: height => tilt_height, derivs => tilt_derivs, third => tilt_third
  end type tilt_t

contains

  pure function tilt_height(self, x, y) result(h)
    class(tilt_t), intent(in) :: self
    real(wp), intent(in) :: x, y
    real(wp) :: h
    h = self%a*x
  end function tilt_height

  pure subroutine tilt_derivs(self, x, y, grad, hess)
    class(tilt_t), intent(in) :: self
    real(wp), intent(in) :: x, y
    real(wp), intent(out) :: grad(2), hess(2, 2)
    grad = [self%a, 0.0_wp]
    hess = 0
  end subroutine tilt_derivs

  pure subroutine tilt_third(self, x, y, t3)
    class(tilt_t), intent(in) :: self
    real(wp), intent(in) :: x, y
    real(wp), intent(out) :: t3(2, 2, 2)
    t3 = 0
  end subroutine tilt_third

end module test_events_models

!> Events on dense output (tubes_integrator: propagate, crossing_log_t) and the sections of
!> tubes_section_events (theta_line_t, x_line/y_line, polar_canonical), against analytic crossings.
program test_events
  use tubes_kinds, only: wp
  use tubes_status, only: TUBES_OK, TUBES_EVENT, TUBES_EINPUT, TUBES_EMAXSTEPS
  use tubes_integrator, only: propagate, event_t, plane_t, crossing_log_t, T_RTOL, T_ATOL
  use tubes_dop853, only: dop853_t
  use tubes_ball, only: ball_t, make_ball
  use tubes_section_events, only: theta_line_t, polar_canonical, u1_section, x_line, y_line, &
                            U1_MINUS, U1_PLUS
  use tubes_check, only: check_close, check_rel, check_true, check_eq, finish
  use test_events_models, only: oscillator_t, fall_field, iso_field, tilt_t, rotate
  use tubes_test_models, only: PI, EPS, oscillator_start
  implicit none

  real(wp), parameter :: C_LEVEL = 0.3_wp        ! oscillator level: x = cos t = 0.3
  ! Fixed step of the long runs (exact in binary: the step ends t0 + k h are exact)
  real(wp), parameter :: H_FIX = 0.0625_wp
  type(dop853_t) :: ig
  type(crossing_log_t) :: log
  type(ball_t) :: ball
  real(wp) :: x(2), z(4), x10(2), ta(64), tol, err_glob, t1, t2, s, dense_err, xs(2)
  real(wp) :: pc(4), v(2), th_dot, p_exact(2), dq(2), hfd, tref
  integer :: da(64), stat, k, na, i, nf0, ns0
  logical :: ok
  character(96) :: lbl

  ! === 1. many crossings in one propagate (non-terminal, both directions) ==================
  ! x = cos t crosses 0.3 falling at acos(0.3) + 2 pi k and rising at 2 pi - acos(0.3) + 2 pi k.
  ! Fixed h = 1/16 to t = 100 (1600 steps). Budget for an event time: (state error at the
  ! crossing + dense-output error) / |dx/dt| (= 0.954) + refinement bracket
  ! (max(4 eps t, 1e-15) <= 9e-14). From test_dop853's h^8 law (5.9e-11 at h = 0.3125,
  ! t = 10) truncation is 1.5e-15 at t = 100; roundoff of 1600 steps of a few ulps adds
  ! <~ 1e-13 (the global error at t = 100 is printed and checked against 3e-13 below), so
  ! 1e-12, the required accuracy, holds with a margin of ~5.
  na = 0
  do k = 0, 20
    if (acos(C_LEVEL) + 2*PI*k < 100) call add(acos(C_LEVEL) + 2*PI*k, -1)
    if (2*PI - acos(C_LEVEL) + 2*PI*k < 100) call add(2*PI - acos(C_LEVEL) + 2*PI*k, 1)
  end do
  call oscillator_start(ig, x, H_FIX)
  call propagate(ig, x, 100.0_wp, stat, event=plane_t(k=1, c=C_LEVEL, terminal=.false.), &
                 crossings=log)
  err_glob = norm2(x - rotate([1.0_wp, 0.0_wp], 100.0_wp))
  write (*, '(a,es10.3,a,i0,a)') '     oscillator h = 1/16: global error at t = 100 ', err_glob, &
    ', ', log%n, ' crossings'
  call check_eq('long run: status TUBES_OK (non-terminal)', stat, TUBES_OK)
  call check_true('long run: global error at t = 100 < 3e-13 (budget above)', err_glob < 3.0e-13_wp)
  call check_eq('long run: every crossing found once (32 in [0, 100])', log%n, na)
  call compare_log('long run', 1.0e-12_wp)
  ok = .true.
  do i = 1, min(log%n, na)
    ! the state there: x = c and v = -sin(t); same budget as the time (|dx/dt| <= 1)
    ok = ok .and. abs(log%x(1, i) - C_LEVEL) <= 1.0e-12_wp
    ok = ok .and. abs(log%x(2, i) + sin(log%t(i))) <= 1.0e-12_wp
  end do
  call check_true('long run: states at the crossings x = 0.3, v = -sin t (1e-12)', ok)

  ! direction filter on the same run: only the falling ones, only the rising ones
  do k = -1, 1, 2
    call log%clear()
    call oscillator_start(ig, x, H_FIX)
    call propagate(ig, x, 100.0_wp, stat, event=plane_t(k=1, c=C_LEVEL, direction=k, &
                   terminal=.false.), crossings=log)
    write (lbl, '(a,i0,a)') 'long run, direction = ', k, ': only those crossings, all found'
    call check_true(trim(lbl), log%n == count(da(1:na) == k) .and. all(log%direction(1:log%n) == k))
  end do

  ! === 2. terminal events and restarts =====================================================
  ! Each call stops at the next crossing and a restart from it finds the following one,
  ! never the one it starts on; a log passed to every call ends with each crossing once.
  ! Budget as in 1 (the run is shorter).
  call log%clear()
  call oscillator_start(ig, x, H_FIX)
  ok = .true.
  do k = 1, 8
    call propagate(ig, x, 100.0_wp, stat, event=plane_t(k=1, c=C_LEVEL), crossings=log)
    ok = ok .and. stat == TUBES_EVENT .and. abs(ig%t - ta(k)) <= 1.0e-12_wp
    ok = ok .and. abs(x(1) - C_LEVEL) <= 1.0e-12_wp
  end do
  call check_true('terminal, direction 0: 8 calls stop at the first 8 crossings in turn', ok)
  call check_eq('terminal: the log holds each of the 8 crossings once', log%n, 8)
  call check_true('terminal: logged times equal the stops', &
                  all(abs(log%t(1:8) - ta(1:8)) <= 1.0e-12_wp) .and. all(log%direction(1:8) == da(1:8)))
  ! falling only, adaptive (rtol = atol = 1e-12): the bound of test_dop853 section 6,
  ! 4 (N + 1) tol for N accepted steps so far (no amplification in the rotation)
  call oscillator_start(ig, x, 0.0_wp)   ! init keeps h: back to the adaptive mode
  do k = 0, 3
    call propagate(ig, x, 100.0_wp, stat, event=plane_t(k=1, c=C_LEVEL, direction=-1))
    write (lbl, '(a,i0)') 'adaptive restart: falling crossing acos(0.3) + 2 pi k, k = ', k
    call check_close(trim(lbl), ig%t, acos(C_LEVEL) + 2*PI*k, 4*(ig%nsteps + 1)*ig%rtol)
  end do
  ! after a terminal stop, a propagate without the event continues normally
  call propagate(ig, x, 30.0_wp, stat)
  call check_close('continue without the event: x(30) = cos 30', x(1), cos(30.0_wp), &
                   4*(ig%nsteps + 1)*ig%rtol)

  ! === 3. two crossings inside one step ====================================================
  ! (a) free fall x = 0.5 t - t^2/2 with one step of h = 1: the level 0.1 is crossed at
  ! 0.5 -+ sqrt(0.05) (0.276, 0.724; apex 0.125 at 0.5), both inside [0, 1] and in different
  ! fifths (nsub = 4). The solution is a quadratic, so the step and the dense output are
  ! exact up to roundoff: time error <= bracket (1e-15) + interpolant roundoff (~10 eps |x|
  ! / |dx/dt| = 1.2e-15); 1e-14 leaves a factor 4.
  t1 = 0.5_wp - sqrt(0.05_wp)
  t2 = 0.5_wp + sqrt(0.05_wp)
  call log%clear()
  call ig%init(fall_field(), t0=0.0_wp)
  ig%h = 1
  x = [0.0_wp, 0.5_wp]
  call propagate(ig, x, 1.0_wp, stat, event=plane_t(k=1, c=0.1_wp, terminal=.false.), crossings=log)
  call check_eq('two in one step (fall): one step taken', int(ig%nsteps), 1)
  call check_eq('two in one step (fall): both crossings found', log%n, 2)
  if (log%n == 2) then
    call check_close('two in one step (fall): first (rising) time', log%t(1), t1, 1.0e-14_wp)
    call check_close('two in one step (fall): second (falling) time', log%t(2), t2, 1.0e-14_wp)
    call check_true('two in one step (fall): in order, rising then falling', &
                    log%t(1) < log%t(2) .and. log%direction(1) == 1 .and. log%direction(2) == -1)
  end if
  ! with the step ends only (nsub = 0) g < 0 at both ends: neither is seen
  call log%clear()
  call ig%init(fall_field(), t0=0.0_wp)
  ig%h = 1
  x = [0.0_wp, 0.5_wp]
  call propagate(ig, x, 1.0_wp, stat, event=plane_t(k=1, c=0.1_wp, terminal=.false., nsub=0), &
                 crossings=log)
  call check_eq('two in one step (fall), nsub = 0: none seen (ends only)', log%n, 0)
  ! terminal: the earlier one stops the call, the restart finds the later one
  call ig%init(fall_field(), t0=0.0_wp)
  ig%h = 1
  x = [0.0_wp, 0.5_wp]
  call propagate(ig, x, 1.0_wp, stat, event=plane_t(k=1, c=0.1_wp))
  call check_eq('two in one step, terminal: status', stat, TUBES_EVENT)
  call check_close('two in one step, terminal: stops at the earlier', ig%t, t1, 1.0e-14_wp)
  call propagate(ig, x, 1.0_wp, stat, event=plane_t(k=1, c=0.1_wp))
  call check_eq('two in one step, terminal restart: status', stat, TUBES_EVENT)
  call check_close('two in one step, terminal restart: finds the later', ig%t, t2, 1.0e-14_wp)

  ! (b) oscillator x = cos(t - 1/4), one step of h = 1/2 (8% of the period), level cos(0.2)
  ! near the maximum: crossings at 0.05 (rising) and 0.45 (falling). The interpolant is not
  ! exact here: the time error is (dense-output error)/|dx/dt| to first order, with
  ! |dx/dt| = sin(0.2) at both. The dense-output error of this very step is measured
  ! against cos(s - 1/4) at 101 points; tolerance twice that / sin(0.2) (linearisation)
  ! plus the bracket.
  call ig%init(oscillator_t(), t0=0.0_wp)
  ig%h = 0.5_wp
  x = [cos(0.25_wp), sin(0.25_wp)]
  call propagate(ig, x, 0.5_wp, stat)
  dense_err = 0
  do i = 0, 100
    s = 0.005_wp*i
    call ig%interp(s, xs)
    dense_err = max(dense_err, abs(xs(1) - cos(s - 0.25_wp)))
  end do
  tol = 2*dense_err/sin(0.2_wp) + 1.0e-15_wp
  write (*, '(a,es10.3,a,es10.3)') '     oscillator h = 0.5: dense-output error ', dense_err, &
    ', event-time tolerance ', tol
  call run_one_step(cos(0.2_wp), 4)
  call check_eq('two in one step (oscillator): both found', log%n, 2)
  if (log%n == 2) then
    call check_close('two in one step (oscillator): t = 0.05', log%t(1), 0.05_wp, tol)
    call check_close('two in one step (oscillator): t = 0.45', log%t(2), 0.45_wp, tol)
    call check_true('two in one step (oscillator): rising then falling', &
                    log%direction(1) == 1 .and. log%direction(2) == -1)
  end if
  ! (c) the documented failure mode (docs/events.md): two crossings inside one sampling
  ! interval h/(nsub+1) are both missed. Level cos(0.03): crossings at 0.22 and 0.28, both
  ! in the fifth [0.2, 0.3] (nsub = 4: missed), in different tenths with nsub = 9 (found).
  call run_one_step(cos(0.03_wp), 4)
  call check_eq('known limitation: two crossings 0.06 apart in one 0.1 interval missed', log%n, 0)
  call run_one_step(cos(0.03_wp), 9)
  call check_eq('... and found with nsub = 9 (intervals of 0.05)', log%n, 2)
  if (log%n == 2) then
    call check_close('nsub = 9: t = 0.22', log%t(1), 0.22_wp, 2*dense_err/sin(0.03_wp) + 1.0e-15_wp)
    call check_close('nsub = 9: t = 0.28', log%t(2), 0.28_wp, 2*dense_err/sin(0.03_wp) + 1.0e-15_wp)
  end if

  ! === 4. a root exactly at a step end belongs to one step only ============================
  ! Fixed h = 0.1 from (1, 0) towards t = 2: the state after 10 steps is taken from a run
  ! stopped by max_steps = 10; the same steps with the level c = x(1) there have g = 0
  ! exactly at that step end (the end of step 10 and the start of step 11).
  call oscillator_start(ig, x, 0.1_wp, 10)
  call propagate(ig, x, 2.0_wp, stat)
  call check_eq('step-end root: setup run stopped by max_steps', stat, TUBES_EMAXSTEPS)
  x10 = x
  tref = ig%t
  call log%clear()
  call oscillator_start(ig, x, 0.1_wp)
  call propagate(ig, x, 2.0_wp, stat, event=plane_t(k=1, c=x10(1), terminal=.false.), crossings=log)
  call check_eq('step-end root: recorded once', log%n, 1)
  if (log%n >= 1) then
    call check_true('step-end root: at the step end exactly, falling', &
                    log%t(1) == tref .and. log%direction(1) == -1 .and. all(log%x(:, 1) == x10))
  end if
  ! terminal at that root, then restart: the restart does not stop on it again
  call oscillator_start(ig, x, 0.1_wp)
  call propagate(ig, x, 2.0_wp, stat, event=plane_t(k=1, c=x10(1)))
  call check_true('step-end root, terminal: stops there', stat == TUBES_EVENT .and. ig%t == tref)
  call propagate(ig, x, 2.0_wp, stat, event=plane_t(k=1, c=x10(1)))
  call check_true('step-end root, restart: runs on to t = 2', stat == TUBES_OK .and. ig%t == 2.0_wp)
  ig%max_steps = 10000000   ! init keeps the budget: restore the default

  ! === 5. theta_line_t on the isotropic oscillator =========================================
  ! q = q0 cos t + p0 sin t, q0 = (1, 0), p0 = (0.3, 0.8): p_theta = 0.8 (conserved). The line
  ! theta = pi/4 is crossed when tan t = 2: at atan 2 + 2 pi k on the ray r > 0 (x + y > 0),
  ! at atan 2 + pi + 2 pi k on the opposite ray. Fixed h = 1/16 to t = 60: the budget of
  ! section 1 (|dg/dt| = 2.5/sqrt(10) = 0.79 at the crossings).
  na = 0
  do k = 0, 9
    call add(atan(2.0_wp) + 2*PI*k, 1)
  end do
  call run_iso([1.0_wp, 0.0_wp, 0.3_wp, 0.8_wp], theta_line_t(theta0=PI/4, terminal=.false.))
  call check_eq('theta = pi/4, p_theta = 0.8: 10 crossings of the ray r > 0 in [0, 60]', log%n, 10)
  call compare_log('theta = pi/4 (isotropic)', 1.0e-12_wp)
  ok = log%n > 0
  do i = 1, log%n
    pc = polar_canonical(log%x(:, i))
    ok = ok .and. abs(pc(4) - 0.8_wp) <= 1.0e-12_wp .and. abs(pc(2) - PI/4) <= 1.0e-12_wp/pc(1)
  end do
  call check_true('theta = pi/4: p_theta = 0.8 and theta = pi/4 at every crossing (1e-12)', ok)
  call run_iso([1.0_wp, 0.0_wp, 0.3_wp, 0.8_wp], theta_line_t(theta0=PI/4, branch=-1, terminal=.false.))
  call check_eq('theta = pi/4, branch -1 with p_theta > 0: none', log%n, 0)
  call run_iso([1.0_wp, 0.0_wp, 0.3_wp, 0.8_wp], u1_section(U1_MINUS, terminal=.false.))
  call check_eq('U1^- (p_theta > 0 branch): all 10', log%n, 10)
  call run_iso([1.0_wp, 0.0_wp, 0.3_wp, 0.8_wp], u1_section(U1_PLUS, terminal=.false.))
  call check_eq('U1^+ (p_theta < 0 branch): none', log%n, 0)
  ! the opposite ray is the ray theta = 5 pi/4: exactly the 9 crossings excluded above
  na = 0
  do k = 0, 8
    call add(atan(2.0_wp) + PI + 2*PI*k, 1)
  end do
  call run_iso([1.0_wp, 0.0_wp, 0.3_wp, 0.8_wp], theta_line_t(theta0=1.25_wp*PI, terminal=.false.))
  call check_eq('theta = 5 pi/4: the 9 opposite-ray crossings', log%n, 9)
  call compare_log('theta = 5 pi/4 (isotropic)', 1.0e-12_wp)
  ! p_theta = -0.8: q0 = (1, 0), p0 = (-0.3, -0.8); tan t = -2, on the ray r > 0 at
  ! 2 pi - atan 2 + 2 pi k, reported -1
  na = 0
  do k = 0, 8
    call add(2*PI - atan(2.0_wp) + 2*PI*k, -1)
  end do
  call run_iso([1.0_wp, 0.0_wp, -0.3_wp, -0.8_wp], theta_line_t(theta0=PI/4, branch=-1, terminal=.false.))
  call check_eq('theta = pi/4, p_theta = -0.8, branch -1: 9 crossings', log%n, 9)
  call compare_log('theta = pi/4, p_theta < 0', 1.0e-12_wp)
  call run_iso([1.0_wp, 0.0_wp, -0.3_wp, -0.8_wp], u1_section(U1_MINUS, terminal=.false.))
  call check_eq('U1^- with p_theta < 0: none', log%n, 0)
  ! terminal U1^-: each call stops at the next crossing of the ray
  call ig%init(iso_field(), t0=0.0_wp)
  ig%h = H_FIX
  z = [1.0_wp, 0.0_wp, 0.3_wp, 0.8_wp]
  ok = .true.
  do k = 0, 3
    call propagate(ig, z, 60.0_wp, stat, event=u1_section(U1_MINUS))
    ok = ok .and. stat == TUBES_EVENT .and. abs(ig%t - (atan(2.0_wp) + 2*PI*k)) <= 1.0e-12_wp
  end do
  call check_true('terminal U1^-: stops at atan 2 + 2 pi k, k = 0..3, in turn', ok)

  ! === 6. p_theta orientation differs from dtheta/dt: ball on a tilted plane ===============
  ! H = x, g = 2 cm/s^2: M = diag(2, 1), px' = -g, py' = 0, so vx = 3 - (5/7) t, vy = 2 from
  ! q0 = (1, 1.5), v0 = (3, 2) (p0 = (7/5) M v0 = (8.4, 2.8)). y - x = 0.5 - t + (5/14) t^2
  ! vanishes at t = 1.4 (1 -+ sqrt(2/7)), both with x > 0. At the first, dtheta/dt < 0 and
  ! p_theta < 0; at the second dtheta/dt > 0 (vy > vx) but p_theta = x (py - px) < 0
  ! (px = (7/5) 2 vx > py). The motion is quadratic: exact up to roundoff. Fixed h = 0.25
  ! (12 steps to t = 3): a few ulps of |x| <= 10 per step, over |dg/dt| >= 0.38: 1e-13.
  call make_ball(ball, tilt_t(a=1.0_wp), 2.0_wp)
  p_exact = ball%momentum([1.0_wp, 1.5_wp], [3.0_wp, 2.0_wp])
  call check_true('tilted plane: p0 = (7/5) M v0 = (8.4, 2.8)', &
                  abs(p_exact(1) - 8.4_wp) <= 8*EPS*8.4_wp .and. abs(p_exact(2) - 2.8_wp) <= 8*EPS*2.8_wp)
  t1 = 1.4_wp*(1 - sqrt(2.0_wp/7))
  t2 = 1.4_wp*(1 + sqrt(2.0_wp/7))
  call run_ball(theta_line_t(theta0=PI/4, terminal=.false.))
  call check_eq('tilted plane: 2 crossings of theta = pi/4', log%n, 2)
  if (log%n == 2) then
    call check_close('tilted plane: first crossing time', log%t(1), t1, 1.0e-13_wp)
    call check_close('tilted plane: second crossing time', log%t(2), t2, 1.0e-13_wp)
    call check_true('tilted plane: both reported as p_theta < 0 (-1)', all(log%direction(1:2) == -1))
    ! at the second: dtheta/dt = (x vy - y vx)/r^2 > 0 while p_theta < 0
    v = ball%velocity(log%x(:, 2))
    th_dot = log%x(1, 2)*v(2) - log%x(2, 2)*v(1)
    pc = polar_canonical(log%x(:, 2))
    call check_true('tilted plane, second crossing: dtheta/dt > 0 but p_theta < 0', &
                    th_dot > 0 .and. pc(4) < 0)
    ! p_theta = s (py - px) with s = x = y, px = 8.4 - 2 t, py = 2.8; p_r = sqrt(2) s (px + py)/(2 s)
    do i = 1, 2
      s = 1 + 3*log%t(i) - (5.0_wp/14)*log%t(i)**2
      pc = polar_canonical(log%x(:, i))
      write (lbl, '(a,i0)') 'tilted plane: p_theta = s (py - px) at crossing ', i
      call check_close(trim(lbl), pc(4), s*(2.8_wp - (8.4_wp - 2*log%t(i))), 1.0e-12_wp)
      write (lbl, '(a,i0)') 'tilted plane: p_r = (px + py)/sqrt(2) at crossing ', i
      call check_close(trim(lbl), pc(3), (8.4_wp - 2*log%t(i) + 2.8_wp)/sqrt(2.0_wp), 1.0e-12_wp)
    end do
  end if
  call run_ball(theta_line_t(theta0=PI/4, branch=1, terminal=.false.))
  call check_eq('tilted plane, branch +1 (p_theta > 0): none', log%n, 0)
  call run_ball(theta_line_t(theta0=PI/4, branch=-1, terminal=.false.))
  call check_eq('tilted plane, branch -1 (p_theta < 0): both', log%n, 2)
  ! the dg/dt filter selects the other notion: direction = +1 keeps only the second
  call run_ball(theta_line_t(theta0=PI/4, direction=1, terminal=.false.))
  call check_true('tilted plane, direction = +1 (dtheta/dt > 0): only the second, reported -1', &
                  log%n == 1 .and. abs(log%t(1) - t2) <= 1.0e-13_wp .and. log%direction(1) == -1)
  ! coordinate lines: y = 1.5 + 2 t reaches 3.5 at t = 1; x = 1 + 3 t - (5/14) t^2 rises on
  ! [0, 3] (its maximum is at t = 4.2) and reaches 2 at t = 1.4 (3 - sqrt(9 - 10/7))
  call run_ball(y_line(3.5_wp, terminal=.false.))
  call check_true('y_line(3.5): one rising crossing at t = 1', &
                  log%n == 1 .and. abs(log%t(1) - 1) <= 1.0e-13_wp .and. log%direction(1) == 1)
  call run_ball(x_line(2.0_wp, direction=-1, terminal=.false.))
  call check_eq('x_line(2, falling): none (x rises on [0, 3])', log%n, 0)
  call run_ball(x_line(2.0_wp, direction=1, terminal=.false.))
  call check_true('x_line(2, rising): at the root of 1 + 3t - (5/14)t^2 = 2', log%n == 1 .and. &
                  abs(log%t(1) - 1.4_wp*(3 - sqrt(9 - 10.0_wp/7))) <= 1.0e-13_wp)

  ! === 7. polar canonical coordinates against their definitions ============================
  ! For q = r (cos theta, sin theta) the canonical momenta are p_r = p . dq/dr and
  ! p_theta = p . dq/dtheta (point transformation). dq/dr, dq/dtheta here by central
  ! differences of that map, step 1e-4: truncation (hfd^2/6)|d^3 q| <= 2e-9 r (theta),
  ! 0 (r, linear), roundoff ~eps r/hfd = 2e-12 r: tolerance 1e-8 (|p| r <= 10).
  ! Kinetic energy of the flat ball (5/14)|p|^2 = (5/14)(p_r^2 + p_theta^2/r^2): a few eps.
  ok = .true.
  hfd = 1.0e-4_wp
  do i = 1, 8
    z = [cos(1.3_wp*i)*(0.5_wp + i), sin(0.7_wp*i)*3, 2*cos(2.1_wp*i), sin(1.9_wp*i) - 0.3_wp]
    pc = polar_canonical(z)
    ok = ok .and. abs(pc(1)*cos(pc(2)) - z(1)) <= 4*EPS*pc(1) .and. abs(pc(1)*sin(pc(2)) - z(2)) <= 4*EPS*pc(1)
    dq = (polar_q(pc(1) + hfd, pc(2)) - polar_q(pc(1) - hfd, pc(2)))/(2*hfd)
    ok = ok .and. abs(pc(3) - dot_product(z(3:4), dq)) <= 1.0e-8_wp
    dq = (polar_q(pc(1), pc(2) + hfd) - polar_q(pc(1), pc(2) - hfd))/(2*hfd)
    ok = ok .and. abs(pc(4) - dot_product(z(3:4), dq)) <= 1.0e-8_wp
    ok = ok .and. abs(z(3)**2 + z(4)**2 - pc(3)**2 - (pc(4)/pc(1))**2) <= 16*EPS*(z(3)**2 + z(4)**2)
  end do
  call check_true('polar: r, theta give q; p_r = p.dq/dr, p_theta = p.dq/dtheta; |p|^2 kept', ok)
  pc = polar_canonical([0.0_wp, 0.0_wp, 1.0_wp, 2.0_wp])
  call check_true('polar at r = 0: p_r is NaN (undefined), p_theta = 0', &
                  .not. (pc(3) == pc(3)) .and. pc(4) == 0)

  ! === 8. max_crossings, backward integration, inputs, cost ================================
  na = 0
  do k = 0, 20
    if (acos(C_LEVEL) + 2*PI*k < 100) call add(acos(C_LEVEL) + 2*PI*k, -1)
    if (2*PI - acos(C_LEVEL) + 2*PI*k < 100) call add(2*PI - acos(C_LEVEL) + 2*PI*k, 1)
  end do
  call log%clear()
  log%max_crossings = 3
  call oscillator_start(ig, x, H_FIX)
  call propagate(ig, x, 100.0_wp, stat, event=plane_t(k=1, c=C_LEVEL, terminal=.false.), crossings=log)
  call check_true('max_crossings = 3: stops (TUBES_EVENT) at the third crossing', &
                  stat == TUBES_EVENT .and. log%n == 3 .and. ig%t == log%t(3) .and. &
                  abs(ig%t - ta(3)) <= 1.0e-12_wp)
  call propagate(ig, x, 100.0_wp, stat, event=plane_t(k=1, c=C_LEVEL, terminal=.false.), crossings=log)
  call check_eq('max_crossings: a full log is refused', stat, TUBES_EINPUT)
  call log%clear()
  call propagate(ig, x, 100.0_wp, stat, event=plane_t(k=1, c=C_LEVEL, terminal=.false.), crossings=log)
  call check_true('max_crossings: after clear, the next three (4..6), none repeated', &
                  stat == TUBES_EVENT .and. log%n == 3 .and. all(abs(log%t(1:3) - ta(4:6)) <= 1.0e-12_wp))
  log%max_crossings = 1000000
  ! backward from t = 0 to -20: x = cos t crosses 0.3 at -acos(0.3) - 2 pi k (dx/dt > 0 there:
  ! rising in time) and at acos(0.3) - 2 pi (k + 1) (falling); recorded in the order of
  ! integration (decreasing t), direction the sign of dg/dt in time
  na = 0
  do k = 0, 3
    if (-acos(C_LEVEL) - 2*PI*k > -20) call add(-acos(C_LEVEL) - 2*PI*k, 1)
    if (acos(C_LEVEL) - 2*PI*(k + 1) > -20) call add(acos(C_LEVEL) - 2*PI*(k + 1), -1)
  end do
  call log%clear()
  call oscillator_start(ig, x, H_FIX)
  call propagate(ig, x, -20.0_wp, stat, event=plane_t(k=1, c=C_LEVEL, terminal=.false.), crossings=log)
  call check_eq('backward: 6 crossings in [-20, 0]', log%n, na)
  call compare_log('backward', 1.0e-12_wp)
  call check_true('backward: in the order of integration (decreasing t)', &
                  all(log%t(2:log%n) < log%t(1:log%n - 1)))
  call oscillator_start(ig, x)
  call propagate(ig, x, 1.0_wp, stat, event=plane_t(k=1, c=C_LEVEL, nsub=-1))
  call check_eq('nsub < 0 refused', stat, TUBES_EINPUT)
  ! cost: DOP853's dense output costs 3 extra f evaluations in a step where it is used.
  ! With nsub = 0 and no crossing it is never used (nfev unchanged); with nsub = 4 it is used
  ! in every step: nfev grows by exactly 3 per step (adaptive mode, rtol = atol = 1e-12).
  call oscillator_start(ig, x, 0.0_wp)
  call propagate(ig, x, 1.0_wp, stat)
  nf0 = int(ig%nfev)
  ns0 = int(ig%nsteps)
  call oscillator_start(ig, x)
  call propagate(ig, x, 1.0_wp, stat, event=plane_t(k=1, c=-2.0_wp, nsub=0))
  call check_eq('cost: nsub = 0, no crossing: no extra evaluations', int(ig%nfev), nf0)
  call oscillator_start(ig, x)
  call propagate(ig, x, 1.0_wp, stat, event=plane_t(k=1, c=-2.0_wp))
  call check_eq('cost: nsub = 4: 3 dense-output evaluations per step', int(ig%nfev), nf0 + 3*ns0)
  write (*, '(a,es9.2,a,es9.2,a)') '     refinement bracket: max(', T_RTOL, ' |t|, ', T_ATOL, ') s'

  call finish('test_events')

contains

  !> Append an expected crossing (time, direction); lists are built in the order of
  !> integration.
  subroutine add(t, d)
    real(wp), intent(in) :: t
    integer, intent(in) :: d
    na = na + 1
    ta(na) = t
    da(na) = d
  end subroutine add

  !> The log against the expected list ta, da: times within tol, same directions.
  subroutine compare_log(name, tol_t)
    character(*), intent(in) :: name
    real(wp), intent(in) :: tol_t
    real(wp) :: worst
    integer :: j, nbad
    nbad = 0
    worst = 0
    if (log%n /= na) nbad = 1
    do j = 1, min(log%n, na)
      worst = max(worst, abs(log%t(j) - ta(j)))
      if (.not. abs(log%t(j) - ta(j)) <= tol_t .or. log%direction(j) /= da(j)) nbad = nbad + 1
    end do
    write (*, '(5x,a,a,es10.3)') name, ': worst event-time error ', worst
    call check_eq(name//': times (tolerance) and directions match the analytic list', nbad, 0)
  end subroutine compare_log

  !> The oscillator from (cos 1/4, sin 1/4) over one step of h = 0.5 to t = 0.5, the crossings
  !> of x = c (nsub samples inside the step) into log.
  subroutine run_one_step(c, nsub)
    real(wp), intent(in) :: c
    integer, intent(in) :: nsub
    call log%clear()
    call ig%init(oscillator_t(), t0=0.0_wp)
    ig%h = 0.5_wp
    x = [cos(0.25_wp), sin(0.25_wp)]
    call propagate(ig, x, 0.5_wp, stat, event=plane_t(k=1, c=c, terminal=.false., nsub=nsub), &
                   crossings=log)
  end subroutine run_one_step

  !> The isotropic oscillator from z0 to t = 60 (fixed h = 1/16), crossings into log.
  subroutine run_iso(z0, ev)
    real(wp), intent(in) :: z0(4)
    type(theta_line_t), intent(in) :: ev
    call log%clear()
    call ig%init(iso_field(), t0=0.0_wp)
    ig%h = H_FIX
    z = z0
    call propagate(ig, z, 60.0_wp, stat, event=ev, crossings=log)
    if (stat /= TUBES_OK) write (*, '(a,i0)') 'FAIL run_iso: status ', stat
  end subroutine run_iso

  !> The ball on the tilted plane from q0 = (1, 1.5), v0 = (3, 2) to t = 3 (fixed h = 0.25).
  subroutine run_ball(ev)
    class(event_t), intent(in) :: ev
    call log%clear()
    call ig%init(ball, t0=0.0_wp)
    ig%h = 0.25_wp
    z = [1.0_wp, 1.5_wp, 8.4_wp, 2.8_wp]
    call propagate(ig, z, 3.0_wp, stat, event=ev, crossings=log)
    if (stat /= TUBES_OK) write (*, '(a,i0)') 'FAIL run_ball: status ', stat
  end subroutine run_ball

  pure function polar_q(r, th) result(qq)
    real(wp), intent(in) :: r, th
    real(wp) :: qq(2)
    qq = [r*cos(th), r*sin(th)]
  end function polar_q
end program test_events
