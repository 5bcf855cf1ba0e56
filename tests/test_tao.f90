!> Test models for test_tao: the harmonic oscillator H = (q^2 + p^2)/2, its failing variants,
!> a one-dimensional field (odd dimension: not canonical; tubes_test_models), the Hamiltonian vector field of
!> omega H_C = omega (|q - x|^2 + |p - y|^2)/2 on (q, p, x, y) written from its gradient
!> (an independent reference for phi_C), and an observer for the dense output.
module test_tao_models
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
  use tubes_kinds, only: wp
  use tubes_test_models, only: oscillator_t, nan_oscillator_t, shy_oscillator_t, rotate, line_field, &
                               affine_field_t
  use tubes_integrator, only: integrator_t, observer_t
  use tubes_tao, only: tao_t
  implicit none
  private
  public :: oscillator_t, nan_oscillator_t, shy_oscillator_t, line_field, coupling_field, &
            dense_probe_t, rotate

  !> Samples interp at 7 interior points of each step, against the exact flow from the
  !> step's start z_old: the total local error, and the error of the Hermite cubic itself.
  !> The latter removes what the step's own defect d = z_new - exact(z_old, h) contributes:
  !> the cubic is linear in its end data, and for f(z) = J z the end slope is off by J d,
  !> so interp = cubic(exact ends) + h01(th) d + h h11(th) J d, h01 = th^2 (3 - 2 th),
  !> h11 = th^2 (th - 1); what is left is the interpolation remainder.
  type, extends(observer_t) :: dense_probe_t
    real(wp) :: err_local = 0   !! max |interp(s) - exact flow from z_old|
    real(wp) :: err_cubic = 0   !! the same without the step's own defect: the cubic's error
    real(wp) :: err_ends = 0    !! max |interp(t_old) - z_old|, |interp(t) - z_new|
  contains
    procedure :: on_step => probe_on_step
  end type dense_probe_t

contains

  !> Hamilton's equations of omega H_C on z = (q, p, x, y), m = 2 (dimension 8), as dz/dt = A z:
  !> dq/dt = dHC/dp = omega (p - y), dp/dt = -dHC/dq = -omega (q - x),
  !> dx/dt = dHC/dy = -omega (p - y), dy/dt = -dHC/dx = omega (q - x).
  function coupling_field(omega) result(f)
    real(wp), intent(in) :: omega   !! binding constant [1/s]
    type(affine_field_t) :: f
    integer :: i
    allocate (f%a(8, 8), source=0.0_wp)
    allocate (f%b(8), source=0.0_wp)
    do i = 1, 2   ! z = (q1, q2, p1, p2, x1, x2, y1, y2)
      f%a(i, [2 + i, 6 + i]) = [omega, -omega]          ! dq/dt = omega (p - y)
      f%a(2 + i, [i, 4 + i]) = [-omega, omega]          ! dp/dt = -omega (q - x)
      f%a(4 + i, [2 + i, 6 + i]) = [-omega, omega]      ! dx/dt = -omega (p - y)
      f%a(6 + i, [i, 4 + i]) = [omega, -omega]          ! dy/dt = omega (q - x)
    end do
  end function coupling_field

  subroutine probe_on_step(self, ig, t_hi)
    class(dense_probe_t), intent(inout) :: self
    class(integrator_t), intent(inout) :: ig
    real(wp), intent(in) :: t_hi
    real(wp) :: xs(2), ex(2), d(2), jd(2), s, th, h
    integer :: j
    select type (ig)
    type is (tao_t)
      h = ig%h_used
      d = ig%z_new - rotate(ig%z_old, h)
      jd = [d(2), -d(1)]
      do j = 1, 7
        th = j/8.0_wp
        s = ig%t_old + th*h
        call ig%interp(s, xs)
        ex = rotate(ig%z_old, s - ig%t_old)
        self%err_local = max(self%err_local, norm2(xs - ex))
        self%err_cubic = max(self%err_cubic, &
                             norm2(xs - ex - th**2*(3 - 2*th)*d - h*th**2*(th - 1)*jd))
      end do
      call ig%interp(ig%t_old, xs)
      self%err_ends = max(self%err_ends, norm2(xs - ig%z_old))
      call ig%interp(ig%t, xs)
      self%err_ends = max(self%err_ends, norm2(xs - ig%z_new))
    end select
  end subroutine probe_on_step

end module test_tao_models

