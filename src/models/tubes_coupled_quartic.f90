!> The coupled quartic Hamiltonian of the UPOsHam examples (Naik, Krajnak, Wiggins and Ross):
!> a double well in x coupled linearly to a harmonic mode y,
!>   H = px^2/(2 m_a) + py^2/(2 m_b) - alpha x^2/2 + beta x^4/4 + omega y^2/2 + eps (x - y)^2/2.
!> The origin is the rank-1 saddle (E = 0) between two wells on either side of x = 0.
module tubes_coupled_quartic
  use tubes_kinds, only: wp
  use tubes_hamiltonian, only: two_mode_t
  implicit none
  private

  !> The coupled quartic; the parameters' defaults live in tubes_models.
  type, extends(two_mode_t), public :: coupled_quartic_t
    real(wp) :: alpha    !! negative curvature of the double well
    real(wp) :: beta     !! quartic stiffness of x
    real(wp) :: omega    !! stiffness of the y mode
    real(wp) :: eps      !! coupling of x and y
  contains
    procedure :: shape => cq_shape, shape_derivs => cq_shape_derivs
  end type coupled_quartic_t

contains

  pure real(wp) function cq_shape(self, q)
    class(coupled_quartic_t), intent(in) :: self
    real(wp), intent(in) :: q(:)
    cq_shape = -self%alpha*q(1)**2/2 + self%beta*q(1)**4/4 + self%omega*q(2)**2/2 &
               + self%eps*(q(1) - q(2))**2/2
  end function cq_shape

  pure subroutine cq_shape_derivs(self, q, grad, hess)
    class(coupled_quartic_t), intent(in) :: self
    real(wp), intent(in) :: q(:)
    real(wp), intent(out) :: grad(:), hess(:, :)
    grad(1) = -self%alpha*q(1) + self%beta*q(1)**3 + self%eps*(q(1) - q(2))
    grad(2) = self%omega*q(2) - self%eps*(q(1) - q(2))
    hess(1, 1) = -self%alpha + 3*self%beta*q(1)**2 + self%eps
    hess(1, 2) = -self%eps
    hess(2, 1) = -self%eps
    hess(2, 2) = self%omega + self%eps
  end subroutine cq_shape_derivs

end module tubes_coupled_quartic
