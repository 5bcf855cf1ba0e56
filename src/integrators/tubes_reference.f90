!> Quad-precision (real128) reference solutions of the conservative rolling ball on the
!> four-well surface: the surface, the Hamiltonian and Hamilton's equations written again in
!> real128 from docs/theory.md (not converted from the double code), integrated by adaptive
!> DOP853 in real128 (tubes_dop853_qp) with rtol = atol = tol. Accuracy and cost are measured in
!> tests/test_reference.f90 and docs/events.md ("Reference solutions").
module tubes_reference
  use tubes_kinds, only: wp, qp, i8
  use tubes_status, only: TUBES_OK, TUBES_EINPUT
  use tubes_dop853_qp, only: qp_field_t, dop853_qp_solve
  implicit none
  private

  integer, parameter :: NMODEL = 7                    ! = tubes_models NMODEL
  real(qp), parameter :: ROLL_QP = 5.0_qp/7.0_qp      ! v = (5/7) M^-1 p for a solid sphere
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
    procedure :: height => ball_qp_height
    procedure :: derivs => ball_qp_derivs
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

  !> Surface height H(x, y) [cm].
  pure real(qp) function ball_qp_height(self, x, y) result(h)
    class(ball_qp_t), intent(in) :: self
    real(qp), intent(in) :: x, y   !! position [cm]
    h = self%alpha*(x*x + y*y) - self%beta*(sqrt(x*x + self%gamma) + sqrt(y*y + self%gamma)) &
        - self%xi*x*y + self%h0
  end function ball_qp_height

  !> Gradient (H_x, H_y) [1] and Hessian [1/cm] (docs/theory.md, "The surface").
  pure subroutine ball_qp_derivs(self, x, y, grad, hess)
    class(ball_qp_t), intent(in) :: self
    real(qp), intent(in) :: x, y
    real(qp), intent(out) :: grad(2), hess(2, 2)
    real(qp) :: sx, sy
    sx = sqrt(x*x + self%gamma)
    sy = sqrt(y*y + self%gamma)
    grad(1) = 2*self%alpha*x - self%beta*x/sx - self%xi*y
    grad(2) = 2*self%alpha*y - self%beta*y/sy - self%xi*x
    hess(1, 1) = 2*self%alpha - self%beta*self%gamma/(sx*sx*sx)
    hess(2, 2) = 2*self%alpha - self%beta*self%gamma/(sy*sy*sy)
    hess(1, 2) = -self%xi
    hess(2, 1) = -self%xi
  end subroutine ball_qp_derivs

  !> Energy per unit mass T + g H = (5/14)(|p|^2 - (grad H . p)^2/D) + g H [(cm/s)^2].
  pure real(qp) function ball_qp_energy(self, x) result(e)
    class(ball_qp_t), intent(in) :: self
    real(qp), intent(in) :: x(4)   !! (x, y, px, py)
    real(qp) :: gr(2), hs(2, 2), s
    call self%derivs(x(1), x(2), gr, hs)
    s = gr(1)*x(3) + gr(2)*x(4)
    e = ROLL_QP/2*(x(3)**2 + x(4)**2 - s*s/(1 + gr(1)**2 + gr(2)**2)) &
        + self%g*self%height(x(1), x(2))
  end function ball_qp_energy

  !> Hamilton's equations: u = grad H . p / D, v = (5/7)(p - u grad H),
  !> dq/dt = v, dp/dt = u Hess(H) v - g grad H.
  pure subroutine ball_qp_eval(self, t, x, dxdt, stat)
    class(ball_qp_t), intent(in) :: self
    real(qp), intent(in) :: t, x(:)
    real(qp), intent(out) :: dxdt(:)
    integer, intent(out) :: stat
    real(qp) :: gr(2), hs(2, 2), u, v(2)
    call self%derivs(x(1), x(2), gr, hs)
    u = (gr(1)*x(3) + gr(2)*x(4))/(1 + gr(1)**2 + gr(2)**2)
    v(1) = ROLL_QP*(x(3) - u*gr(1))
    v(2) = ROLL_QP*(x(4) - u*gr(2))
    dxdt(1) = v(1)
    dxdt(2) = v(2)
    dxdt(3) = u*(hs(1, 1)*v(1) + hs(1, 2)*v(2)) - self%g*gr(1)
    dxdt(4) = u*(hs(2, 1)*v(1) + hs(2, 2)*v(2)) - self%g*gr(2)
    stat = 0
    if (.not. all(abs(dxdt(1:4)) <= huge(1.0_qp))) stat = -1
  end subroutine ball_qp_eval

  !> The real128 ball of a parameter vector [alpha, beta, gamma, xi, h0, g, zeta] (zeta must
  !> be 0: conservative only; gamma > 0, g > 0).
  subroutine ball_qp_from_params(params, ball, stat)
    real(qp), intent(in) :: params(NMODEL)
    type(ball_qp_t), intent(out) :: ball
    integer, intent(out) :: stat
    stat = TUBES_OK
    if (.not. (params(3) > 0 .and. params(6) > 0 .and. params(7) == 0)) then
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

  !> Reference state at t_end from x0 at t = 0 for double inputs: the double parameters and
  !> initial state are converted exactly to real128, the result rounded to double.
  subroutine reference_solution_wp(params, x0, t_end, tol, x_end, stat, nsteps, nfev)
    real(wp), intent(in) :: params(NMODEL)   !! [alpha, beta, gamma, xi, h0, g, 0]
    real(wp), intent(in) :: x0(4)            !! initial state (x, y, px, py)
    real(wp), intent(in) :: t_end            !! final time [s]
    real(wp), intent(in) :: tol              !! rtol = atol of the step control
    real(wp), intent(out) :: x_end(4)        !! state at t_end
    integer, intent(out) :: stat
    integer(i8), intent(out), optional :: nsteps   !! accepted steps
    integer(i8), intent(out), optional :: nfev     !! right-hand-side evaluations
    real(qp) :: xq(4)
    call reference_solution_qp(real(params, qp), real(x0, qp), real(t_end, qp), &
                               real(tol, qp), xq, stat, nsteps, nfev)
    x_end = real(xq, wp)
  end subroutine reference_solution_wp
end module tubes_reference
