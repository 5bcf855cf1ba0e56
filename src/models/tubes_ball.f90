!> A ball rolling without slipping on a surface z = H(x, y), per unit mass, in canonical
!> coordinates (x, y, px, py) [cm, cm, cm/s, cm/s] (Ross et al. 2018, eq. kin_rescale):
!>   T = (5/14) p^T M^-1 p,  M = I + grad H grad H^T,  V = g H,  p = (7/5) M v.
!> With s = grad H . p, D = 1 + |grad H|^2, u = s/D and v = (5/7)(p - u grad H):
!>   dq/dt = v,   dp/dt = u Hess(H) v - g grad H          (derivation: docs/theory.md)
!> The ball is a natural system (tubes_hamiltonian): V = g H, shape = H, potential_scale = g,
!> A(q) = (5/7) M^-1. Damping is the generic damped_t wrapper (-c p on the momenta).
module tubes_ball
  use tubes_kinds, only: wp
  use tubes_hamiltonian, only: natural_t, NAMES_QUADRANT, NAMES_GENERIC
  use tubes_surface, only: surface_t
  implicit none
  private

  integer, parameter :: rk = wp   ! the kind of the kind-generic source included below

  real(wp), parameter, public :: ROLL = 5.0_wp/7.0_wp  !! v = ROLL M^-1 p for a solid sphere
  real(wp), parameter, public :: MAX_RADIUS = 1.0e6_wp  !! |x| + |y| beyond this is refused [cm]

  !> Conservative rolling ball (potential_scale = g).
  type, extends(natural_t), public :: ball_t
    class(surface_t), allocatable :: surf   !! the surface it rolls on
    real(wp) :: g = 981.0_wp                !! gravitational acceleration [cm/s^2]
    logical :: four_well = .true.           !! name equilibria by quadrant (W1, S12, ...)
  contains
    procedure :: eval => ball_eval
    procedure :: jacobian => ball_jacobian
    procedure :: energy => ball_energy
    procedure :: gradient => ball_gradient
    procedure :: hessian => ball_hessian
    procedure :: shape => ball_shape
    procedure :: shape_derivs => ball_shape_derivs
    procedure :: kinetic_matrix => ball_kinetic_matrix
    procedure :: rest_kinetic_matrix => ball_rest_kinetic
    procedure :: naming => ball_naming
    procedure :: potential_scale => ball_potential_scale
    procedure :: velocity => ball_velocity
    procedure :: momentum => ball_momentum
    procedure :: potential_xy => ball_potential
  end type ball_t

  public :: make_ball

