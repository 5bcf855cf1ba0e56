!> Test models and probes for test_backends: the harmonic oscillator x'' = -x (state (x, v),
!> exact flow a rotation), the same oscillator failing (NaN, fatal) below x = 1/2, one that
!> refuses (recoverably) states off its circle (shy_oscillator_t with r2max), and observers that measure each step.
module test_backends_models
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
  use tubes_kinds, only: wp
  use tubes_test_models, only: oscillator_t, nan_oscillator_t, shy_oscillator_t, rotate
  use tubes_field, only: vector_field_t
  use tubes_integrator, only: integrator_t, observer_t
  use tubes_ball, only: ball_t
  implicit none
  private
  public :: oscillator_t, nan_oscillator_t, shy_oscillator_t, osc_probe_t, ball_probe_t
  public :: rotate

  !> For each accepted step of an oscillator run: the step h, the local error of the step
  !> (|x_new - exact flow from x_old|, x_old the previous accepted state) and the largest
  !> dense-output error at theta = 1/4, 1/2, 3/4 against the same exact flow.
  type, extends(observer_t) :: osc_probe_t
    real(wp) :: xprev(2) = [1.0_wp, 0.0_wp]   !! the last accepted state
    real(wp) :: h_cut = 0                     !! length of a step cut by an event
    integer :: n = 0
    real(wp), allocatable :: h(:), e_step(:), e_dense(:)
  contains
    procedure :: on_step => osc_on_step
  end type osc_probe_t

  !> Sums over the accepted steps of a ball run, for the error bounds of the test:
  !> s_state = sum_k (1 + |z_k|_inf) and s_energy = sum_k |f(z_k)|_2 (1 + |z_k|_inf), the max
  !> over the two ends z_k of each step.
  type, extends(observer_t) :: ball_probe_t
    type(ball_t) :: ball
    real(wp) :: zprev(4) = 0
    real(wp) :: s_state = 0, s_energy = 0
  contains
    procedure :: on_step => ball_on_step
  end type ball_probe_t

contains

  subroutine osc_on_step(self, ig, t_hi)
    class(osc_probe_t), intent(inout) :: self
    class(integrator_t), intent(inout) :: ig
    real(wp), intent(in) :: t_hi
    real(wp) :: xs(2), xn(2), h, ed
    integer :: j
    if (t_hi /= ig%t) then       ! a step cut by an event: not a whole step
      self%h_cut = abs(ig%t - ig%t_old)
      return
    end if
    h = ig%t - ig%t_old
    ed = 0
    do j = 1, 3
      call ig%interp(ig%t_old + j*h/4, xs)
      ed = max(ed, norm2(xs - rotate(self%xprev, j*h/4)))
    end do
    call ig%interp(ig%t, xn)
    call append(self, abs(h), norm2(xn - rotate(self%xprev, h)), ed)
    self%xprev = xn
  end subroutine osc_on_step

  subroutine append(self, h, es, ed)
    class(osc_probe_t), intent(inout) :: self
    real(wp), intent(in) :: h, es, ed
    real(wp), allocatable :: tmp(:, :)
    integer :: m
    if (.not. allocated(self%h)) allocate (self%h(256), self%e_step(256), self%e_dense(256))
    m = size(self%h)
    if (self%n == m) then
      allocate (tmp(m, 3))
      tmp(:, 1) = self%h
      tmp(:, 2) = self%e_step
      tmp(:, 3) = self%e_dense
      deallocate (self%h, self%e_step, self%e_dense)
      allocate (self%h(2*m), self%e_step(2*m), self%e_dense(2*m))
      self%h(1:m) = tmp(:, 1)
      self%e_step(1:m) = tmp(:, 2)
      self%e_dense(1:m) = tmp(:, 3)
    end if
    self%n = self%n + 1
    self%h(self%n) = h
    self%e_step(self%n) = es
    self%e_dense(self%n) = ed
  end subroutine append

  subroutine ball_on_step(self, ig, t_hi)
    class(ball_probe_t), intent(inout) :: self
    class(integrator_t), intent(inout) :: ig
    real(wp), intent(in) :: t_hi
    real(wp) :: zn(4), f0(4), f1(4), w
    integer :: st
    call ig%interp(ig%t, zn)
    call self%ball%eval(ig%t_old, self%zprev, f0, st)
    call self%ball%eval(ig%t, zn, f1, st)
    w = 1 + max(maxval(abs(self%zprev)), maxval(abs(zn)))
    self%s_state = self%s_state + w
    self%s_energy = self%s_energy + w*max(norm2(f0), norm2(f1))
    self%zprev = zn
  end subroutine ball_on_step

end module test_backends_models


