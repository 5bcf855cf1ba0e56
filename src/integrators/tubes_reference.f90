!> Quad-precision (real128) reference solutions of the conservative rolling ball on the
!> four-well surface: the surface, the Hamiltonian and Hamilton's equations are the double
!> model's own source compiled in real128 (tubes_fourwell_formula.inc, tubes_ball_formula.inc;
!> docs/development.md, "Kind-generic sources"), integrated by DOP853's source in real128
!> (tubes_dop853_qp) with rtol = atol = tol. What makes it a reference is the precision, not a
!> second formula: the formula is checked against closed forms and energy conservation. Accuracy and cost are measured in
!> tests/test_reference.f90 and docs/events.md ("Reference solutions").
module tubes_reference
  use tubes_kinds, only: wp, qp, i8
  use tubes_status, only: TUBES_OK, TUBES_EINPUT
  use tubes_dop853_qp, only: qp_field_t, dop853_qp_solve
  implicit none
  private

  integer, parameter :: NMODEL = 10                   ! = tubes_models NMODEL
  integer, parameter :: rk = qp   ! the kind of the kind-generic sources included below
  real(qp), parameter :: ROLL = 5.0_qp/7.0_qp   ! tubes_ball's ROLL in real128 (5/7, a solid sphere)
  !> Smallest tolerance accepted: 50 ulps of real128 (below it roundoff dominates the steps).
  real(qp), parameter, public :: REF_TOL_MIN = 1.0e-32_qp

  !> The conservative ball on H = alpha (x^2 + y^2) - beta (sqrt(x^2 + gamma) +
  !> sqrt(y^2 + gamma)) - xi x y + h0 in real128; state (x, y, px, py) [cm, cm, cm/s, cm/s].
  type, extends(qp_field_t), public :: ball_qp_t
    real(qp) :: alpha = 0.07_qp     !! [1/cm]
    real(qp) :: beta = 1.017_qp     !! [1]
    real(qp) :: gamma = 15.103_qp   !! [cm^2]
    real(qp) :: xi = 0.00656_qp     !! [1/cm]
    real(qp) :: h0 = 12.065_qp      !! [cm]
    real(qp) :: g = 981.0_qp        !! gravity [cm/s^2]
  contains
    procedure :: dim => ball_qp_dim
    procedure :: eval => ball_qp_eval
    procedure :: energy => ball_qp_energy
  end type ball_qp_t

  !> reference_solution(params, x0, t_end, tol, x_end, stat [, nsteps, nfev]): the state at
  !> t_end from x0 at t = 0, in real(wp) (params, x0, t_end, tol, x_end real(wp); the double
  !> parameters are used exactly) or in real128 (all real(qp)).
  interface reference_solution
    module procedure reference_solution_wp, reference_solution_qp
  end interface reference_solution

  public :: reference_solution, ball_qp_from_params