contains

  !> Build a ball model on surface `surf` (allocate with source=, see STYLE.md).
  subroutine make_ball(ball, surf, g, four_well)
    type(ball_t), intent(out) :: ball
    class(surface_t), intent(in) :: surf   !! the surface
    real(wp), intent(in) :: g              !! gravity [cm/s^2]
    logical, intent(in), optional :: four_well  !! quadrant names (default .true.)
    allocate (ball%surf, source=surf)
    ball%g = g
    if (present(four_well)) ball%four_well = four_well
  end subroutine make_ball

  !> The surface's height H(q) [cm] (V = g H).
  pure real(wp) function ball_shape(self, q)
    class(ball_t), intent(in) :: self
    real(wp), intent(in) :: q(:)
    ball_shape = self%surf%height(q(1), q(2))
  end function ball_shape

  pure subroutine ball_shape_derivs(self, q, grad, hess)
    class(ball_t), intent(in) :: self
    real(wp), intent(in) :: q(:)
    real(wp), intent(out) :: grad(:), hess(:, :)
    real(wp) :: gr(2), hs(2, 2)
    call self%surf%derivs(q(1), q(2), gr, hs)
    grad(1:2) = gr
    hess(1:2, 1:2) = hs
  end subroutine ball_shape_derivs

  !> A(q) = (5/7) M^-1 = (5/7)(I - grad H grad H^T / (1 + |grad H|^2)).
  pure subroutine ball_kinetic_matrix(self, q, a)
    class(ball_t), intent(in) :: self
    real(wp), intent(in) :: q(:)
    real(wp), intent(out) :: a(:, :)
    real(wp) :: gr(2), hs(2, 2), d
    call self%surf%derivs(q(1), q(2), gr, hs)
    d = 1 + gr(1)**2 + gr(2)**2
    a(1:2, 1:2) = -ROLL*outer(gr, gr)/d
    a(1, 1) = a(1, 1) + ROLL
    a(2, 2) = a(2, 2) + ROLL
  end subroutine ball_kinetic_matrix

  !> At a critical point of the surface M = I: A = (5/7) I.
  pure subroutine ball_rest_kinetic(self, q, a)
    class(ball_t), intent(in) :: self
    real(wp), intent(in) :: q(:)
    real(wp), intent(out) :: a(:, :)
    a(1:2, 1:2) = 0
    a(1, 1) = ROLL
    a(2, 2) = ROLL
  end subroutine ball_rest_kinetic

  !> dH/dx = (-dp/dt, dq/dt) of the conservative flow [(cm/s)^2/cm, cm/s].
  pure subroutine ball_gradient(self, x, g, stat)
    class(ball_t), intent(in) :: self
    real(wp), intent(in) :: x(:)
    real(wp), intent(out) :: g(:)
    integer, intent(out) :: stat
    real(wp) :: f(4)
    call ball_eval(self, 0.0_wp, x, f, stat)
    g(1:4) = [-f(3), -f(4), f(1), f(2)]
  end subroutine ball_gradient

  !> Hessian of H from the analytic Jacobian J Hess H (ball_jacobian): Hess = -J jac.
  pure subroutine ball_hessian(self, x, h, stat)
    class(ball_t), intent(in) :: self
    real(wp), intent(in) :: x(:)
    real(wp), intent(out) :: h(:, :)
    integer, intent(out) :: stat
    real(wp) :: jac(4, 4)
    call ball_jacobian(self, 0.0_wp, x, jac, stat)
    h(1:2, 1:4) = -jac(3:4, 1:4)
    h(3:4, 1:4) = jac(1:2, 1:4)
  end subroutine ball_hessian

  !> V = g H.
  pure real(wp) function ball_potential_scale(self)
    class(ball_t), intent(in) :: self
    ball_potential_scale = self%g
  end function ball_potential_scale

  pure integer function ball_naming(self)
    class(ball_t), intent(in) :: self
    ball_naming = merge(NAMES_QUADRANT, NAMES_GENERIC, self%four_well)
  end function ball_naming

  pure subroutine ball_eval(self, t, x, dxdt, stat)
    class(ball_t), intent(in) :: self
    real(wp), intent(in)  :: t, x(:)
    real(wp), intent(out) :: dxdt(:)
    integer, intent(out)  :: stat
    real(wp) :: gr(2), hs(2, 2)
    call self%surf%derivs(x(1), x(2), gr, hs)
    call ball_rhs_of(gr, hs, self%g, x, dxdt, stat)
    if (abs(x(1)) + abs(x(2)) > MAX_RADIUS) stat = -1
  end subroutine ball_eval

  !> Analytic Jacobian of Hamilton's equations (derivation: docs/theory.md, "Jacobian").
  pure subroutine ball_jacobian(self, t, x, jac, stat)
    class(ball_t), intent(in) :: self
    real(wp), intent(in)  :: t, x(:)
    real(wp), intent(out) :: jac(:, :)
    integer, intent(out)  :: stat
    real(wp) :: gr(2), k(2, 2), t3(2, 2, 2), p(2), d, u, v(2), du_dp(2), du_dq(2), kv(2)
    real(wp) :: dv_dp(2, 2), dv_dq(2, 2), dk_v(2, 2)
    integer :: j
    call self%surf%derivs(x(1), x(2), gr, k)
    call self%surf%third(x(1), x(2), t3)
    p = x(3:4)
    d = 1 + gr(1)**2 + gr(2)**2
    u = (gr(1)*p(1) + gr(2)*p(2))/d
    v = ROLL*(p - u*gr)
    du_dp = gr/d
    du_dq = matmul(k, p - 2*u*gr)/d
    dv_dp = -ROLL*outer(gr, du_dp)
    dv_dp(1, 1) = dv_dp(1, 1) + ROLL
    dv_dp(2, 2) = dv_dp(2, 2) + ROLL
    dv_dq = -ROLL*(outer(gr, du_dq) + u*k)
    kv = matmul(k, v)
    do j = 1, 2
      dk_v(:, j) = matmul(t3(:, :, j), v)   ! (dK/dq_j) v
    end do
    jac(1:2, 1:2) = dv_dq
    jac(1:2, 3:4) = dv_dp
    jac(3:4, 1:2) = outer(kv, du_dq) + u*dk_v + u*matmul(k, dv_dq) - self%g*k
    jac(3:4, 3:4) = outer(kv, du_dp) + u*matmul(k, dv_dp)
    stat = 0
    if (.not. all(abs(jac(1:4, 1:4)) <= huge(1.0_wp))) stat = -1
  end subroutine ball_jacobian

  pure function outer(a, b) result(m)
    real(wp), intent(in) :: a(2), b(2)
    real(wp) :: m(2, 2)
    m(:, 1) = a*b(1)
    m(:, 2) = a*b(2)
  end function outer

  !> Total energy per unit mass T + g H [(cm/s)^2].
  pure real(wp) function ball_energy(self, x) result(e)
    class(ball_t), intent(in) :: self
    real(wp), intent(in) :: x(:)   !! (x, y, px, py)
    real(wp) :: gr(2), hs(2, 2)
    call self%surf%derivs(x(1), x(2), gr, hs)
    e = ball_energy_of(gr, self%surf%height(x(1), x(2)), self%g, x)
  end function ball_energy

  !> Potential energy per unit mass g H(x, y) [(cm/s)^2].
  pure real(wp) function ball_potential(self, x, y) result(v)
    class(ball_t), intent(in) :: self
    real(wp), intent(in) :: x, y
    v = self%g*self%surf%height(x, y)
  end function ball_potential

  !> Planar velocity (dx/dt, dy/dt) [cm/s] from momenta: v = (5/7) M^-1 p.
  pure function ball_velocity(self, x) result(v)
    class(ball_t), intent(in) :: self
    real(wp), intent(in) :: x(4)
    real(wp) :: v(2), gr(2), hs(2, 2), u
    call self%surf%derivs(x(1), x(2), gr, hs)
    u = (gr(1)*x(3) + gr(2)*x(4))/(1 + gr(1)**2 + gr(2)**2)
    v = ROLL*(x(3:4) - u*gr)
  end function ball_velocity

  !> Momenta (px, py) [cm/s] from the planar velocity at (q1, q2): p = (7/5) M v.
  pure function ball_momentum(self, q, v) result(p)
    class(ball_t), intent(in) :: self
    real(wp), intent(in) :: q(2), v(2)
    real(wp) :: p(2), gr(2), hs(2, 2)
    call self%surf%derivs(q(1), q(2), gr, hs)
    p = (v + gr*(gr(1)*v(1) + gr(2)*v(2)))/ROLL
  end function ball_momentum

  include 'tubes_ball_formula.inc'   ! ball_rhs_of, ball_energy_of in real(wp)
end module tubes_ball