!> Tao's explicit symplectic methods for non-separable H (orders 2, 4, 6): the composition,
!> the exact coupling flow phi_C against Hamilton's equations, measured orders (oscillator
!> against the exact solution, rolling ball by Richardson), time reversibility, long-time
!> energy against RK4, the effect of omega, dense output, backward integration, the copies
!> across calls, and failure statuses.
program test_tao
  use tubes_kinds, only: wp
  use tubes_status, only: TUBES_OK, TUBES_EINPUT, TUBES_EMODEL, TUBES_ESTEP
  use tubes_field, only: vector_field_t
  use tubes_tao, only: tao_t, tao_flow_c, tao_composition, TAO_OMEGA_DEFAULT
  use tubes_rk4, only: rk4_t
  use tubes_dop853, only: dop853_t
  use tubes_integrator, only: propagate
  use tubes_fourwell, only: fourwell_t
  use tubes_ball, only: ball_t, make_ball
  use tubes_check, only: check_close, check_true, check_eq, finish
  use test_tao_models, only: oscillator_t, nan_oscillator_t, shy_oscillator_t, line_field, &
                             coupling_field, dense_probe_t, rotate
  use tubes_test_models, only: X0_BALL, PI, EPS
  implicit none

  real(wp), parameter :: OMEGA_OSC = 2.0_wp   ! oscillator: 4x its binding threshold 1/2 (3.)
  real(wp), parameter :: OMEGA = TAO_OMEGA_DEFAULT

  type(tao_t) :: ig
  type(rk4_t) :: rk
  type(dop853_t) :: ref
  type(ball_t) :: ball
  type(dense_probe_t) :: probe
  integer :: kinds(64), nfl, i, j, o, stat, nev(3)
  integer(kind(ig%nfev)) :: ns
  real(wp) :: coefs(64), w(8), wc(8), wr(8), sums(3), sabs(3), hc0, tol, amp
  real(wp) :: x(2), xf(2), err(3), dif(2), order, h, z(4), zs(4, 3), zr(4), e0, e_trip
  real(wp) :: etenth(10, 2), eloc(2), ecub(2), errs(4), bound
  character(100) :: lbl

  call make_ball(ball, fourwell_t(), 981.0_wp)
  e0 = ball%energy(X0_BALL)

  ! === 0. defaults ===========================================================================
  call check_true('default order is 2', ig%order == 2)
  call check_true('default omega_bind is TAO_OMEGA_DEFAULT = 200 /s', &
                  ig%omega_bind == TAO_OMEGA_DEFAULT .and. TAO_OMEGA_DEFAULT == 200.0_wp)

  ! === 1. the composition ====================================================================
  ! Each flow kind must add up to one full step (consistency: the method integrates
  ! H_A + H_B + omega H_C over h); the composition is a palindrome (symmetric method: the
  ! merged sums at both ends are the same two products added in either order, so equal
  ! bitwise); merging leaves no two equal neighbours; 5, 13, 37 flows with 4, 10, 28 model
  ! evaluations (A and B flows). Sum tolerance: n eps sum |coef| (n additions).
  do o = 2, 6, 2
    call tao_composition(o, kinds, coefs, nfl)
    sums = 0
    sabs = 0
    do i = 1, nfl
      sums(kinds(i)) = sums(kinds(i)) + coefs(i)
      sabs(kinds(i)) = sabs(kinds(i)) + abs(coefs(i))
    end do
    write (lbl, '(a,i0)') 'composition: number of flows, order ', o
    call check_eq(trim(lbl), nfl, merge(5, merge(13, 37, o == 4), o == 2))
    write (lbl, '(a,i0)') 'composition: model evaluations per step, order ', o
    call check_eq(trim(lbl), count(kinds(1:nfl) /= 3), merge(4, merge(10, 28, o == 4), o == 2))
    do j = 1, 3
      write (lbl, '(a,a,a,i0)') 'composition: flow ', achar(iachar('A') + j - 1), &
        ' sums to one step, order ', o
      call check_close(trim(lbl), sums(j), 1.0_wp, nfl*EPS*sabs(j))
    end do
    write (lbl, '(a,i0)') 'composition: palindrome, order ', o
    call check_true(trim(lbl), all(kinds(1:nfl) == kinds(nfl:1:-1)) .and. &
                    all(coefs(1:nfl) == coefs(nfl:1:-1)))
    write (lbl, '(a,i0)') 'composition: no equal neighbours, starts and ends with A, order ', o
    call check_true(trim(lbl), all(kinds(1:nfl - 1) /= kinds(2:nfl)) .and. kinds(1) == 1 &
                    .and. kinds(nfl) == 1)
  end do
  call tao_composition(3, kinds, coefs, nfl)
  call check_eq('composition: order 3 is not offered (n = 0)', nfl, 0)
  ! the counters agree: one step of each order on the oscillator
  do o = 2, 6, 2
    call start(oscillator_t(), 0.0_wp, o, OMEGA_OSC, 0.1_wp)
    x = [1.0_wp, 0.0_wp]
    call propagate(ig, x, 0.1_wp, stat)
    nev(o/2) = int(ig%nfev)
  end do
  call check_true('nfev per step: 4, 10, 28 for tao2, tao4, tao6', all(nev == [4, 10, 28]))

  ! === 2. the coupling flow phi_C ============================================================
  ! From Hamilton's equations of omega H_C (coupling_field): u = q - x, v = p - y obey
  ! u' = 2 omega v, v' = -2 omega u (a rotation at rate 2 omega), and q + x, p + y are
  ! constant. tao_flow_c must (a) keep q + x, p + y and H_C = (|u|^2 + |v|^2)/2 (a rotation
  ! and a halving: a few ulps of the values, tolerance 8 eps), (b) agree with DOP853 on
  ! coupling_field at rtol = atol = 1e-13 (adaptive bound 4 N tol (1 + |w|), as in test_dop853),
  ! (c) be a one-parameter group (phi^-d phi^d = id to 8 eps), (d) swap the state and its
  ! copy at 2 omega d = pi (u, v -> -u, -v).
  w = [1.3_wp, -0.4_wp, 2.1_wp, 0.7_wp, 0.9_wp, 0.2_wp, 1.6_wp, -1.1_wp]   ! (q, p, x, y)
  wc = w
  call tao_flow_c(3.0_wp, 0.7_wp, wc(1:2), wc(3:4), wc(5:6), wc(7:8))
  call check_close('phi_C keeps q + x', maxval(abs((wc(1:2) + wc(5:6)) - (w(1:2) + w(5:6)))), &
                   0.0_wp, 8*EPS*maxval(abs(w)))
  call check_close('phi_C keeps p + y', maxval(abs((wc(3:4) + wc(7:8)) - (w(3:4) + w(7:8)))), &
                   0.0_wp, 8*EPS*maxval(abs(w)))
  hc0 = (sum((w(1:2) - w(5:6))**2) + sum((w(3:4) - w(7:8))**2))/2
  call check_close('phi_C keeps H_C', &
                   (sum((wc(1:2) - wc(5:6))**2) + sum((wc(3:4) - wc(7:8))**2))/2, hc0, 8*EPS*hc0)
  call ref%init(coupling_field(3.0_wp), t0=0.0_wp)
  ref%rtol = 1.0e-13_wp
  ref%atol = 1.0e-13_wp
  wr = w
  call propagate(ref, wr, 0.7_wp, stat)
  tol = 4*(ref%nsteps + 1)*ref%rtol*(1 + maxval(abs(w)))
  write (*, '(a,es10.3,a,i0,a)') '     |phi_C - DOP853|: ', maxval(abs(wc - wr)), ' (', &
    ref%nsteps, ' DOP853 steps)'
  call check_close('phi_C = flow of Hamilton''s equations of omega H_C (DOP853)', &
                   maxval(abs(wc - wr)), 0.0_wp, tol)
  call tao_flow_c(3.0_wp, -0.7_wp, wc(1:2), wc(3:4), wc(5:6), wc(7:8))
  call check_close('phi_C^-d phi_C^d = id', maxval(abs(wc - w)), 0.0_wp, 8*EPS*maxval(abs(w)))
  wc = w
  call tao_flow_c(3.0_wp, PI/6, wc(1:2), wc(3:4), wc(5:6), wc(7:8))   ! 2 omega d = pi
  call check_close('phi_C at 2 omega d = pi swaps (q, p) and (x, y)', &
                   maxval(abs(wc - [w(5:8), w(1:4)])), 0.0_wp, 8*EPS*maxval(abs(w)))

  ! === 3. convergence order on the oscillator ================================================
  ! H = (q^2 + p^2)/2. The copies stay bound only if omega exceeds a threshold: near the
  ! diagonal x = q, y = p the gap (u, v) = (q - x, p - y) obeys, for the exact flow of Hbar,
  ! u' = -H_pq u + (H_pp + 2 omega) v, v' = (H_qq - 2 omega) u - H_qp v, here
  ! u'' = -(2 omega + 1)(2 omega - 1) u: bound (oscillating) for omega > 1/2, exponentially
  ! separating below. omega = 2 (OMEGA_OSC) is 4x that; the ball's default 200 would put the
  ! asymptotic regime at h < 1/(2 omega) = 2.5e-3 and tao6's errors at the roundoff floor.
  ! The methods are symmetric, so the error is C h^p (1 + c h^2 + ...) and the local order
  ! from h and h/2 is p + O(h^2). Here the h^2 term is not small at h = 1/8 (tao6: order
  ! 5.86 from 1/8 and 1/16, 5.96 from 1/16 and 1/32: the defect quarters, as h^2 predicts),
  ! so h = 1/16, 1/32, 1/64 (exact, dividing t = 10), where the drift is <= 0.04; window
  ! +-0.15. The errors (printed) stay >= 100x above the roundoff floor (~1e-12 for 640
  ! steps of 37 flows).
  do o = 2, 6, 2
    do i = 1, 3
      h = 0.0625_wp/2**(i - 1)
      call start(oscillator_t(), 0.0_wp, o, OMEGA_OSC, h)
      x = [1.0_wp, 0.0_wp]
      call propagate(ig, x, 10.0_wp, stat)
      write (lbl, '(a,i0,a,f7.5)') 'oscillator tao', o, ': status, h = ', h
      call check_eq(trim(lbl), stat, TUBES_OK)
      err(i) = norm2(x - rotate([1.0_wp, 0.0_wp], 10.0_wp))
    end do
    write (*, '(a,i0,a,3es10.3)') '     tao', o, ' oscillator errors at t = 10, h = 1/16, 1/32, 1/64: ', err
    do i = 1, 2
      order = log(err(i)/err(i + 1))/log(2.0_wp)
      write (lbl, '(a,i0,a,i0,a,f7.5)') 'oscillator tao', o, ': measured order ', o, &
        ' (+-0.15), from h = ', 0.0625_wp/2**(i - 1)
      call check_close(trim(lbl), order, real(o, wp), 0.15_wp)
    end do
  end do

  ! === 4. convergence order on the rolling ball (Richardson, default omega) ==================
  ! From rest at (4, 12.6149) cm, t = 1 s, omega = 200 /s (above the ball's binding threshold
  ! ~70 /s, see the doc). The error expansion is in h and omega h (the coupling rotates by
  ! 2 omega h per step), so the asymptotic order needs omega h << 1: h <= 1/512 s
  ! (2 omega h <= 0.78) for tao2, h <= 1/1024 s for tao6 and 1/2048 s for tao4 (at 1/512 s
  ! their local orders are still 0.2 and 0.3 short). The differences |z_h - z_h/2|,
  ! |z_h/2 - z_h/4| (printed) stay >= 100x above the ~2e-10 roundoff floor of the ball. The
  ! local order drifts by O((omega h)^2); window +-0.3, which separates p from p +- 1.
  do o = 2, 6, 2
    do i = 1, 3
      h = merge(1.0_wp/512, merge(1.0_wp/2048, 1.0_wp/1024, o == 4), o == 2)/2**(i - 1)
      call start(ball, 0.0_wp, o, OMEGA, h)
      z = X0_BALL
      call propagate(ig, z, 1.0_wp, stat)
      write (lbl, '(a,i0,a,es9.3)') 'ball tao', o, ': status, h = ', h
      call check_eq(trim(lbl), stat, TUBES_OK)
      zs(:, i) = z
    end do
    dif(1) = norm2(zs(:, 1) - zs(:, 2))
    dif(2) = norm2(zs(:, 2) - zs(:, 3))
    write (*, '(a,i0,a,2es10.3)') '     tao', o, ' ball |z_h - z_h/2|, |z_h/2 - z_h/4|: ', dif
    order = log(dif(1)/dif(2))/log(2.0_wp)
    write (lbl, '(a,i0,a,i0,a)') 'ball tao', o, ': Richardson order ', o, ' (+-0.3)'
    call check_close(trim(lbl), order, real(o, wp), 0.3_wp)
  end do

  ! === 5. time reversibility =================================================================
  ! tao2 is symmetric: its step with -h is the exact inverse of the step with h on the
  ! augmented space (q, p, x, y), and the copies are kept across calls. Forward to t = 1 s
  ! on the ball (512 steps) and back to 0 must return to the start up to roundoff: a few
  ! ulps of max|z| (~80 cm/s) per step and direction, times the growth of a perturbation
  ! over 1 s. That growth (amp) is measured, not assumed: the largest of |dz(1 s)|/|dz(0)|
  ! over perturbations of 1e-8 |z| in each component. Tolerance 4 (2 N) eps max|z| amp.
  ! RK4 with the same step is not symmetric: its round trip misses by its truncation error,
  ! which this tolerance rejects (the check is not vacuous).
  call start(ball, 0.0_wp, 2, OMEGA, 1.0_wp/512)
  z = X0_BALL
  call propagate(ig, z, 1.0_wp, stat)
  zr = z
  call propagate(ig, z, 0.0_wp, stat)
  call check_eq('reversibility: status', stat, TUBES_OK)
  call check_true('reversibility: back at t = 0', ig%t == 0.0_wp)
  e_trip = norm2(z - X0_BALL)
  amp = 0
  do j = 1, 4
    call start(ball, 0.0_wp, 2, OMEGA, 1.0_wp/512)
    z = X0_BALL
    z(j) = z(j) + 1.0e-8_wp*80
    call propagate(ig, z, 1.0_wp, stat)
    amp = max(amp, norm2(z - zr)/(1.0e-8_wp*80))
  end do
  tol = 4*(2*512)*EPS*80*amp
  write (*, '(a,es10.3,a,f8.2)') '     tao2 round trip 0 -> 1 s -> 0: |z - z0| = ', e_trip, &
    ', perturbation growth over 1 s: ', amp
  call check_close('reversibility: tao2 returns to the start (roundoff growth)', e_trip, 0.0_wp, tol)
  call rk%init(ball, t0=0.0_wp)
  rk%h = 1.0_wp/512
  z = X0_BALL
  call propagate(rk, z, 1.0_wp, stat)
  call propagate(rk, z, 0.0_wp, stat)
  write (*, '(a,es10.3)') '     rk4 round trip: |z - z0| = ', norm2(z - X0_BALL)
  call check_true('reversibility: rk4 (not symmetric) would fail that tolerance', &
                  norm2(z - X0_BALL) > tol)

  ! === 6. long-time energy: tao2 against rk4 =================================================
  ! 1000 s on the ball (hundreds of oscillations; the motion is chaotic), energy sampled
  ! every 0.5 s. tao2 at h = 1/512 s (2 omega h = 0.78); rk4 at h = 1/100 s, where its energy
  ! error over the first 100 s is comparable (asked: within 10x) to tao2's. A symplectic
  ! method keeps a modified energy up to exponentially long times: the energy error
  ! oscillates without drift, and the largest |dE| in the last tenth is about that of the
  ! first (a random walk would give sqrt(10) = 3.2, a linear drift 10): tao2's ratio must be
  ! < 3. RK4 is not symplectic: its error accumulates linearly, 10x from the first to the
  ! last tenth; > 5 asks for at least half of that.
  call start(ball, 0.0_wp, 2, OMEGA, 1.0_wp/512)
  call rk%init(ball, t0=0.0_wp)
  rk%h = 0.01_wp
  etenth = 0
  do j = 1, 2
    z = X0_BALL
    do i = 1, 2000
      if (j == 1) then
        call propagate(ig, z, 0.5_wp*i, stat)
      else
        call propagate(rk, z, 0.5_wp*i, stat)
      end if
      if (stat /= TUBES_OK) exit
      etenth(1 + (i - 1)/200, j) = max(etenth(1 + (i - 1)/200, j), abs(ball%energy(z) - e0)/e0)
    end do
    call check_eq(merge('long run tao2: status', 'long run rk4: status ', j == 1), stat, TUBES_OK)
  end do
  write (*, '(a,10es8.1)') '     tao2 max |dE|/E per 100 s: ', etenth(:, 1)
  write (*, '(a,10es8.1)') '     rk4  max |dE|/E per 100 s: ', etenth(:, 2)
  call check_true('long run: rk4 and tao2 comparable over the first 100 s (within 10x)', &
                  etenth(1, 2) < 10*etenth(1, 1) .and. etenth(1, 1) < 10*etenth(1, 2))
  call check_true('long run: tao2 energy error bounded (last/first tenth < 3)', &
                  etenth(10, 1) < 3*etenth(1, 1))
  call check_true('long run: rk4 energy error drifts (last/first tenth > 5)', &
                  etenth(10, 2) > 5*etenth(1, 2))

  ! === 7. the effect of omega ================================================================
  ! Too small: below the binding threshold (section 3: omega > max eig(H_qq)/2, ~70 /s on
  ! the ball) the copies separate exponentially and the method loses the trajectory: over
  ! 20 s at omega = 1 /s the energy error is O(0.1) against ~1e-5 at the default; asked:
  ! > 100x the default's. Too large: the error grows with omega (Tao's bound is
  ! O(omega h^l) per unit time): tao4 at h = 1/4096 s, error at t = 1 s against DOP853
  ! (rtol = atol = 1e-13, error ~1e-12), omega = 1e4 /s against the default 200 /s: the
  ! bound alone predicts 50x; asked: > 10x.
  do j = 1, 2
    call start(ball, 0.0_wp, 2, merge(1.0_wp, OMEGA, j == 1), 1.0_wp/512)
    z = X0_BALL
    errs(j) = 0
    do i = 1, 40
      call propagate(ig, z, 0.5_wp*i, stat)
      if (stat /= TUBES_OK) exit
      errs(j) = max(errs(j), abs(ball%energy(z) - e0)/e0)
    end do
  end do
  write (*, '(a,2es10.3)') '     tao2 max |dE|/E over 20 s, omega = 1, 200 /s: ', errs(1:2)
  call check_true('omega too small (1 /s): energy error > 100x the default''s', &
                  errs(1) > 100*errs(2))
  call ref%init(ball, t0=0.0_wp)
  zr = X0_BALL
  call propagate(ref, zr, 1.0_wp, stat)
  do j = 3, 4
    call start(ball, 0.0_wp, 4, merge(OMEGA, 1.0e4_wp, j == 3), 1.0_wp/4096)
    z = X0_BALL
    call propagate(ig, z, 1.0_wp, stat)
    errs(j) = norm2(z - zr)
  end do
  write (*, '(a,2es10.3)') '     tao4 h = 1/4096 s error at 1 s, omega = 200, 1e4 /s: ', errs(3:4)
  call check_true('omega too large (1e4 /s): error > 10x the default''s', errs(4) > 10*errs(3))

  ! === 8. dense output =======================================================================
  ! Hermite cubic from (q, p) and f at both ends, on the oscillator (omega = 2, h = 0.2 and
  ! 0.1). The cubic's own error (probe%err_cubic: the interpolant minus the exact flow, less
  ! what the step's defect contributes, see dense_probe_t) is the Hermite remainder
  ! x''''(xi) th^2 (1 - th)^2 h^4/24 <= sqrt(2) h^4/384 on the unit circle, for every order:
  ! bound that plus 100 eps for the rounding of the subtraction, and order 4 (+-0.3 as for
  ! rk4). The total local error (interp against the exact flow from z_old) adds the step's
  ! defect: tao2's O(h^3) dominates (order 3, +-0.3); tao4's defect is O(h^5) but with a
  ! large constant (the copies carry the global error into each step), so the total is
  ! only printed.
  do o = 2, 4, 2
    do i = 1, 2
      h = 0.2_wp/2**(i - 1)
      call start(oscillator_t(), 0.0_wp, o, OMEGA_OSC, h)
      x = [1.0_wp, 0.0_wp]
      probe = dense_probe_t()
      call propagate(ig, x, 10.0_wp, stat, observer=probe)
      eloc(i) = probe%err_local
      ecub(i) = probe%err_cubic
      bound = sqrt(2.0_wp)*h**4/384 + 100*EPS
      write (lbl, '(a,i0,a,f4.2)') 'dense output tao', o, ': cubic within the Hermite bound, h = ', h
      call check_close(trim(lbl), ecub(i), 0.0_wp, bound)
      write (lbl, '(a,i0,a,f4.2)') 'dense output tao', o, ': reproduces the step ends (4 eps), h = ', h
      call check_close(trim(lbl), probe%err_ends, 0.0_wp, 4*EPS)
    end do
    write (*, '(a,i0,a,2es10.3,a,2es10.3)') '     tao', o, ' h = 0.2, 0.1: cubic error ', ecub, &
      ', total local error ', eloc
    order = log(ecub(1)/ecub(2))/log(2.0_wp)
    write (lbl, '(a,i0,a)') 'dense output tao', o, ': cubic error order 4 (+-0.3)'
    call check_close(trim(lbl), order, 4.0_wp, 0.3_wp)
    if (o == 2) then
      order = log(eloc(1)/eloc(2))/log(2.0_wp)
      call check_close('dense output tao2: total local error order 3 (+-0.3)', order, 3.0_wp, 0.3_wp)
    end if
  end do
  ! the slopes are evaluated on first use: 2 for the first step, then 1 per step (the end
  ! slope carries over); without dense output no extra evaluation (section 1)
  call start(oscillator_t(), 0.0_wp, 2, OMEGA_OSC, 0.1_wp)
  x = [1.0_wp, 0.0_wp]
  call propagate(ig, x, 0.1_wp, stat)
  ns = ig%nfev
  call ig%interp(0.05_wp, xf)
  call check_eq('dense output: first step costs 2 slopes', int(ig%nfev - ns), 2)
  call propagate(ig, x, 0.2_wp, stat)
  ns = ig%nfev
  call ig%interp(0.15_wp, xf)
  call ig%interp(0.16_wp, xf)
  call check_eq('dense output: next step costs 1 slope', int(ig%nfev - ns), 1)

  ! === 9. backward integration ===============================================================
  ! (q, p, t) -> (q, -p, -t) maps the oscillator onto itself, and each flow (A, B with -d at
  ! the mirrored point, C rotating back) performs the same operations with the p and y
  ! signs flipped: backward to -3 mirrors forward to +3 (4 ulps for the grid times).
  ! Against the exact (cos 3, sin 3): backward runs at h = 1/32 and 1/64 converge with
  ! order 2 (+-0.15, as in section 3).
  do i = 1, 2
    call start(oscillator_t(), 0.0_wp, 2, OMEGA_OSC, (1.0_wp/32)/i)
    x = [1.0_wp, 0.0_wp]
    call propagate(ig, x, -3.0_wp, stat)
    call check_eq('backward: status', stat, TUBES_OK)
    call check_true('backward: lands on t = -3', ig%t == -3.0_wp)
    err(i) = norm2(x - [cos(3.0_wp), sin(3.0_wp)])
  end do
  write (*, '(a,2es10.3)') '     tao2 backward errors at t = -3, h = 1/32, 1/64: ', err(1:2)
  call check_close('backward: order 2 against the exact solution (+-0.15)', &
                   log(err(1)/err(2))/log(2.0_wp), 2.0_wp, 0.15_wp)
  xf = x
  call start(oscillator_t(), 0.0_wp, 2, OMEGA_OSC, 1.0_wp/64)
  x = [1.0_wp, 0.0_wp]
  call propagate(ig, x, 3.0_wp, stat)
  call check_close('backward mirrors forward: q', xf(1), x(1), 4*EPS)
  call check_close('backward mirrors forward: p', xf(2), -x(2), 4*EPS)
  tol = 2*err(2)   ! tao2's error at h = 1/64 over 3 time units, for section 11

  ! === 10. the copies across calls ===========================================================
  ! The copies (x, y) persist between steps and calls: two propagate calls (0 -> 0.5 -> 1 s)
  ! give bitwise the result of one (same grid, h = 1/512). If the caller changes the state,
  ! the copies restart from it: bitwise the same as a fresh stepper.
  call start(ball, 0.0_wp, 2, OMEGA, 1.0_wp/512)
  z = X0_BALL
  call propagate(ig, z, 0.5_wp, stat)
  call propagate(ig, z, 1.0_wp, stat)
  zr = z
  call start(ball, 0.0_wp, 2, OMEGA, 1.0_wp/512)
  z = X0_BALL
  call propagate(ig, z, 1.0_wp, stat)
  call check_true('copies kept across calls: split run = single run (bitwise)', all(z == zr))
  call check_true('copies differ from the state after a step (they are not reset)', &
                  any(ig%x_copy /= z(1:2)) .or. any(ig%y_copy /= z(3:4)))
  z(3:4) = 0                       ! stop the ball where it is
  zr = z
  call propagate(ig, z, 1.5_wp, stat)
  zs(:, 1) = z
  call start(ball, 1.0_wp, 2, OMEGA, 1.0_wp/512)
  z = zr
  call propagate(ig, z, 1.5_wp, stat)
  call check_true('state changed outside: same result as a fresh start (bitwise)', &
                  all(z == zs(:, 1)))
  ! landing: non-binary h over many steps leaves no sliver step (grid t0 + k h)
  call start(oscillator_t(), 0.0_wp, 2, OMEGA_OSC, 1.0e-3_wp)
  x = [1.0_wp, 0.0_wp]
  call propagate(ig, x, 1.0_wp, stat)
  call check_eq('h = 1e-3 to t = 1: exactly 1000 steps', int(ig%nsteps), 1000)
  call check_true('h = 1e-3 to t = 1: lands on t = 1', ig%t == 1.0_wp)

  ! === 11. failure statuses ==================================================================
  x = [1.0_wp, 0.0_wp]
  call start(oscillator_t(), 0.0_wp, 2, OMEGA_OSC, 0.0_wp)
  call propagate(ig, x, 1.0_wp, stat)
  call check_eq('h = 0: TUBES_EINPUT', stat, TUBES_EINPUT)
  call start(oscillator_t(), 0.0_wp, 3, OMEGA_OSC, 0.1_wp)
  call propagate(ig, x, 1.0_wp, stat)
  call check_eq('order 3: TUBES_EINPUT', stat, TUBES_EINPUT)
  call start(oscillator_t(), 0.0_wp, 2, -1.0_wp, 0.1_wp)
  call propagate(ig, x, 1.0_wp, stat)
  call check_eq('omega < 0: TUBES_EINPUT', stat, TUBES_EINPUT)
  call check_true('inputs rejected: t and x untouched', ig%t == 0 .and. all(x == [1.0_wp, 0.0_wp]))
  ! a rejected order must not leave a stale composition behind (regression: an empty one
  ! was kept and later steps applied no flow at all)
  ig%order = 3
  call propagate(ig, x, 1.0_wp, stat)
  ig%order = 2
  ig%omega_bind = OMEGA_OSC
  call propagate(ig, x, 1.0_wp, stat)
  call check_eq('order 3 then 2: status', stat, TUBES_OK)
  call check_close('order 3 then 2: the state moved (q(1) = cos 1 to tao2 error)', x(1), &
                   cos(1.0_wp), tol)
  call start(line_field(), 0.0_wp, 2, OMEGA, 0.1_wp)
  xf(1:1) = 0
  call propagate(ig, xf(1:1), 1.0_wp, stat)
  call check_eq('odd dimension (not (q, p)): TUBES_EINPUT', stat, TUBES_EINPUT)
  ! NaN below q = 1/2 (reached at t = pi/3 from (1, 0)): TUBES_EMODEL, t and x at the last
  ! accepted step (before pi/3; on the exact solution to within tao2's error at h = 1/64
  ! over 3 time units, section 9, doubled)
  call start(nan_oscillator_t(), 0.0_wp, 2, OMEGA_OSC, 1.0_wp/64)
  x = [1.0_wp, 0.0_wp]
  call propagate(ig, x, 10.0_wp, stat)
  call check_eq('NaN model: TUBES_EMODEL', stat, TUBES_EMODEL)
  call check_true('NaN model: t left at the last accepted step (< pi/3)', &
                  ig%t < PI/3 .and. ig%t > 1)
  call check_close('NaN model: x left at the last accepted step', &
                   norm2(x - rotate([1.0_wp, 0.0_wp], ig%t)), 0.0_wp, tol)
  ! a model that keeps asking for smaller steps: h/4 per refusal until the step underflows
  call start(shy_oscillator_t(x_min=0.5_wp), 0.0_wp, 2, OMEGA_OSC, 1.0_wp/64)
  x = [1.0_wp, 0.0_wp]
  call propagate(ig, x, 10.0_wp, stat)
  call check_eq('model refusing q < 1/2: TUBES_ESTEP', stat, TUBES_ESTEP)
  call check_true('model refusing q < 1/2: steps were retried', ig%nrejected > 0)
  call check_close('model refusing q < 1/2: stopped before t = pi/3 (within h)', ig%t, &
                   PI/3, 1.0_wp/64)

  call finish('test_tao')

contains

  !> A fresh tao stepper with every setting explicit (they persist across init).
  subroutine start(model, t0, order, omega, h)
    class(vector_field_t), intent(in) :: model
    real(wp), intent(in) :: t0, omega, h
    integer, intent(in) :: order
    call ig%init(model, t0=t0)
    ig%order = order
    ig%omega_bind = omega
    ig%h = h
  end subroutine start
end program test_tao
