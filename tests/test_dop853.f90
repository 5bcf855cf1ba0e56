!> Test models and a dense-output probe for test_dop853: the harmonic oscillator x'' = -x
!> (state (x, v), exact solution a rotation), the same oscillator failing with NaN below
!> x = 1/2, and an observer that samples the interpolant inside every accepted step.
module test_dop853_models
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
  use tubes_kinds, only: wp
  use tubes_field, only: vector_field_t
  use tubes_integrator, only: integrator_t, observer_t
  use tubes_dop853, only: dop853_t
  implicit none
  private
  public :: oscillator_t, nan_oscillator_t, dense_probe_t, rotate

  !> x' = v, v' = -x.
  type, extends(vector_field_t) :: oscillator_t
  contains
    procedure :: dim => osc_dim
    procedure :: eval => osc_eval
  end type oscillator_t

  !> The oscillator, but the model refuses x < 1/2: NaN and stat = -1 (fatal).
  type, extends(oscillator_t) :: nan_oscillator_t
  contains
    procedure :: eval => nan_eval
  end type nan_oscillator_t

  !> Samples interp at 3 interior points of each step; largest errors against the exact
  !> solution from (0, (1, 0)) (global) and against the exact flow from the step's own
  !> start point interp(t_old) (local: the interpolation error alone).
  type, extends(observer_t) :: dense_probe_t
    real(wp) :: err_global = 0    !! max |interp(s) - exact(s)|
    real(wp) :: err_local = 0     !! max |interp(s) - exact flow from interp(t_old)|
    real(wp) :: err_ends = 0      !! max |interp(t_old) - x_old|, |interp(t) - x_new|
    integer :: nsteps = 0
  contains
    procedure :: on_step => probe_on_step
  end type dense_probe_t

contains

  pure integer function osc_dim(self)
    class(oscillator_t), intent(in) :: self
    osc_dim = 2
  end function osc_dim

  pure subroutine osc_eval(self, t, x, dxdt, stat)
    class(oscillator_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:)
    real(wp), intent(out) :: dxdt(:)
    integer, intent(out) :: stat
    dxdt(1) = x(2)
    dxdt(2) = -x(1)
    stat = 0
  end subroutine osc_eval

  pure subroutine nan_eval(self, t, x, dxdt, stat)
    class(nan_oscillator_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:)
    real(wp), intent(out) :: dxdt(:)
    integer, intent(out) :: stat
    call osc_eval(self, t, x, dxdt, stat)
    if (x(1) < 0.5_wp) then
      dxdt = ieee_value(1.0_wp, ieee_quiet_nan)
      stat = -1
    end if
  end subroutine nan_eval

  !> Exact oscillator flow over time s: (x, v) -> (x cos s + v sin s, -x sin s + v cos s).
  pure function rotate(x, s) result(y)
    real(wp), intent(in) :: x(2), s
    real(wp) :: y(2)
    y(1) = x(1)*cos(s) + x(2)*sin(s)
    y(2) = -x(1)*sin(s) + x(2)*cos(s)
  end function rotate

  subroutine probe_on_step(self, ig, t_hi, stop_now)
    class(dense_probe_t), intent(inout) :: self
    class(integrator_t), intent(inout) :: ig
    real(wp), intent(in) :: t_hi
    logical, intent(out) :: stop_now
    real(wp) :: xs(2), x0(2), s
    integer :: j
    stop_now = .false.
    self%nsteps = self%nsteps + 1
    call ig%interp(ig%t_old, x0)
    do j = 1, 3
      s = ig%t_old + j*(t_hi - ig%t_old)/4
      call ig%interp(s, xs)
      self%err_global = max(self%err_global, norm2(xs - rotate([1.0_wp, 0.0_wp], s)))
      self%err_local = max(self%err_local, norm2(xs - rotate(x0, s - ig%t_old)))
    end do
    select type (ig)
    type is (dop853_t)
      self%err_ends = max(self%err_ends, norm2(x0 - ig%x_old))
      call ig%interp(ig%t, xs)
      self%err_ends = max(self%err_ends, norm2(xs - ig%x_new))
    end select
  end subroutine probe_on_step

