!> The Henon-Heiles system (M. Henon and C. Heiles, Astron. J. 69, 73 (1964)): a star in an
!> axisymmetric galaxy, the classic 2-DOF test of chaos and of transport over saddles:
!>   H = (px^2 + py^2)/2 + (x^2 + y^2)/2 + x^2 y - y^3/3     (no parameters, dimensionless).
!> Equilibria: a centre-centre well at the origin (E = 0) and three rank-1 saddles at E = 1/6,
!> (0, 1) and (+-sqrt(3)/2, -1/2), each with lambda = 1 and omega = sqrt(3) (docs/models.md).
module tubes_henon_heiles
  use tubes_kinds, only: wp
  use tubes_hamiltonian, only: separable_t, BLOWUP_Q
  implicit none
  private

  !> Henon-Heiles: a natural system with unit masses.
  type, extends(separable_t), public :: henon_heiles_t
  contains
    procedure :: eval => hh_eval
    procedure :: shape => hh_shape
    procedure :: shape_derivs => hh_shape_derivs
    procedure :: masses => hh_masses
  end type henon_heiles_t

contains

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
    if (.not. abs(dxdt(3)) + abs(dxdt(4)) <= huge(1.0_wp) .or. abs(x(1)) + abs(x(2)) > BLOWUP_Q) &
      stat = -1
  end subroutine hh_eval

  !> Unit masses.
  pure subroutine hh_masses(self, m)
    class(henon_heiles_t), intent(in) :: self
    real(wp), intent(out) :: m(:)
    m(1:2) = 1.0_wp
  end subroutine hh_masses

end module tubes_henon_heiles