!> The GSL and SUNDIALS backends of integrator_t (gsl_rk8pd, gsl_rk4imp, cvode_adams with
!> the fixed-point and with the Newton corrector, arkode_erk8) against the analytic oscillator
!> and DOP853 on the rolling ball, with convergence rates, energy conservation, dense output,
!> events, failure statuses, restarts, counters, and two instances at once (interleaved, and
!> in two OpenMP threads).
!>
!> Error bounds. Every accepted step commits a local error d with |d|_2 <= CB tol (1 + |z|_inf)
!> (rtol = atol = tol): GSL's y_new control accepts max_i |err_i|/(atol + rtol |z_i|) <= 1.1,
!> SUNDIALS (and DOP853) a weighted RMS <= 1, i.e. |err|_2 <= sqrt(n) max_i w_i; CB = 1.1
!> sqrt(n) covers both. (For CVODE this is its estimate of the local error of the order-q
!> solution it propagates; the Runge-Kutta pairs propagate the higher-order solution, whose
!> error is far below the estimate.) Global errors are sums of local errors carried by the flow.
program test_backends
  use tubes_kinds, only: wp, i8
  use tubes_status, only: TUBES_OK, TUBES_EVENT, TUBES_EMODEL, TUBES_EMAXSTEPS
  use tubes_field, only: vector_field_t
  use tubes_integrator, only: integrator_t, propagate, plane_t
  use tubes_dop853, only: dop853_t
  use tubes_gsl, only: gsl_t
  use tubes_sundials, only: cvode_t, arkode_t
  use tubes_fourwell, only: fourwell_t
  use tubes_ball, only: ball_t, make_ball
  use tubes_variational, only: variational_t, make_variational, stm_start
  use tubes_check, only: check_close, check_true, check_eq, finish
  use test_backends_models, only: oscillator_t, nan_oscillator_t, shy_oscillator_t, &
                                  osc_probe_t, ball_probe_t, rotate
  use tubes_test_models, only: X0_BALL, PI, EPS
  implicit none

  integer, parameter :: NB = 5
  integer, parameter :: RK8PD = 1, RK4IMP = 2, CVODE_FP = 3, CVODE_NEWTON = 4, ERK8 = 5
  character(*), parameter :: NAMES(NB) = [character(18) :: 'gsl_rk8pd', 'gsl_rk4imp', &
                                          'cvode_adams', 'cvode_adams/newton', 'arkode_erk8']
  real(wp), parameter :: T_BALL = 2.0_wp   ! [s]
  real(wp), parameter :: CB2 = 1.1_wp*sqrt(2.0_wp), CB4 = 1.1_wp*2   ! CB for n = 2, 4

  class(integrator_t), allocatable :: ig
  type(ball_t) :: ball
  real(wp) :: zref(4), ref_bound, g_amp
  real(wp) :: c_dense(NB)   ! error constant of each backend's dense output, e <= c h^(d+1)
  integer :: d_dense(NB)    ! and its degree d
  integer :: b

  call make_ball(ball, fourwell_t(), 981.0_wp)
  call ball_reference(zref, ref_bound, g_amp)
  do b = 1, NB
    write (*, '(/,a,a)') '=== ', trim(NAMES(b))
    call oscillator_ladder(b)
    call oscillator_dense(b)
    call oscillator_event(b)
    call ball_checks(b)
    call failure_checks(b)
    call restart_checks(b)
    call count_checks(b)
  end do
  call two_instances()
  deallocate (ig)   ! frees the solver memory (final); main-program variables are never finalized
  call finish('test_backends')