contains

  pure integer function ball_qp_dim(self)
    class(ball_qp_t), intent(in) :: self
    ball_qp_dim = 4
  end function ball_qp_dim

  !> Energy per unit mass T + g H = (5/14)(|p|^2 - (grad H . p)^2/D) + g H [(cm/s)^2].
  pure real(qp) function ball_qp_energy(self, x) result(e)
    class(ball_qp_t), intent(in) :: self
    real(qp), intent(in) :: x(4)   !! (x, y, px, py)
    real(qp) :: gr(2), hs(2, 2)
    call fourwell_derivs_of(self%alpha, self%beta, self%gamma, self%xi, x(1), x(2), gr, hs)
    e = ball_energy_of(gr, fourwell_height_of(self%alpha, self%beta, self%gamma, self%xi, &
                                              self%h0, x(1), x(2)), self%g, x)
  end function ball_qp_energy

  !> Hamilton's equations: u = grad H . p / D, v = (5/7)(p - u grad H),
  !> dq/dt = v, dp/dt = u Hess(H) v - g grad H (gradient and Hessian: docs/theory.md, "The surface").
  pure subroutine ball_qp_eval(self, t, x, dxdt, stat)
    class(ball_qp_t), intent(in) :: self
    real(qp), intent(in) :: t, x(:)
    real(qp), intent(out) :: dxdt(:)
    integer, intent(out) :: stat
    real(qp) :: gr(2), hs(2, 2)
    call fourwell_derivs_of(self%alpha, self%beta, self%gamma, self%xi, x(1), x(2), gr, hs)
    call ball_rhs_of(gr, hs, self%g, x, dxdt, stat)
  end subroutine ball_qp_eval

  !> The real128 ball of a parameter vector [alpha, beta, gamma, xi, h0, g, zeta, C_rr, noise,
  !> temperature] (the last four must be 0: conservative only; gamma > 0, g > 0).
  subroutine ball_qp_from_params(params, ball, stat)
    real(qp), intent(in) :: params(NMODEL)
    type(ball_qp_t), intent(out) :: ball
    integer, intent(out) :: stat
    stat = TUBES_OK
    if (.not. (params(3) > 0 .and. params(6) > 0 .and. all(params(7:10) == 0))) then
      stat = TUBES_EINPUT
      return
    end if
    ball = ball_qp_t(alpha=params(1), beta=params(2), gamma=params(3), xi=params(4), &
                     h0=params(5), g=params(6))
  end subroutine ball_qp_from_params

  !> Reference state at t_end from x0 at t = 0, all in real128, rtol = atol = tol.
  !> stat: TUBES_OK, TUBES_EINPUT (damped or invalid model, tol outside [REF_TOL_MIN, 1)),
  !> or the integrator's failure code (x_end then at the last accepted step).
  subroutine reference_solution_qp(params, x0, t_end, tol, x_end, stat, nsteps, nfev)
    real(qp), intent(in) :: params(NMODEL)   !! [alpha, beta, gamma, xi, h0, g, 0]
    real(qp), intent(in) :: x0(4)            !! initial state (x, y, px, py)
    real(qp), intent(in) :: t_end            !! final time [s]
    real(qp), intent(in) :: tol              !! rtol = atol of the step control
    real(qp), intent(out) :: x_end(4)        !! state at t_end
    integer, intent(out) :: stat
    integer(i8), intent(out), optional :: nsteps   !! accepted steps
    integer(i8), intent(out), optional :: nfev     !! right-hand-side evaluations
    type(ball_qp_t) :: ball
    integer(i8) :: ns, nf
    x_end = x0
    if (present(nsteps)) nsteps = 0
    if (present(nfev)) nfev = 0
    if (.not. (tol >= REF_TOL_MIN .and. tol < 1)) then
      stat = TUBES_EINPUT
      return
    end if
    call ball_qp_from_params(params, ball, stat)
    if (stat /= TUBES_OK) return
    call dop853_qp_solve(ball, 0.0_qp, x_end, t_end, tol, tol, stat, nsteps=ns, nfev=nf)
    if (present(nsteps)) nsteps = ns
    if (present(nfev)) nfev = nf
  end subroutine reference_solution_qp

  !> Reference state at t_end from x0 at t = 0 for double inputs (the arguments of
  !> reference_solution_qp in real(wp)): the double parameters and initial state are converted
  !> exactly to real128, the result rounded to double.
  subroutine reference_solution_wp(params, x0, t_end, tol, x_end, stat, nsteps, nfev)
    real(wp), intent(in) :: params(NMODEL), x0(4), t_end, tol
    real(wp), intent(out) :: x_end(4)
    integer, intent(out) :: stat
    integer(i8), intent(out), optional :: nsteps, nfev
    real(qp) :: xq(4)
    call reference_solution_qp(real(params, qp), real(x0, qp), real(t_end, qp), &
                               real(tol, qp), xq, stat, nsteps, nfev)
    x_end = real(xq, wp)
  end subroutine reference_solution_wp

  include 'tubes_fourwell_formula.inc'   ! the surface in real(qp)
  include 'tubes_ball_formula.inc'       ! the ball in real(qp)
end module tubes_reference
