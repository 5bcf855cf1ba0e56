!> The test oscillator shared by the integrator and event tests: x'' = -x as the state (x, v),
!> whose exact flow is a rotation (also in real128, for the reference integrator), and two failing
!> variants (it was written out in six tests);
!> the probe of a method's dense output on it (it was written out in three); and its fixed-step
!> run to t = 10 of the convergence-order tests (written out in two); and the constants the tests
!> share.
module tubes_test_models
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
  use tubes_kinds, only: wp, qp, PI
  use tubes_dop853_qp, only: qp_field_t
  use tubes_status, only: TUBES_OK
  use tubes_field, only: vector_field_t, jet_spec_t
  use tubes_integrator, only: integrator_t, observer_t, propagate
  use tubes_check, only: check_eq, check_true
  use tubes_dop853, only: dop853_t
  use tubes_rk4, only: rk4_t
  use tubes_ball, only: ball_t, make_ball
  use tubes_fourwell, only: fourwell_t
  use tubes_hamiltonian, only: separable_t
  implicit none
  private
  public :: oscillator_t, qp_oscillator_t, nan_oscillator_t, shy_oscillator_t, rotate, dense_probe_t, &
            oscillator_fixed_step, ball_fixed_step, oscillator_start, affine_field_t, line_field, &
            fall_field, iso_field, quartic_bath_t

  public :: PI   !! tubes_kinds'
  real(wp), parameter, public :: EPS = epsilon(1.0_wp)
  !> The rolling ball's benchmark release (docs/benchmarks.md, problem 1): at rest at (4,
  !> 12.614863819914357) cm, dE = 1500 (cm/s)^2 above the saddles.
  real(wp), parameter, public :: X0_BALL(4) = [4.0_wp, 12.614863819914357_wp, 0.0_wp, 0.0_wp]

  !> A double well in q1 with a degenerate last coordinate (docs/models.md, "Degenerate
  !> equilibria"), unit masses: V = -q1^2/2 + q1^4/4 [+ w^2 q2^2/2 when N = 3] + (qN - s)^k/k,
  !> a root of dV/dqN of multiplicity m = k - 1 at qN = s. Equilibria: (+-1, 0.., s) at
  !> V = -1/4 (index 0, one zero mode) and (0, 0.., s) at V = 0 (index 1, one zero mode: D1).
  !> With cosines = .true. instead V = cos(q1) + cos(q2) (N = 2): an equilibrium every pi.
  type, extends(separable_t), public :: quartic_bath_t
    real(wp) :: s = 0          !! the degenerate coordinate's root
    integer :: k = 4           !! its power (even, >= 4)
    real(wp) :: w = 1.3_wp     !! the middle coordinate's frequency (N = 3)
    logical :: cosines = .false.
  contains
    procedure :: shape => qb_shape
    procedure :: shape_derivs => qb_shape_derivs
    procedure :: masses => qb_masses
  end type quartic_bath_t

  !> Samples interp at nsamp interior points of every accepted step (s = t_old + j h/(nsamp + 1))
  !> of an oscillator integration: the largest errors against the exact solution from (0, (1, 0))
  !> (global) and against the exact flow from the step's own start interp(t_old) (local: the
  !> interpolation error alone); the largest jump between a step's interp(t) and the next one's
  !> interp(t_old) (join); and for DOP853 and RK4, how far interp is from the step's end values.
  type, extends(observer_t) :: dense_probe_t
    integer :: nsamp = 3          !! interior samples per step
    real(wp) :: err_global = 0    !! max |interp(s) - exact(s)|
    real(wp) :: err_local = 0     !! max |interp(s) - exact flow from interp(t_old)|
    real(wp) :: err_join = 0      !! max |interp_k(t_k) - interp_(k+1)(t_k)|
    real(wp) :: err_ends = 0      !! max |interp(t_old) - x_old|, |interp(t) - x_new|
    real(wp) :: x_end(2) = 0      !! interp(t) of the previous step
    integer :: nsteps = 0
  contains
    procedure :: on_step => probe_on_step
  end type dense_probe_t

  !> x' = v, v' = -x.
  type, extends(vector_field_t) :: oscillator_t
  contains
    procedure :: dim => osc_dim
    procedure :: eval => osc_eval
    procedure :: jacobian => osc_jacobian
    procedure :: jet_spec => osc_jet_spec
  end type oscillator_t

  !> The oscillator in real128 (test_reference: against cos/sin in real128).
  type, extends(qp_field_t) :: qp_oscillator_t
  contains
    procedure :: dim => qosc_dim
    procedure :: eval => qosc_eval
  end type qp_oscillator_t

  !> dx/dt = A x + b: the tests' linear fields (line_field, fall_field, iso_field here, and
  !> test_tao's coupling). With entries 0 and +-1, matmul gives the components written out bit
  !> for bit.
  type, extends(vector_field_t) :: affine_field_t
    real(wp), allocatable :: a(:, :), b(:)
  contains
    procedure :: dim => affine_dim
    procedure :: eval => affine_eval
  end type affine_field_t

  !> The oscillator, but x < 1/2 gives NaN and stat = -1 (fatal).
  type, extends(oscillator_t) :: nan_oscillator_t
  contains
    procedure :: eval => nan_eval
  end type nan_oscillator_t

  !> The oscillator, but it refuses states with x < x_min or x^2 + v^2 > r2max: stat = +1
  !> (recoverable: retry with a smaller step). The exact solution from (1, 0) stays on the unit
  !> circle. The defaults refuse nothing.
  type, extends(oscillator_t) :: shy_oscillator_t
    real(wp) :: x_min = -huge(1.0_wp)
    real(wp) :: r2max = huge(1.0_wp)
  contains
    procedure :: eval => shy_eval
  end type shy_oscillator_t

