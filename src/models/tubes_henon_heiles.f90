!> The Henon-Heiles system (M. Henon and C. Heiles, Astron. J. 69, 73 (1964)): a star in an
!> axisymmetric galaxy, the classic 2-DOF test of chaos and of transport over saddles:
!>   H = (px^2 + py^2)/2 + (x^2 + y^2)/2 + x^2 y - y^3/3     (no parameters, dimensionless).
!> Equilibria: a centre-centre well at the origin (E = 0) and three rank-1 saddles at E = 1/6,
!> (0, 1) and (+-sqrt(3)/2, -1/2), each with lambda = 1 and omega = sqrt(3) (docs/models.md).
module tubes_henon_heiles
  use tubes_kinds, only: wp
  use tubes_hamiltonian, only: natural_t
  implicit none
  private

  real(wp), parameter :: MAX_Q = 1.0e6_wp   !! |x| + |y| beyond this is an escaped orbit: refused

  !> Henon-Heiles: a natural system with unit masses.
  type, extends(natural_t), public :: henon_heiles_t
  contains
    procedure :: ndof => hh_ndof
    procedure :: energy => hh_energy
    procedure :: gradient => hh_gradient
    procedure :: hessian => hh_hessian
    procedure :: eval => hh_eval
    procedure :: shape => hh_shape
    procedure :: shape_derivs => hh_shape_derivs
    procedure :: kinetic_matrix => hh_kinetic
  end type henon_heiles_t

contains

  pure integer function hh_ndof(self)
    class(henon_heiles_t), intent(in) :: self
    hh_ndof = 2
  end function hh_ndof

  !> V(x, y) = (x^2 + y^2)/2 + x^2 y - y^3/3.
  pure real(wp) function hh_shape(self, q)
    class(henon_heiles_t), intent(in) :: self
    real(wp), intent(in) :: q(:)
    hh_shape = 0.5_wp*(q(1)**2 + q(2)**2) + q(1)**2*q(2) - q(2)**3/3
  end function hh_shape

  pure subroutine hh_shape_derivs(self, q, grad, hess)
    class(henon_heiles_t), intent(in) :: self
    real(wp), intent(in) :: q(:)
    real(wp), intent(out) :: grad(:), hess(:, :)
    grad(1) = q(1) + 2*q(1)*q(2)
    grad(2) = q(2) + q(1)**2 - q(2)**2
    hess(1, 1) = 1 + 2*q(2)
    hess(1, 2) = 2*q(1)
    hess(2, 1) = 2*q(1)
    hess(2, 2) = 1 - 2*q(2)
  end subroutine hh_shape_derivs

  pure subroutine hh_kinetic(self, q, a)
    class(henon_heiles_t), intent(in) :: self
    real(wp), intent(in) :: q(:)
    real(wp), intent(out) :: a(:, :)
    a(1:2, 1:2) = 0
    a(1, 1) = 1
    a(2, 2) = 1
  end subroutine hh_kinetic

  pure real(wp) function hh_energy(self, x)
    class(henon_heiles_t), intent(in) :: self
    real(wp), intent(in) :: x(:)
    hh_energy = 0.5_wp*(x(3)**2 + x(4)**2) + hh_shape(self, x(1:2))
  end function hh_energy

  pure subroutine hh_gradient(self, x, g, stat)
    class(henon_heiles_t), intent(in) :: self
    real(wp), intent(in) :: x(:)
    real(wp), intent(out) :: g(:)
    integer, intent(out) :: stat
    g(1) = x(1) + 2*x(1)*x(2)
    g(2) = x(2) + x(1)**2 - x(2)**2
    g(3) = x(3)
    g(4) = x(4)
    stat = 0
    if (.not. all(abs(g(1:4)) <= huge(1.0_wp)) .or. abs(x(1)) + abs(x(2)) > MAX_Q) stat = -1
  end subroutine hh_gradient

  pure subroutine hh_hessian(self, x, h, stat)
    class(henon_heiles_t), intent(in) :: self
    real(wp), intent(in) :: x(:)
    real(wp), intent(out) :: h(:, :)
    integer, intent(out) :: stat
    real(wp) :: gr(2), hs(2, 2)
    call hh_shape_derivs(self, x(1:2), gr, hs)
    h(1:4, 1:4) = 0
    h(1:2, 1:2) = hs
    h(3, 3) = 1
    h(4, 4) = 1
    stat = 0
    if (abs(x(1)) + abs(x(2)) > MAX_Q) stat = -1
  end subroutine hh_hessian

  !> Hamilton's equations, scalar form (the hot path).
  pure subroutine hh_eval(self, t, x, dxdt, stat)
    class(henon_heiles_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:)
    real(wp), intent(out) :: dxdt(:)
    integer, intent(out) :: stat
    dxdt(1) = x(3)
    dxdt(2) = x(4)
    dxdt(3) = -x(1) - 2*x(1)*x(2)
    dxdt(4) = -x(2) - x(1)**2 + x(2)**2
    stat = 0
    if (.not. abs(dxdt(3)) + abs(dxdt(4)) <= huge(1.0_wp) .or. abs(x(1)) + abs(x(2)) > MAX_Q) stat = -1
  end subroutine hh_eval

end module tubes_henon_heiles
