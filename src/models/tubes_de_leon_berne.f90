!> The De Leon-Berne model of isomerisation (N. De Leon and B. J. Berne, J. Chem. Phys. 75, 3495
!> (1981)), as in the UPOsHam examples (Naik, Krajnak, Wiggins and Ross): a Morse oscillator x
!> coupled to a symmetric double well y,
!>   H = px^2/(2 m_a) + py^2/(2 m_b) + D (1 - exp(-lambda x))^2
!>       + 4 y^2 (y^2 - 1) exp(-zeta lambda x) + eps_s.
!> The origin is the rank-1 saddle (E = eps_s) between two wells at y = +-1/sqrt(2) (dV/dy = 0
!> there for every x), slightly on the x < 0 side; y = 0 is invariant, so the saddle's Lyapunov
!> orbit is a Morse oscillation along x with a period in closed form (docs/models.md).
module tubes_de_leon_berne
  use tubes_kinds, only: wp
  use tubes_hamiltonian, only: two_mode_t
  implicit none
  private

  !> De Leon-Berne; the parameters' defaults live in tubes_models.
  type, extends(two_mode_t), public :: de_leon_berne_t
    real(wp) :: d        !! dissociation energy D of the Morse oscillator
    real(wp) :: lambda   !! range of the Morse oscillator
    real(wp) :: zeta     !! decay of the double well along x
    real(wp) :: eps_s    !! energy of the saddle
  contains
    procedure :: shape => dlb_shape, shape_derivs => dlb_shape_derivs
  end type de_leon_berne_t

contains

  pure real(wp) function dlb_shape(self, q)
    class(de_leon_berne_t), intent(in) :: self
    real(wp), intent(in) :: q(:)
    dlb_shape = self%d*(1 - exp(-self%lambda*q(1)))**2 &
                + 4*q(2)**2*(q(2)**2 - 1)*exp(-self%zeta*self%lambda*q(1)) + self%eps_s
  end function dlb_shape

  !> With e1 = exp(-lambda x), ez = exp(-zeta lambda x), w(y) = 4 y^2 (y^2 - 1):
  !> V_x = 2 D lambda e1 (1 - e1) - zeta lambda w ez, V_y = w' ez, w' = 16 y^3 - 8 y;
  !> V_xx = 2 D lambda^2 (2 e1^2 - e1) + (zeta lambda)^2 w ez, V_xy = -zeta lambda w' ez,
  !> V_yy = (48 y^2 - 8) ez.
  pure subroutine dlb_shape_derivs(self, q, grad, hess)
    class(de_leon_berne_t), intent(in) :: self
    real(wp), intent(in) :: q(:)
    real(wp), intent(out) :: grad(:), hess(:, :)
    real(wp) :: e1, ez, w, wp_, zl
    zl = self%zeta*self%lambda
    e1 = exp(-self%lambda*q(1))
    ez = exp(-zl*q(1))
    w = 4*q(2)**2*(q(2)**2 - 1)
    wp_ = 16*q(2)**3 - 8*q(2)
    grad(1) = 2*self%d*self%lambda*e1*(1 - e1) - zl*w*ez
    grad(2) = wp_*ez
    hess(1, 1) = 2*self%d*self%lambda**2*(2*e1*e1 - e1) + zl*zl*w*ez
    hess(1, 2) = -zl*wp_*ez
    hess(2, 1) = hess(1, 2)
    hess(2, 2) = (48*q(2)**2 - 8)*ez
  end subroutine dlb_shape_derivs

end module tubes_de_leon_berne