contains

  pure real(wp) function qb_shape(self, q)
    class(quartic_bath_t), intent(in) :: self
    real(wp), intent(in) :: q(:)
    integer :: n
    n = size(q)
    if (self%cosines) then
      qb_shape = cos(q(1)) + cos(q(2))
      return
    end if
    qb_shape = -q(1)**2/2 + q(1)**4/4 + (q(n) - self%s)**self%k/self%k
    if (n == 3) qb_shape = qb_shape + self%w**2*q(2)**2/2
  end function qb_shape

  pure subroutine qb_shape_derivs(self, q, grad, hess)
    class(quartic_bath_t), intent(in) :: self
    real(wp), intent(in) :: q(:)
    real(wp), intent(out) :: grad(:), hess(:, :)
    integer :: n
    n = size(q)
    grad = 0
    hess = 0
    if (self%cosines) then
      grad(1:2) = -sin(q(1:2))
      hess(1, 1) = -cos(q(1))
      hess(2, 2) = -cos(q(2))
      return
    end if
    grad(1) = -q(1) + q(1)**3
    hess(1, 1) = -1 + 3*q(1)**2
    grad(n) = (q(n) - self%s)**(self%k - 1)
    hess(n, n) = (self%k - 1)*(q(n) - self%s)**(self%k - 2)
    if (n == 3) then
      grad(2) = self%w**2*q(2)
      hess(2, 2) = self%w**2
    end if
  end subroutine qb_shape_derivs

  pure subroutine qb_masses(self, m)
    class(quartic_bath_t), intent(in) :: self
    real(wp), intent(out) :: m(:)
    m = 1.0_wp
  end subroutine qb_masses

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

  pure integer function qosc_dim(self)
    class(qp_oscillator_t), intent(in) :: self
    qosc_dim = 2
  end function qosc_dim

  pure subroutine qosc_eval(self, t, x, dxdt, stat)
    class(qp_oscillator_t), intent(in) :: self
    real(qp), intent(in) :: t, x(:)
    real(qp), intent(out) :: dxdt(:)
    integer, intent(out) :: stat
    dxdt(1) = x(2)
    dxdt(2) = -x(1)
    stat = 0
  end subroutine qosc_eval

  pure integer function affine_dim(self)
    class(affine_field_t), intent(in) :: self
    affine_dim = size(self%b)
  end function affine_dim

  pure subroutine affine_eval(self, t, x, dxdt, stat)
    class(affine_field_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:)
    real(wp), intent(out) :: dxdt(:)
    integer, intent(out) :: stat
    dxdt = matmul(self%a, x) + self%b
    stat = 0
  end subroutine affine_eval

  !> x' = 1 in one dimension (not a canonical (q, p) state).
  function line_field() result(f)
    type(affine_field_t) :: f
    allocate (f%a(1, 1), source=0.0_wp)
    allocate (f%b(1), source=1.0_wp)
  end function line_field

  !> Free fall x' = v, v' = -1: its solution is a quadratic.
  function fall_field() result(f)
    type(affine_field_t) :: f
    allocate (f%a(2, 2), source=0.0_wp)
    f%a(1, 2) = 1
    allocate (f%b(2), source=[0.0_wp, -1.0_wp])
  end function fall_field

  !> The 2-D isotropic oscillator H = (px^2 + py^2)/2 + (x^2 + y^2)/2 on (x, y, px, py):
  !> q(t) = q0 cos t + p0 sin t.
  function iso_field() result(f)
    type(affine_field_t) :: f
    allocate (f%a(4, 4), source=0.0_wp)
    f%a(1, 3) = 1
    f%a(2, 4) = 1
    f%a(3, 1) = -1
    f%a(4, 2) = -1
    allocate (f%b(4), source=0.0_wp)
  end function iso_field

  !> Its formula, H = (p^2 + q^2)/2 (the Taylor method's source).
  pure function osc_jet_spec(self) result(spec)
    class(oscillator_t), intent(in) :: self
    type(jet_spec_t) :: spec
    character, parameter :: NL = new_line('a')
    spec%text = 'tubes-expression 1' // NL // 'kind hamiltonian' // NL // 'expr (p^2 + q^2)/2' // NL // &
                'coordinates q' // NL // 'momenta p' // NL
  end function osc_jet_spec

  !> The exact Jacobian [[0, 1], [-1, 0]] (implicit and Newton-corrected methods).
  pure subroutine osc_jacobian(self, t, x, jac, stat)
    class(oscillator_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:)
    real(wp), intent(out) :: jac(:, :)
    integer, intent(out) :: stat
    jac = reshape([0.0_wp, -1.0_wp, 1.0_wp, 0.0_wp], [2, 2])
    stat = 0
  end subroutine osc_jacobian

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

  pure subroutine shy_eval(self, t, x, dxdt, stat)
    class(shy_oscillator_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:)
    real(wp), intent(out) :: dxdt(:)
    integer, intent(out) :: stat
    call osc_eval(self, t, x, dxdt, stat)
    if (x(1) < self%x_min .or. x(1)**2 + x(2)**2 > self%r2max) stat = 1
  end subroutine shy_eval

  subroutine probe_on_step(self, ig, t_hi)
    class(dense_probe_t), intent(inout) :: self
    class(integrator_t), intent(inout) :: ig
    real(wp), intent(in) :: t_hi
    real(wp) :: xs(2), x0(2), s
    integer :: j
    self%nsteps = self%nsteps + 1
    call ig%interp(ig%t_old, x0)
    if (self%nsteps > 1) self%err_join = max(self%err_join, norm2(x0 - self%x_end))
    do j = 1, self%nsamp
      s = ig%t_old + j*(t_hi - ig%t_old)/(self%nsamp + 1)
      call ig%interp(s, xs)
      self%err_global = max(self%err_global, norm2(xs - rotate([1.0_wp, 0.0_wp], s)))
      self%err_local = max(self%err_local, norm2(xs - rotate(x0, s - ig%t_old)))
    end do
    call ig%interp(ig%t, self%x_end)
    select type (ig)
    type is (dop853_t)
      self%err_ends = max(self%err_ends, norm2(x0 - ig%x_old), norm2(self%x_end - ig%x_new))
    type is (rk4_t)
      self%err_ends = max(self%err_ends, norm2(x0 - ig%x_old), norm2(self%x_end - ig%x_new))
    end select
  end subroutine probe_on_step

  !> The oscillator from (1, 0) to t = 10 with ig at the fixed step h: checks the status and the
  !> landing on t = 10 (labels name // ': status, h = ' and ': lands on t = 10, h = ', h written
  !> with the edit descriptor hfmt) and returns the error at t = 10 against the exact solution.
  !> ig set to integrate the oscillator from x = (1, 0) at t = 0, with fixed step h and the step
  !> budget max_steps when they are given (init keeps the previous ones otherwise).
  subroutine oscillator_start(ig, x, h, max_steps)
    class(integrator_t), intent(inout) :: ig
    real(wp), intent(out) :: x(2)
    real(wp), intent(in), optional :: h
    integer, intent(in), optional :: max_steps
    call ig%init(oscillator_t(), t0=0.0_wp)
    if (present(h)) ig%h = h
    if (present(max_steps)) ig%max_steps = max_steps
    x = [1.0_wp, 0.0_wp]
  end subroutine oscillator_start

  subroutine oscillator_fixed_step(ig, h, name, hfmt, err)
    class(integrator_t), intent(inout) :: ig
    real(wp), intent(in) :: h
    character(*), intent(in) :: name, hfmt
    real(wp), intent(out) :: err
    real(wp) :: x(2)
    integer :: stat
    character(80) :: lbl
    call oscillator_start(ig, x, h)
    call propagate(ig, x, 10.0_wp, stat)
    write (lbl, '(2a,' // hfmt // ')') name, ': status, h = ', h
    call check_eq(trim(lbl), stat, TUBES_OK)
    write (lbl, '(2a,' // hfmt // ')') name, ': lands on t = 10, h = ', h
    call check_true(trim(lbl), ig%t == 10.0_wp)
    err = norm2(x - rotate([1.0_wp, 0.0_wp], 10.0_wp))
  end subroutine oscillator_fixed_step

  !> The rolling ball (the four-well, g = 981) from X0_BALL with fixed step h, its states at
  !> times(k) into zs(:, k) (the Richardson-order tests; written out in two), the status checked
  !> (label "<name>: status, h = <h in hfmt>").
  subroutine ball_fixed_step(ig, h, times, name, hfmt, zs)
    class(integrator_t), intent(inout) :: ig
    real(wp), intent(in) :: h, times(:)
    character(*), intent(in) :: name, hfmt
    real(wp), intent(out) :: zs(:, :)
    type(ball_t) :: ball
    real(wp) :: z(4)
    integer :: k, stat
    character(80) :: lbl
    call make_ball(ball, fourwell_t(), 981.0_wp)
    call ig%init(ball, t0=0.0_wp)
    ig%h = h
    z = X0_BALL
    zs = ieee_value(1.0_wp, ieee_quiet_nan)
    do k = 1, size(times)
      call propagate(ig, z, times(k), stat)
      if (stat /= TUBES_OK) exit
      zs(:, k) = z
    end do
    write (lbl, '(2a,' // hfmt // ')') name, ': status, h = ', h
    call check_eq(trim(lbl), stat, TUBES_OK)
  end subroutine ball_fixed_step

  !> Exact oscillator flow over time s: (x, v) -> (x cos s + v sin s, -x sin s + v cos s).
  pure function rotate(x, s) result(y)
    real(wp), intent(in) :: x(2), s
    real(wp) :: y(2)
    y(1) = x(1)*cos(s) + x(2)*sin(s)
    y(2) = -x(1)*sin(s) + x(2)*cos(s)
  end function rotate
end module tubes_test_models
