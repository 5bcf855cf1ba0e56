!> The coupled quartic Hamiltonian of the UPOsHam examples (Naik, Krajnak, Wiggins and Ross):
!> a double well in x coupled linearly to a harmonic mode y,
!>   H = px^2/(2 m_a) + py^2/(2 m_b) - alpha x^2/2 + beta x^4/4 + omega y^2/2 + eps (x - y)^2/2.
!> The origin is the rank-1 saddle (E = 0) between two wells on either side of x = 0.
module tubes_coupled_quartic
  use tubes_kinds, only: wp
  use tubes_hamiltonian, only: natural_t
  implicit none
  private

  real(wp), parameter :: MAX_Q = 1.0e6_wp   !! |x| + |y| beyond this is refused (a blown-up state)

  !> The coupled quartic; the parameters' defaults live in tubes_models.
  type, extends(natural_t), public :: coupled_quartic_t
    real(wp) :: m_a      !! mass of the x mode
    real(wp) :: m_b      !! mass of the y mode
    real(wp) :: alpha    !! negative curvature of the double well
    real(wp) :: beta     !! quartic stiffness of x
    real(wp) :: omega    !! stiffness of the y mode
    real(wp) :: eps      !! coupling of x and y
  contains
    procedure :: ndof => cq_ndof
    procedure :: energy => cq_energy
    procedure :: gradient => cq_gradient
    procedure :: hessian => cq_hessian
    procedure :: shape => cq_shape
    procedure :: shape_derivs => cq_shape_derivs
    procedure :: kinetic_matrix => cq_kinetic
  end type coupled_quartic_t

contains

  pure integer function cq_ndof(self)
    class(coupled_quartic_t), intent(in) :: self
    cq_ndof = 2
  end function cq_ndof

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

  pure subroutine cq_kinetic(self, q, a)
    class(coupled_quartic_t), intent(in) :: self
    real(wp), intent(in) :: q(:)
    real(wp), intent(out) :: a(:, :)
    a(1:2, 1:2) = 0
    a(1, 1) = 1/self%m_a
    a(2, 2) = 1/self%m_b
  end subroutine cq_kinetic

  pure real(wp) function cq_energy(self, x)
    class(coupled_quartic_t), intent(in) :: self
    real(wp), intent(in) :: x(:)
    cq_energy = x(3)**2/(2*self%m_a) + x(4)**2/(2*self%m_b) + cq_shape(self, x(1:2))
  end function cq_energy

  pure subroutine cq_gradient(self, x, g, stat)
    class(coupled_quartic_t), intent(in) :: self
    real(wp), intent(in) :: x(:)
    real(wp), intent(out) :: g(:)
    integer, intent(out) :: stat
    real(wp) :: hs(2, 2)
    call cq_shape_derivs(self, x(1:2), g(1:2), hs)
    g(3) = x(3)/self%m_a
    g(4) = x(4)/self%m_b
    stat = 0
    if (.not. all(abs(g(1:4)) <= huge(1.0_wp)) .or. abs(x(1)) + abs(x(2)) > MAX_Q) stat = -1
  end subroutine cq_gradient

  pure subroutine cq_hessian(self, x, h, stat)
    class(coupled_quartic_t), intent(in) :: self
    real(wp), intent(in) :: x(:)
    real(wp), intent(out) :: h(:, :)
    integer, intent(out) :: stat
    real(wp) :: gr(2), hs(2, 2)
    call cq_shape_derivs(self, x(1:2), gr, hs)
    h(1:4, 1:4) = 0
    h(1:2, 1:2) = hs
    h(3, 3) = 1/self%m_a
    h(4, 4) = 1/self%m_b
    stat = 0
    if (abs(x(1)) + abs(x(2)) > MAX_Q) stat = -1
  end subroutine cq_hessian

end module tubes_coupled_quartic