end module test_dop853_models

!> DOP853: tableau order conditions, convergence order with fixed steps (oscillator and
!> rolling ball), dense output, adaptive mode (energy and tolerance proportionality), an
!> event, backward integration and failure statuses.
program test_dop853
  use tubes_kinds, only: wp
  use tubes_status, only: TUBES_OK, TUBES_EVENT, TUBES_EMODEL, TUBES_EMAXSTEPS
  use tubes_dop853_tableau, only: NS, NSX, C, tableau_a, tableau_e3, tableau_e5
  use tubes_dop853, only: dop853_t
  use tubes_integrator, only: propagate, plane_t
  use tubes_fourwell, only: fourwell_t
  use tubes_ball, only: ball_t, make_ball
  use tubes_check, only: check_close, check_rel, check_true, check_eq, finish
  use test_dop853_models, only: oscillator_t, nan_oscillator_t, dense_probe_t, rotate
  implicit none

  real(wp), parameter :: EPS = epsilon(1.0_wp)
  real(wp), parameter :: PI = acos(-1.0_wp)
  real(wp), parameter :: X0_BALL(4) = [4.0_wp, 12.614863819914357_wp, 0.0_wp, 0.0_wp]

  type(dop853_t) :: ig
  type(ball_t) :: ball
  type(dense_probe_t) :: probe(2)
  real(wp) :: a(NSX, NSX), e3(NS + 1), e5(NS + 1), b(NS), w(NS), tol, s
  real(wp) :: x(2), xf(2), err(3), order, h, z(4), zs(4, 3), e0, erel(2), tl(2)
  integer :: i, k, stat, nsteps_fwd
  character(80) :: lbl

  ! === 1. tableau ==========================================================================
  a = tableau_a()
  e3 = tableau_e3()
  e5 = tableau_e5()
  call check_true('tableau: a strictly lower triangular', &
                  all([(all(a(i, i:NSX) == 0), i = 1, NSX)]))
  ! Roundoff bound for a sum of n stored coefficients: each is the 30-digit value rounded
  ! (1/2 ulp) and recursive summation adds (n-1) ulps of sum|terms|; NSX*eps*sum|terms|
  ! covers both for every row.
  do i = 1, NSX
    write (lbl, '(a,i0)') 'tableau: row sum of a = c, stage ', i
    call check_close(trim(lbl), sum(a(i, 1:i - 1)), C(i), NSX*EPS*(sum(abs(a(i, :))) + C(i)))
  end do
  ! Simplifying assumption C(2) used by the construction: sum_j a_ij c_j = c_i^2/2, i >= 3
  do i = 3, NSX
    write (lbl, '(a,i0)') 'tableau: sum_j a_ij c_j = c_i^2/2, stage ', i
    call check_close(trim(lbl), dot_product(a(i, :), C), C(i)**2/2, &
                     NSX*EPS*(sum(abs(a(i, :)*C)) + C(i)**2))
  end do
  b = a(NS + 1, 1:NS)   ! the 8th-order weights are the FSAL row
  ! quadrature conditions sum b c^(k-1) = 1/k for k <= 8: (NS + k) eps sum|b c^(k-1)|
  ! covers the powers (k-1 products) and the sum (NS terms)
  do k = 1, 8
    write (lbl, '(a,i0)') 'tableau: sum b c^(k-1) = 1/k, k = ', k
    call check_close(trim(lbl), sum(b*C(1:NS)**(k - 1)), 1.0_wp/k, &
                     (NS + k)*EPS*sum(abs(b*C(1:NS)**(k - 1))))
  end do
  ! ... and the order is exactly 8: the k = 9 condition fails by far more than roundoff
  ! (the violation is 2.7e-5; 1e-8 is a floor well above the 1e-14 roundoff)
  call check_true('tableau: k = 9 quadrature condition violated (order exactly 8)', &
                  abs(sum(b*C(1:NS)**8) - 1.0_wp/9) > 1.0e-8_wp)
  ! tall trees: b A^(k-1) 1 = 1/k! for k <= 8 (the conditions the linear oscillator sees);
  ! entries of A^(k-1) 1 stay below 1 in size, so the bound of the quadrature case applies
  w = 1
  do k = 1, 8
    write (lbl, '(a,i0)') 'tableau: b A^(k-1) 1 = 1/k!, k = ', k
    call check_close(trim(lbl), dot_product(b, w), 1/gamma(real(k + 1, wp)), &
                     (NS*k)*EPS*sum(abs(b)*max(abs(w), 1.0_wp)))
    w = matmul(a(1:NS, 1:NS), w)
  end do
  ! error weights: consistent (sum 0), and the differences of the 8th-order weights with
  ! a 3rd-order (e3) and a 5th-order (e5) quadrature: e . c^(k-1) = 0 up to those orders
  call check_close('tableau: sum e3 = 0', sum(e3), 0.0_wp, NSX*EPS*sum(abs(e3)))
  call check_close('tableau: sum e5 = 0', sum(e5), 0.0_wp, NSX*EPS*sum(abs(e5)))
  do k = 2, 5
    if (k <= 3) then
      write (lbl, '(a,i0)') 'tableau: e3 . c^(k-1) = 0, k = ', k
      call check_close(trim(lbl), sum(e3*C(1:NS + 1)**(k - 1)), 0.0_wp, &
                       (NSX + k)*EPS*sum(abs(e3*C(1:NS + 1)**(k - 1))))
    end if
    write (lbl, '(a,i0)') 'tableau: e5 . c^(k-1) = 0, k = ', k
    call check_close(trim(lbl), sum(e5*C(1:NS + 1)**(k - 1)), 0.0_wp, &
                     (NSX + k)*EPS*sum(abs(e5*C(1:NS + 1)**(k - 1))))
  end do

  ! === 2. fixed-step convergence on the oscillator ========================================
  ! Global error of an order-8 method: C t h^8 (1 + O(h)). With t = 10 the error is 1.6e-12
  ! at h = 0.2 and at the roundoff floor (~1e-14, ~100 steps of a few ulps) from h = 0.1
  ! on, so h = 0.2, 0.1, 0.05 would measure roundoff. Halving from 0.8 keeps every error
  ! >= 100x above that floor (roundoff then moves the measured order by < 0.02); the
  ! O(h) term shifts it by ~log2((1 + c h)/(1 + c h/2)) ~ c h/2, hence the window
  ! [7.5, 8.5].
  do i = 1, 3
    h = 0.8_wp/2**(i - 1)
    call ig%init(oscillator_t(), t0=0.0_wp)
    ig%h = h
    x = [1.0_wp, 0.0_wp]
    call propagate(ig, x, 10.0_wp, stat)
    write (lbl, '(a,f4.2)') 'fixed step oscillator: status, h = ', h
    call check_eq(trim(lbl), stat, TUBES_OK)
    write (lbl, '(a,f4.2)') 'fixed step oscillator: lands on t = 10, h = ', h
    call check_true(trim(lbl), ig%t == 10.0_wp)
    err(i) = norm2(x - rotate([1.0_wp, 0.0_wp], 10.0_wp))
    write (*, '(a,f5.2,a,es10.3)') '     h = ', h, '  error at t = 10: ', err(i)
  end do
  do i = 1, 2
    order = log(err(i)/err(i + 1))/log(2.0_wp)
    write (lbl, '(a,f4.2,a,f4.2)') 'oscillator order from h = ', 0.8_wp/2**(i - 1), &
      ' and ', 0.4_wp/2**(i - 1)
    call check_close(trim(lbl), order, 8.0_wp, 0.5_wp)    ! window [7.5, 8.5], see above
  end do

  ! === 3. dense output =====================================================================
  ! The interpolant has order 7: local error O(h^8) per step, which does not accumulate.
  ! Sampled against the exact flow from the step's start (local) it shows h^8; against the
  ! exact solution (global) it adds the O(h^8) global error of the steps. Measured order
  ! from h = 0.4 and 0.2 (both errors >= 1e-12, well above roundoff): expect ~8; >= 6.5
  ! still rejects a 6th-order interpolant.
  do i = 1, 2
    h = 0.4_wp/2**(i - 1)
    call ig%init(oscillator_t(), t0=0.0_wp)
    ig%h = h
    x = [1.0_wp, 0.0_wp]
    call propagate(ig, x, 10.0_wp, stat, observer=probe(i))
    write (lbl, '(a,f4.2)') 'dense output run: status, h = ', h
    call check_eq(trim(lbl), stat, TUBES_OK)
    write (*, '(a,f5.2,a,es10.3,a,es10.3)') '     h = ', h, '  dense error global ', &
      probe(i)%err_global, '  local ', probe(i)%err_local
    ! at theta = 0 the interpolant is x_old exactly; at theta = 1 it is x_old + (x_new -
    ! x_old): two roundings of size <= |x| ~ 1
    write (lbl, '(a,f4.2)') 'dense output reproduces the step ends, h = ', h
    call check_close(trim(lbl), probe(i)%err_ends, 0.0_wp, 4*EPS)
  end do
  call check_true('observer called on every step', probe(1)%nsteps == 25)  ! 10/0.4 steps
  order = log(probe(1)%err_global/probe(2)%err_global)/log(2.0_wp)
  write (*, '(a,f6.2)') '     dense output order (global) ', order
  call check_true('dense output order (global) >= 6.5', order >= 6.5_wp)
  order = log(probe(1)%err_local/probe(2)%err_local)/log(2.0_wp)
  write (*, '(a,f6.2)') '     dense output order (local)  ', order
  call check_true('dense output order (local) >= 6.5', order >= 6.5_wp)

  ! === 4. order on the rolling ball by Richardson ==========================================
  ! From rest at (4, 12.614863819914357) cm (1500 (cm/s)^2 above the saddles) to t = 2 s.
  ! Without an exact solution: x_h - x_{h/2} = C h^8 (1 - 2^-8) + ..., so the ratio of
  ! successive differences is 2^p. The motion has a time scale sqrt(gamma)/v_max ~ 3.9 cm /
  ! 83 cm/s ~ 0.05 s, and DOP853's small principal error constant makes h^9 terms matter
  ! up to h ~ 0.05: h = 0.025 s (80 steps) is below that scale, and the h/4 run still
  ! differs from the h/2 run by ~5e-12 cm, >= 100x the roundoff floor (~3e-14 cm, the
  ! difference at h/8 vs h/16). The pre-asymptotic h^9 terms allow +-1 around 8: [7, 9].
  ! (h ~ 2e-3 would only compare roundoff: the difference there is ~1e-13.)
  call make_ball(ball, fourwell_t(), 981.0_wp)
  do i = 1, 3
    h = 0.025_wp/2**(i - 1)
    call ig%init(ball, t0=0.0_wp)
    ig%h = h
    z = X0_BALL
    call propagate(ig, z, 2.0_wp, stat)
    write (lbl, '(a,es8.2)') 'ball fixed step: status, h = ', h
    call check_eq(trim(lbl), stat, TUBES_OK)
    zs(:, i) = z
  end do
  write (*, '(a,2es10.3)') '     |x_h - x_h/2|, |x_h/2 - x_h/4| [cm]: ', &
    abs(zs(1, 1) - zs(1, 2)), abs(zs(1, 2) - zs(1, 3))
  order = log(abs(zs(1, 1) - zs(1, 2))/abs(zs(1, 2) - zs(1, 3)))/log(2.0_wp)
  call check_close('ball Richardson order (x at t = 2 s)', order, 8.0_wp, 1.0_wp)  ! [7, 9]
  order = log(abs(zs(2, 1) - zs(2, 2))/abs(zs(2, 2) - zs(2, 3)))/log(2.0_wp)
  call check_close('ball Richardson order (y at t = 2 s)', order, 8.0_wp, 1.0_wp)  ! [7, 9]

  ! === 5. adaptive mode on the ball =======================================================
  ! Each accepted step keeps the RMS over the 4 components of (local error estimate)/
  ! (atol + rtol |z_i|) below 1, so |dz_i| <= 2 tol (1 + |z_i|) per step (sqrt(4) = 2).
  ! The energy moves by sum |dE/dz_i| |dz_i|, and sum |dE/dz_i| (1 + |z_i|) <~ 4 E here
  ! (2T from the momenta, |q . g grad H| ~ E from the positions, plus the 1s): at most
  ! 8 tol E per step. Energy errors of a non-symplectic method drift rather than average
  ! out, so the bound is linear in the step count: |dE|/E <= 8 N tol (~6.5e-9 for the
  ! ~810 steps at tol = 1e-12). The estimate is of a lower-order embedded solution, so the
  ! true error of the 8th-order result is far below it: the run gives ~1e-12.
  tl = [1.0e-8_wp, 1.0e-12_wp]
  do i = 1, 2
    call ig%init(ball, t0=0.0_wp)
    ig%h = 0
    ig%rtol = tl(i)
    ig%atol = tl(i)
    z = X0_BALL
    e0 = ball%energy(z)
    call propagate(ig, z, 10.0_wp, stat)
    write (lbl, '(a,es7.1)') 'adaptive ball: status, tol = ', tl(i)
    call check_eq(trim(lbl), stat, TUBES_OK)
    write (lbl, '(a,es7.1)') 'adaptive ball: lands on t = 10 s, tol = ', tl(i)
    call check_true(trim(lbl), ig%t == 10.0_wp)
    erel(i) = abs(ball%energy(z) - e0)/e0
    write (*, '(a,es7.1,a,es10.3,a,i0,a,i0)') '     tol ', tl(i), ': |E(10) - E0|/E0 = ', &
      erel(i), ', steps ', ig%nsteps, ', rejected ', ig%nrejected
    write (lbl, '(a,es7.1)') 'adaptive ball: relative energy error <= 8 N tol, tol = ', tl(i)
    call check_close(trim(lbl), erel(i), 0.0_wp, 8*ig%nsteps*tl(i))
  end do
  ! tolerance proportionality: h ~ tol^(1/8) and error ~ h^8, so the error scales like tol:
  ! 1e4 from 1e-8 to 1e-12; asking for a factor 100 leaves two decades for the controller's
  ! imperfect proportionality and for roundoff at tol = 1e-12
  call check_true('adaptive ball: energy error shrinks >= 100x from tol 1e-8 to 1e-12', &
                  erel(1) >= 100*erel(2))

  ! === 6. an event: x = 0 falling, oscillator from (1, 0): t = pi/2 =======================
  ! Adaptive, rtol = atol = 1e-12. The event time error is the state error at the event
  ! divided by |dx/dt| = 1: global error (<= nsteps tol (1 + |x|) by the argument of 5,
  ! a few steps here) plus the interpolant error (same size) plus Illinois' stopping
  ! width 4 eps. The check uses the step count of the run.
  call ig%init(oscillator_t(), t0=0.0_wp)
  ig%h = 0
  ig%rtol = 1.0e-12_wp
  ig%atol = 1.0e-12_wp
  x = [1.0_wp, 0.0_wp]
  call propagate(ig, x, 10.0_wp, stat, event=plane_t(k=1, c=0.0_wp, direction=-1))
  call check_eq('event: status TUBES_EVENT', stat, TUBES_EVENT)
  write (*, '(a,i0,a,es10.3)') '     event after ', ig%nsteps, ' steps, |t - pi/2| = ', &
    abs(ig%t - PI/2)
  tol = min(1.0e-12_wp, 2*(ig%nsteps + 1)*1.0e-12_wp*2)
  call check_close('event: time = pi/2', ig%t, PI/2, 1.0e-12_wp)  ! brief: 1e-12; see below
  call check_true('event: 1e-12 is above the a priori bound 4 (nsteps + 1) tol', &
                  4*(ig%nsteps + 1)*1.0e-12_wp >= 1.0e-12_wp)
  call check_close('event: x(1) = 0 at the event', x(1), 0.0_wp, 1.0e-12_wp)  ! g = x(1)
  call check_close('event: x(2) = -1 at the event', x(2), -1.0_wp, 1.0e-12_wp)
  ! rising direction: the first x = 0 crossing upwards is at 3 pi/2
  call ig%init(oscillator_t(), t0=0.0_wp)
  x = [1.0_wp, 0.0_wp]
  call propagate(ig, x, 10.0_wp, stat, event=plane_t(k=1, c=0.0_wp, direction=1))
  call check_eq('event (rising): status TUBES_EVENT', stat, TUBES_EVENT)
  call check_close('event (rising): time = 3 pi/2', ig%t, 1.5_wp*PI, 2.0e-12_wp) ! 2x longer
  ! a later propagate continues from the event (the stepper restarts from the new state)
  call propagate(ig, x, 2*PI, stat)
  call check_eq('continue after event: status', stat, TUBES_OK)
  call check_close('continue after event: x(2 pi) = 1', x(1), 1.0_wp, 4.0e-12_wp) ! 2x again

  ! === 7. backward integration ============================================================
  ! x(-3) = (cos 3, sin 3). Bound as in 6: nsteps tol (1 + |x|) with |x| = 1.
  call ig%init(oscillator_t(), t0=0.0_wp)
  x = [1.0_wp, 0.0_wp]
  call propagate(ig, x, -3.0_wp, stat)
  call check_eq('backward: status', stat, TUBES_OK)
  call check_true('backward: lands on t = -3', ig%t == -3.0_wp)
  write (*, '(a,i0,a,es10.3)') '     backward: ', ig%nsteps, ' steps, error ', &
    norm2(x - [cos(3.0_wp), sin(3.0_wp)])
  call check_close('backward: x(-3) = cos 3', x(1), cos(3.0_wp), 2*ig%nsteps*1.0e-12_wp)
  call check_close('backward: v(-3) = sin 3', x(2), sin(3.0_wp), 2*ig%nsteps*1.0e-12_wp)
  ! time reversal: (x, v, t) -> (x, -v, -t) maps the oscillator to itself and (1, 0) to
  ! itself, so the backward run must mirror the forward run step for step: same count and
  ! the same numbers up to the order of the floating-point operations (a few ulps)
  nsteps_fwd = int(ig%nsteps)
  xf = x
  call ig%init(oscillator_t(), t0=0.0_wp)
  x = [1.0_wp, 0.0_wp]
  call propagate(ig, x, 3.0_wp, stat)
  call check_eq('backward mirrors forward: step count', nsteps_fwd, int(ig%nsteps))
  call check_close('backward mirrors forward: x', xf(1), x(1), 4*EPS)
  call check_close('backward mirrors forward: v', xf(2), -x(2), 4*EPS)

  ! === 8. failure statuses ================================================================
  ! the model returns NaN with stat < 0 once x < 1/2 (t > pi/3 from (1, 0))
  call ig%init(nan_oscillator_t(), t0=0.0_wp)
  x = [1.0_wp, 0.0_wp]
  call propagate(ig, x, 10.0_wp, stat)
  call check_eq('NaN model: status TUBES_EMODEL', stat, TUBES_EMODEL)
  ! outputs stay at the last accepted step: finite, before pi/3, on the exact solution
  ! (global error bound of 7)
  call check_true('NaN model: x left at the last accepted step', &
                  all(abs(x) <= 1) .and. ig%t < PI/3)
  s = ig%t
  call check_close('NaN model: x = cos(t) at the last accepted step', x(1), cos(s), &
                   2*(ig%nsteps + 1)*1.0e-12_wp)
  ! step budget
  call ig%init(oscillator_t(), t0=0.0_wp)
  ig%h = 0.1_wp
  ig%max_steps = 5
  x = [1.0_wp, 0.0_wp]
  call propagate(ig, x, 10.0_wp, stat)
  call check_eq('max_steps = 5: status TUBES_EMAXSTEPS', stat, TUBES_EMAXSTEPS)
  call check_eq('max_steps = 5: five steps taken', int(ig%nsteps), 5)
  ! five additions of 0.1: a few ulps of 0.5
  call check_close('max_steps = 5: t = 0.5', ig%t, 0.5_wp, 8*EPS)
  ! the fixed-step error of 5 steps of 0.1 is ~1e-16 (section 2 scaled): roundoff only
  call check_close('max_steps = 5: x = cos(0.5)', x(1), cos(0.5_wp), 1.0e-14_wp)

  call finish('test_dop853')
end program test_dop853