contains

  !> A new integrator of backend b (integrator_t's default settings).
  !> Back-end b, set to integrate field from t = 0 at rtol = atol = tol.
  subroutine new_backend(b, ig, field, tol)
    integer, intent(in) :: b
    class(integrator_t), allocatable, intent(out) :: ig
    class(vector_field_t), intent(in) :: field
    real(wp), intent(in) :: tol
    select case (b)
    case (RK8PD); allocate (ig, source=gsl_t(kind='gsl_rk8pd'))
    case (RK4IMP); allocate (ig, source=gsl_t(kind='gsl_rk4imp'))
    case (CVODE_FP); allocate (ig, source=cvode_t(nonlinear='fixedpoint'))
    case (CVODE_NEWTON); allocate (ig, source=cvode_t(nonlinear='newton'))
    case (ERK8); allocate (arkode_t :: ig)
    end select
    call ig%init(field, 0.0_wp)
    ig%rtol = tol
    ig%atol = tol
  end subroutine new_backend

  !> Least-squares slope of y against x.
  pure real(wp) function slope(x, y)
    real(wp), intent(in) :: x(:), y(:)
    real(wp) :: mx, my
    mx = sum(x)/size(x)
    my = sum(y)/size(y)
    slope = sum((x - mx)*(y - my))/sum((x - mx)**2)
  end function slope

  !> Expected d log(global error)/d log(tol), and the window allowed around it.
  !> Steps are sized so that the estimated local error of the embedded (or step-doubled)
  !> solution of order q, ~ h^(q+1), meets tol; the propagated solution of order p then has a
  !> global error ~ N h^(p+1) ~ h^p ~ tol^(p/(q+1)): 8/8 = 1 for Prince-Dormand 8(7) and
  !> Fehlberg 8(7), 4/5 for rk4imp (order 4; the estimate by step doubling is that of the
  !> order-4 two-half-step result). CVODE's Adams order q varies (1..12): q/(q+1) in
  !> [1/2, 12/13]. The windows add +-0.2 for the imperfect proportionality of real controllers
  !> (h set from the previous step's estimate, safety factors, the starting steps).
  subroutine rate_window(b, w)
    integer, intent(in) :: b
    real(wp), intent(out) :: w(2)
    select case (b)
    case (RK8PD, ERK8); w = [0.8_wp, 1.2_wp]
    case (RK4IMP); w = [0.6_wp, 1.0_wp]
    case default; w = [0.5_wp - 0.2_wp, 12.0_wp/13 + 0.2_wp]
    end select
  end subroutine rate_window

  ! ======================================================================== oscillator
  !> x = cos t from (1, 0) to t = 10 at tol = 1e-5 ... 1e-11: accuracy, convergence rate in
  !> tol, and the order of the local error.
  subroutine oscillator_ladder(b)
    integer, intent(in) :: b
    integer, parameter :: K0 = 5, K1 = 11
    real(wp) :: err(K0:K1), tol, x(2), lt(K0:K1), s, w(2)
    integer(i8) :: nst(K0:K1)
    integer :: k, stat, m
    character(100) :: lbl
    type(osc_probe_t) :: probe
    real(wp), allocatable :: lh(:), le(:)
    logical, allocatable :: use(:)
    allocate (lh(0), le(0))
    do k = K0, K1
      tol = 10.0_wp**(-k)
      call new_backend(b, ig, oscillator_t(), tol)
      x = [1.0_wp, 0.0_wp]
      probe = osc_probe_t()
      call propagate(ig, x, 10.0_wp, stat, observer=probe)
      write (lbl, '(a,a,es7.1)') trim(NAMES(b)), ': oscillator status and t = 10, tol ', tol
      call check_true(trim(lbl), stat == TUBES_OK .and. ig%t == 10.0_wp)
      err(k) = norm2(x - rotate([1.0_wp, 0.0_wp], 10.0_wp))
      nst(k) = ig%nsteps
      lt(k) = log10(tol)
      write (*, '(a,es7.1,a,es10.3,a,i5,a,i6,a,i3,a,i5,a,es9.2)') '     tol ', tol, ' err ', &
        err(k), ' steps ', ig%nsteps, ' nfev ', ig%nfev, ' rej ', ig%nrejected, ' niter ', &
        ig%niter, ' err/(N tol) ', err(k)/(nst(k)*tol)
      ! the rotation carries earlier local errors along without growth: the global error is
      ! at most their sum, N CB tol (1 + |x|_inf) <= 2 CB N tol
      write (lbl, '(a,a,es7.1)') trim(NAMES(b)), ': oscillator error <= 2 CB N tol, tol ', tol
      call check_close(trim(lbl), err(k), 0.0_wp, 2*CB2*nst(k)*tol)
      if (k <= 8) then
        ! local errors of the whole steps (the last one is cut to land on t = 10) that stand
        ! >= 1000 ulps above roundoff, for the order fit below
        m = probe%n - 1
        use = probe%e_step(1:m) > 1000*EPS
        lh = [lh, log10(pack(probe%h(1:m), use))]
        le = [le, log10(pack(probe%e_step(1:m), use))]
      end if
    end do
    write (lbl, '(a,a)') trim(NAMES(b)), ': oscillator error(1e-8) < error(1e-5)'
    call check_true(trim(lbl), err(8) < err(5))
    write (lbl, '(a,a)') trim(NAMES(b)), ': oscillator error(1e-11) < error(1e-8)'
    call check_true(trim(lbl), err(11) < err(8))
    s = slope(lt, log10(err))
    call rate_window(b, w)
    write (*, '(a,f6.3)') '     d log(err)/d log(tol) = ', s
    write (lbl, '(a,a,f4.2,a,f4.2,a)') trim(NAMES(b)), &
      ': oscillator d log(err)/d log(tol) in [', w(1), ', ', w(2), ']'
    call check_true(trim(lbl), s >= w(1) .and. s <= w(2))
    ! Order of the one-step methods from their local errors. On x'' = -x a Runge-Kutta step
    ! of size h maps x to R(ih) x, so its local error |R(ih) - exp(ih)| depends on h alone:
    ! C h^(r+1) with r >= p the order of the stability function R. Gauss-Legendre (rk4imp)
    ! has R = the (2,2) Pade approximant, r = 4 exactly (the two half steps keep h^5).
    ! Prince-Dormand 8(7) as coded in GSL has b.A^8.1 = (1 - 0.0013)/9!: in the measurable
    ! range (h ~ 0.2..1; local errors above roundoff) its h^10 term dominates, slope 9..10.
    ! Fehlberg 8(7): r >= 8. Windows: [4.5, 5.5] and [8.5, 10.5].
    if (b == RK8PD .or. b == RK4IMP .or. b == ERK8) then
      s = slope(lh, le)
      write (*, '(a,f6.3,a,i0,a)') '     local error exponent (fit): ', s, ' (', size(lh), &
        ' steps, tol 1e-5..1e-8)'
      if (b == RK4IMP) then
        w = [4.5_wp, 5.5_wp]
      else
        w = [8.5_wp, 10.5_wp]
      end if
      write (lbl, '(a,a,f4.1,a,f4.1,a)') trim(NAMES(b)), ': local error ~ h^e, e in [', &
        w(1), ', ', w(2), ']'
      call check_true(trim(lbl), s >= w(1) .and. s <= w(2))
    end if
  end subroutine oscillator_ladder

  !> Dense output at theta = 1/4, 1/2, 3/4 of every step against the exact flow from the
  !> step's start (tol 1e-8).
  subroutine oscillator_dense(b)
    integer, intent(in) :: b
    type(osc_probe_t) :: probe
    real(wp) :: x(2), tol, bnd, s, w(2)
    integer :: stat, k, nbad, m
    logical, allocatable :: use(:)
    character(100) :: lbl
    tol = 1.0e-8_wp
    call new_backend(b, ig, oscillator_t(), tol)
    x = [1.0_wp, 0.0_wp]
    call propagate(ig, x, 10.0_wp, stat, observer=probe)
    m = probe%n
    write (*, '(a,es9.2,a,es9.2,a,es9.2)') '     dense output, tol 1e-8: max error ', &
      maxval(probe%e_dense(1:m)), ', max step error ', maxval(probe%e_step(1:m)), &
      ', max h ', maxval(probe%h(1:m))
    nbad = 0
    select case (b)
    case (RK8PD, RK4IMP)
      ! cubic Hermite: x - p = x''''(xi)/4! (s - t0)^2 (s - t1)^2, |.| <= h^4/384 per
      ! component (x'''' = x on the unit circle), sqrt(2) h^4/384 in 2-norm; plus the error
      ! of the data at t1 (the step's local error, measured) and roundoff
      do k = 1, m
        bnd = sqrt(2.0_wp)*probe%h(k)**4/384 + probe%e_step(k) + 8*EPS
        if (.not. probe%e_dense(k) <= bnd) nbad = nbad + 1
      end do
      write (lbl, '(a,a)') trim(NAMES(b)), &
        ': Hermite dense output error <= sqrt(2) h^4/384 + step error, every step'
      call check_eq(trim(lbl), nbad, 0)
      d_dense(b) = 3
      c_dense(b) = sqrt(2.0_wp)/384
    case (CVODE_FP, CVODE_NEWTON)
      ! CVODE's interpolant is its Nordsieck polynomial, whose corrections the error test
      ! controls along with the solution: local error <= CB tol (1 + |x|_inf) <= 2 CB tol
      do k = 1, m
        if (.not. probe%e_dense(k) <= 2*CB2*tol) nbad = nbad + 1
      end do
      write (lbl, '(a,a)') trim(NAMES(b)), ': Nordsieck dense output error <= 2 CB tol, every step'
      call check_eq(trim(lbl), nbad, 0)
      d_dense(b) = 0
      c_dense(b) = 2*CB2*tol
    case (ERK8)
      ! ARKODE's Hermite interpolant of degree d (interp_degree = 4: y, f at both ends and
      ! f at t_old + 2h/3, taken at the cubic interpolant's state) errs by C h^(d+1) on the
      ! oscillator, independently of the state (rotation invariance); fit d + 1 = 5 (+-0.5)
      ! over the steps whose interpolation error stands 100x above the step's own error
      use = probe%e_dense(1:m) > 100*probe%e_step(1:m) .and. probe%e_dense(1:m) > 1000*EPS
      s = slope(log10(pack(probe%h(1:m), use)), log10(pack(probe%e_dense(1:m), use)))
      write (*, '(a,f6.3,a,i0,a)') '     dense error exponent (fit): ', s, ' (', count(use), &
        ' steps)'
      w = [4.5_wp, 5.5_wp]
      write (lbl, '(a,a)') trim(NAMES(b)), ': Hermite (degree 4) dense output error ~ h^5'
      call check_true(trim(lbl), s >= w(1) .and. s <= w(2))
      d_dense(b) = 4
      c_dense(b) = maxval(probe%e_dense(1:m)/probe%h(1:m)**5, mask=use)
      write (*, '(a,es9.2)') '     its constant: max error/h^5 = ', c_dense(b)
    end select
  end subroutine oscillator_dense

  !> x(1) = 0 falling from (1, 0): t = pi/2, located on the dense output (tol 1e-10).
  subroutine oscillator_event(b)
    integer, intent(in) :: b
    type(osc_probe_t) :: probe
    real(wp) :: x(2), tol, bnd
    integer :: stat
    character(100) :: lbl
    tol = 1.0e-10_wp
    call new_backend(b, ig, oscillator_t(), tol)
    x = [1.0_wp, 0.0_wp]
    call propagate(ig, x, 10.0_wp, stat, event=plane_t(k=1, c=0.0_wp, direction=-1), &
                   observer=probe)
    write (lbl, '(a,a)') trim(NAMES(b)), ': event status TUBES_EVENT'
    call check_eq(trim(lbl), stat, TUBES_EVENT)
    ! |dx/dt| = 1 at the root, so the time error is the state error there: the global error
    ! before the step (2 CB N tol), the dense output's error on the cut step (the constant
    ! of oscillator_dense times h^(d+1); CVODE: 2 CB tol), Illinois' bracket (4 eps t)
    if (d_dense(b) > 0) then
      bnd = 2*CB2*ig%nsteps*tol + c_dense(b)*probe%h_cut**(d_dense(b) + 1) + 2*CB2*tol
    else
      bnd = 2*CB2*ig%nsteps*tol + 2*CB2*tol
    end if
    bnd = bnd + 8*EPS
    write (*, '(a,es10.3,a,es9.2,a,i0,a,es9.2)') '     event time error ', ig%t - PI/2, &
      ' (bound ', bnd, ') after ', ig%nsteps, ' steps; cut step ', probe%h_cut
    write (lbl, '(a,a)') trim(NAMES(b)), ': event time = pi/2'
    call check_close(trim(lbl), ig%t, PI/2, bnd)
    write (lbl, '(a,a)') trim(NAMES(b)), ': state at the event = (0, -1)'
    call check_close(trim(lbl), norm2(x - [0.0_wp, -1.0_wp]), 0.0_wp, 2*bnd)
  end subroutine oscillator_event

  ! ======================================================================== rolling ball
  !> DOP853 at tol 1e-14 to t = 2 s, its error bound, and the error amplification G of the
  !> flow: G = max_t |Phi(T, t)|_F over a 0.01 s grid, Phi(T, t) = Phi(T, 0) Phi(t, 0)^-1 and
  !> Phi^-1 = -Omega Phi^T Omega (symplectic), from the variational equations.
  subroutine ball_reference(zref, ref_bound, g_amp)
    real(wp), intent(out) :: zref(4), ref_bound, g_amp
    type(dop853_t) :: ref
    type(variational_t) :: var
    type(ball_probe_t) :: bp
    real(wp) :: z(20), phis(4, 4, 0:200), om(4, 4), pinv(4, 4)
    integer :: stat, k
    call make_variational(var, ball)
    call ref%init(var, 0.0_wp)
    ref%rtol = 1.0e-12_wp
    ref%atol = 1.0e-12_wp
    z = stm_start(X0_BALL)
    phis(:, :, 0) = reshape(z(5:20), [4, 4])
    do k = 1, 200
      call propagate(ref, z, k*0.01_wp, stat)
      phis(:, :, k) = reshape(z(5:20), [4, 4])
    end do
    om = 0
    om(1, 3) = 1
    om(2, 4) = 1
    om(3, 1) = -1
    om(4, 2) = -1
    g_amp = 0
    do k = 0, 200
      pinv = -matmul(om, matmul(transpose(phis(:, :, k)), om))
      g_amp = max(g_amp, norm2(matmul(phis(:, :, 200), pinv)))
    end do
    call ref%init(ball, 0.0_wp)
    ref%rtol = 1.0e-14_wp
    ref%atol = 1.0e-14_wp
    zref = X0_BALL
    bp%ball = ball
    bp%zprev = X0_BALL
    call propagate(ref, zref, T_BALL, stat, observer=bp)
    ref_bound = g_amp*CB4*ref%rtol*bp%s_state
    write (*, '(a,i0,a,es9.2,a,f7.1)') 'reference: DOP853 tol 1e-14, ', ref%nsteps, &
      ' steps, error bound ', ref_bound, '; G = ', g_amp
  end subroutine ball_reference

  !> The rolling ball on the four-well surface, from rest at (4, 12.61...) cm to t = 2 s.
  subroutine ball_checks(b)
    integer, intent(in) :: b
    type(ball_probe_t) :: bp
    real(wp) :: z(4), e0, tl(2), err(2), de(2), bnd, s, w(2)
    integer :: i, stat
    character(100) :: lbl
    tl = [1.0e-8_wp, 1.0e-11_wp]
    e0 = ball%energy(X0_BALL)
    do i = 1, 2
      call new_backend(b, ig, ball, tl(i))
      z = X0_BALL
      bp%ball = ball   ! (assignment, not a structure constructor: STYLE.md)
      bp%zprev = X0_BALL
      bp%s_state = 0
      bp%s_energy = 0
      call propagate(ig, z, T_BALL, stat, observer=bp)
      write (lbl, '(a,a,es7.1)') trim(NAMES(b)), ': ball status and t = 2 s, tol ', tl(i)
      call check_true(trim(lbl), stat == TUBES_OK .and. ig%t == T_BALL)
      err(i) = norm2(z - zref)
      de(i) = abs(ball%energy(z) - e0)
      ! global error <= G sum_k |d_k|_2 <= G CB tol sum_k (1 + |z_k|_inf), plus the
      ! reference's own bound
      bnd = g_amp*CB4*tl(i)*bp%s_state + ref_bound
      write (*, '(a,es7.1,a,es10.3,a,es9.2,a,es10.3,a,es9.2,a,i5,a,i6,a,i4)') '     tol ', &
        tl(i), ' |z - z_dop853| ', err(i), ' (bound ', bnd, ')  |dE| ', de(i), ' (bound ', &
        CB4*tl(i)*bp%s_energy, ') steps ', ig%nsteps, ' nfev ', ig%nfev, ' rej ', ig%nrejected
      write (lbl, '(a,a,es7.1)') trim(NAMES(b)), &
        ': ball = DOP853 within G CB tol sum(1 + |z|), tol ', tl(i)
      call check_close(trim(lbl), err(i), 0.0_wp, bnd)
      ! the flow conserves E, so a local error d_k changes E by grad E . d_k for good:
      ! |dE| <= sum_k |grad E|_2 |d_k|_2, and in canonical coordinates
      ! |grad E| = |(-dp/dt, dq/dt)| = |f|
      write (lbl, '(a,a,es7.1)') trim(NAMES(b)), &
        ': ball energy error <= CB tol sum |f| (1 + |z|), tol ', tl(i)
      call check_close(trim(lbl), de(i), 0.0_wp, CB4*tl(i)*bp%s_energy)
    end do
    ! the error falls with the tolerance at the rate of oscillator_ladder
    s = log10(err(1)/err(2))/3
    call rate_window(b, w)
    write (*, '(a,f6.3)') '     ball d log(err)/d log(tol) = ', s
    write (lbl, '(a,a,f4.2,a,f4.2,a)') trim(NAMES(b)), &
      ': ball d log(err)/d log(tol) (1e-8 -> 1e-11) in [', w(1), ', ', w(2), ']'
    call check_true(trim(lbl), s >= w(1) .and. s <= w(2))
  end subroutine ball_checks

  ! ======================================================================== failures
  subroutine failure_checks(b)
    integer, intent(in) :: b
    real(wp) :: x(2), tol
    integer :: stat
    character(100) :: lbl
    tol = 1.0e-10_wp
    ! a fatal model failure (NaN, stat < 0 below x = 1/2, i.e. after t = pi/3)
    call new_backend(b, ig, nan_oscillator_t(), tol)
    x = [1.0_wp, 0.0_wp]
    call propagate(ig, x, 10.0_wp, stat)
    write (*, '(a,f9.6,a,i0,a,a)') '     NaN model stopped at t = ', ig%t, ', flag ', &
      solver_flag(ig), ': ', trim(solver_msg(ig))
    write (lbl, '(a,a)') trim(NAMES(b)), ': NaN model: TUBES_EMODEL'
    call check_eq(trim(lbl), stat, TUBES_EMODEL)
    write (lbl, '(a,a)') trim(NAMES(b)), ': NaN model: t, x at the last accepted step'
    call check_true(trim(lbl), ig%t > 0 .and. ig%t < PI/3 .and. all(abs(x) <= 1))
    write (lbl, '(a,a)') trim(NAMES(b)), ': NaN model: x = cos(t) there (2 CB N tol)'
    call check_close(trim(lbl), x(1), cos(ig%t), 2*CB2*(ig%nsteps + 1)*tol)
    write (lbl, '(a,a)') trim(NAMES(b)), ': NaN model: solver flag and message kept'
    call check_true(trim(lbl), solver_flag(ig) /= 0 .and. len_trim(solver_msg(ig)) > 0)
    ! a recoverable refusal (stat > 0) of states more than 1e-6 off the unit circle: the
    ! stages of long steps leave it. GSL halves the step, CVODE retries the corrector with a
    ! smaller step; ERKStep (SUNDIALS 6.4.1) cannot recover and stops (ARK_UNREC_RHSFUNC_ERR)
    call new_backend(b, ig, shy_oscillator_t(r2max=1 + 1.0e-6_wp), tol)
    x = [1.0_wp, 0.0_wp]
    call propagate(ig, x, 10.0_wp, stat)
    write (*, '(a,i0,a,i0,a,i0,a,es10.3,a,a)') '     picky model: status ', stat, ', steps ', &
      ig%nsteps, ', rejected ', ig%nrejected, ', err ', &
      norm2(x - rotate([1.0_wp, 0.0_wp], ig%t)), ' ', trim(solver_msg(ig))
    if (b == ERK8) then
      write (lbl, '(a,a)') trim(NAMES(b)), ': picky model: TUBES_EMODEL, ARK_UNREC_RHSFUNC_ERR'
      call check_true(trim(lbl), stat == TUBES_EMODEL .and. solver_flag(ig) == -11)
    else
      write (lbl, '(a,a)') trim(NAMES(b)), ': picky model: recovers, TUBES_OK at t = 10'
      call check_true(trim(lbl), stat == TUBES_OK .and. ig%t == 10.0_wp)
      if (b == RK8PD) then
        ! the plain oscillator run at this tol rejects no step (oscillator_ladder): every
        ! rejection here is a refused stage that made evolve halve the step
        write (lbl, '(a,a)') trim(NAMES(b)), ': picky model: refusals were retried (rejected > 0)'
        call check_true(trim(lbl), ig%nrejected > 0)
      end if
      write (lbl, '(a,a)') trim(NAMES(b)), ': picky model: x(10) within 2 CB N tol'
      call check_close(trim(lbl), norm2(x - rotate([1.0_wp, 0.0_wp], 10.0_wp)), 0.0_wp, &
                       2*CB2*ig%nsteps*tol)
    end if
    ! step budget
    call new_backend(b, ig, oscillator_t(), tol)
    ig%max_steps = 3
    x = [1.0_wp, 0.0_wp]
    call propagate(ig, x, 10.0_wp, stat)
    write (lbl, '(a,a)') trim(NAMES(b)), ': max_steps = 3: TUBES_EMAXSTEPS'
    call check_eq(trim(lbl), stat, TUBES_EMAXSTEPS)
    write (lbl, '(a,a)') trim(NAMES(b)), ': max_steps = 3: three steps, 0 < t < 10'
    call check_true(trim(lbl), ig%nsteps == 3 .and. ig%t > 0 .and. ig%t < 10)
    write (lbl, '(a,a)') trim(NAMES(b)), ': max_steps = 3: x on the exact solution (6 CB tol)'
    call check_close(trim(lbl), norm2(x - rotate([1.0_wp, 0.0_wp], ig%t)), 0.0_wp, 2*CB2*3*tol)
  end subroutine failure_checks

  integer function solver_flag(ig)
    class(integrator_t), intent(in) :: ig
    select type (ig)
    type is (gsl_t); solver_flag = ig%solver_flag
    type is (cvode_t); solver_flag = ig%solver_flag
    type is (arkode_t); solver_flag = ig%solver_flag
    class default; solver_flag = 0
    end select
  end function solver_flag

  function solver_msg(ig) result(msg)
    class(integrator_t), intent(in) :: ig
    character(:), allocatable :: msg
    select type (ig)
    type is (gsl_t); msg = trim(ig%solver_msg)
    type is (cvode_t); msg = trim(ig%solver_msg)
    type is (arkode_t); msg = trim(ig%solver_msg)
    class default; msg = ''
    end select
  end function solver_msg

  ! ======================================================================== restarts
  !> init() again on a used instance (another model and dimension), and destroy(), must give
  !> the very numbers of a new instance.
  subroutine restart_checks(b)
    integer, intent(in) :: b
    class(integrator_t), allocatable :: fresh_ig
    real(wp) :: x(2), z(4), zf(4)
    integer :: stat, st2
    character(100) :: lbl
    call new_backend(b, ig, oscillator_t(), 1.0e-9_wp)
    x = [1.0_wp, 0.0_wp]
    call propagate(ig, x, 3.0_wp, stat)
    call ig%init(ball, 0.0_wp)
    z = X0_BALL
    call propagate(ig, z, 0.5_wp, stat)
    call new_backend(b, fresh_ig, ball, 1.0e-9_wp)
    zf = X0_BALL
    call propagate(fresh_ig, zf, 0.5_wp, st2)
    write (lbl, '(a,a)') trim(NAMES(b)), ': init() again (new model, n 2 -> 4) = new instance'
    call check_true(trim(lbl), stat == TUBES_OK .and. st2 == TUBES_OK .and. all(z == zf) .and. &
                    ig%nsteps == fresh_ig%nsteps .and. ig%nfev == fresh_ig%nfev)
    call destroy(ig)
    call ig%init(ball, 0.0_wp)
    z = X0_BALL
    call propagate(ig, z, 0.5_wp, stat)
    write (lbl, '(a,a)') trim(NAMES(b)), ': destroy() then init() = new instance'
    call check_true(trim(lbl), stat == TUBES_OK .and. all(z == zf) .and. ig%nfev == fresh_ig%nfev)
  end subroutine restart_checks

  subroutine destroy(ig)
    class(integrator_t), intent(inout) :: ig
    select type (ig)
    type is (gsl_t); call ig%destroy()
    type is (cvode_t); call ig%destroy()
    type is (arkode_t); call ig%destroy()
    end select
  end subroutine destroy

  ! ======================================================================== counters
  !> nfev, counted in tubes' callback, against the solver's own count or the stage count.
  subroutine count_checks(b)
    integer, intent(in) :: b
    real(wp) :: x(2)
    integer :: stat
    integer(i8) :: nsolver
    character(100) :: lbl
    call new_backend(b, ig, oscillator_t(), 1.0e-9_wp)
    x = [1.0_wp, 0.0_wp]
    call propagate(ig, x, 10.0_wp, stat)
    select type (ig)
    type is (gsl_t)
      if (b == RK8PD) then
        ! 2 evaluations for the starting step, f(t0, x0), then per attempt 12 new stages
        ! (k1 = f at the step's start) and f at the end, which evolve reuses as the next
        ! step's f at the start (GSL 2.7)
        write (*, '(a,i0,a,i0,a,i0)') '     nfev ', ig%nfev, ', steps ', ig%nsteps, &
          ', rejected ', ig%nrejected
        write (lbl, '(a,a)') trim(NAMES(b)), ': nfev = 3 + 13 (accepted + rejected)'
        call check_eq(trim(lbl), int(ig%nfev), int(3 + 13*(ig%nsteps + ig%nrejected)))
      else
        write (*, '(a,i0,a,i0,a,i0)') '     nfev ', ig%nfev, ', Jacobians ', ig%njev, &
          ', steps ', ig%nsteps
        write (lbl, '(a,a)') trim(NAMES(b)), ': one Jacobian per attempt'
        call check_eq(trim(lbl), int(ig%njev), int(ig%nsteps + ig%nrejected))
      end if
    type is (cvode_t)
      nsolver = ig%solver_rhs_evals()
      write (*, '(a,i0,a,i0,a,i0)') '     nfev ', ig%nfev, ', CVODE counted ', nsolver, &
        ', Jacobians ', ig%njev
      write (lbl, '(a,a)') trim(NAMES(b)), ': nfev = CVodeGetNumRhsEvals'
      call check_eq(trim(lbl), int(ig%nfev), int(nsolver))
    type is (arkode_t)
      nsolver = ig%solver_rhs_evals()
      write (*, '(a,i0,a,i0,a,i0,a,i0)') '     nfev ', ig%nfev, ', ERKStep counted ', &
        nsolver, ', steps ', ig%nsteps, ', rejected ', ig%nrejected
      ! tubes' starting step costs 2 evaluations that ERKStep does not see
      write (lbl, '(a,a)') trim(NAMES(b)), ': nfev = 2 + ERKStepGetNumRhsEvals'
      call check_eq(trim(lbl), int(ig%nfev), int(2 + nsolver))
      ! 13 Fehlberg stages + 1 inert (see tubes_sundials) = 13 new evaluations per attempt,
      ! f(y_n+1) after each accepted step, f(y_0) at the start, and 1 for the degree-4
      ! interpolant ERKStep evaluates to return y at the stop time (one stop, at t = 10)
      write (lbl, '(a,a)') trim(NAMES(b)), ': ERKStep count = 2 + 13 attempts + accepted'
      call check_eq(trim(lbl), int(nsolver), int(2 + 13*(ig%nsteps + ig%nrejected) + ig%nsteps))
    end select
  end subroutine count_checks

  ! ======================================================================== two at once
  !> Two instances of each backend alive together (oscillator and ball), stepped alternately
  !> and in two OpenMP threads, must reproduce the runs made one at a time bit for bit.
  subroutine two_instances()
    real(wp) :: xs(2), zs(4), xi(2), zi(4), xp(2), zp(4)
    integer(i8) :: ns(2), ni(2), np(2)
    integer :: b
    character(100) :: lbl
    write (*, '(/,a)') '=== two instances at once'
    do b = 1, NB
      call run_alone(b, 1, xs, ns(1))
      call run_alone(b, 2, zs, ns(2))
      call run_interleaved(b, xi, zi, ni)
      write (lbl, '(a,a)') trim(NAMES(b)), ': two instances stepped alternately = one at a time'
      call check_true(trim(lbl), all(xi == xs) .and. all(zi == zs) .and. all(ni == ns))
      !$omp parallel sections num_threads(2)
      !$omp section
      call run_alone(b, 1, xp, np(1))
      !$omp section
      call run_alone(b, 2, zp, np(2))
      !$omp end parallel sections
      write (lbl, '(a,a)') trim(NAMES(b)), ': two instances in two threads = one at a time'
      call check_true(trim(lbl), all(xp == xs) .and. all(zp == zs) .and. all(np == ns))
    end do
  end subroutine two_instances

  !> One of the two runs alone: k = 1 the oscillator (to its event x = 0 rising, then on to
  !> t = 10), k = 2 the ball to T_BALL; the final state and the evaluations.
  subroutine run_alone(b, k, x, nfev)
    integer, intent(in) :: b, k
    real(wp), intent(out) :: x(:)
    integer(i8), intent(out) :: nfev
    class(integrator_t), allocatable :: a
    integer :: stat
    if (k == 1) then
      call new_backend(b, a, oscillator_t(), 1.0e-9_wp)
      x = [1.0_wp, 0.0_wp]
      call propagate(a, x, 10.0_wp, stat, event=plane_t(k=1, c=0.0_wp, direction=1))
      call propagate(a, x, 10.0_wp, stat)
    else
      call new_backend(b, a, ball, 1.0e-9_wp)
      x = X0_BALL
      call propagate(a, x, T_BALL, stat)
    end if
    nfev = a%nfev
  end subroutine run_alone

  !> run_alone's two runs, one step of each in turn (the oscillator's event, restart included).
  subroutine run_interleaved(b, x, z, nfev)
    integer, intent(in) :: b
    real(wp), intent(out) :: x(2), z(4)
    integer(i8), intent(out) :: nfev(2)
    class(integrator_t), allocatable :: a1, a2
    integer :: stat, phase
    call new_backend(b, a1, oscillator_t(), 1.0e-9_wp)
    call new_backend(b, a2, ball, 1.0e-9_wp)
    x = [1.0_wp, 0.0_wp]
    z = X0_BALL
    a1%max_steps = 1
    a2%max_steps = 1
    phase = 1
    do while (phase <= 2 .or. a2%t < T_BALL)
      if (phase == 1) then       ! up to the event, one step per call
        call propagate(a1, x, 10.0_wp, stat, event=plane_t(k=1, c=0.0_wp, direction=1))
        if (stat == TUBES_EVENT) phase = 2
      else if (phase == 2 .and. a1%t < 10) then
        call propagate(a1, x, 10.0_wp, stat)
        if (a1%t == 10.0_wp) phase = 3
      end if
      if (a2%t < T_BALL) call propagate(a2, z, T_BALL, stat)
    end do
    nfev = [a1%nfev, a2%nfev]
  end subroutine run_interleaved

end program test_backends
