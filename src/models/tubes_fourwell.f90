!> The machined four-well surface of Ross et al. (2018), eq. (pot_rescale):
!>   H = alpha (x^2 + y^2) - beta (sqrt(x^2 + gamma) + sqrt(y^2 + gamma)) - xi x y + h0
module tubes_fourwell
  use tubes_kinds, only: wp
  use tubes_surface, only: surface_t
  implicit none
  private

  integer, parameter :: rk = wp   ! the kind of the kind-generic source included below

  !> Paper parameters are the defaults.
  type, extends(surface_t), public :: fourwell_t
    real(wp) :: alpha = 0.07_wp     !! curvature of the bowl [1/cm]
    real(wp) :: beta = 1.017_wp     !! depth of the wells [1]
    real(wp) :: gamma = 15.103_wp   !! smoothing of the ridges [cm^2]
    real(wp) :: xi = 0.00656_wp     !! tilt coupling of x and y [1/cm]
    real(wp) :: h0 = 12.065_wp      !! height offset [cm]
  contains
    procedure :: height => fourwell_height, derivs => fourwell_derivs, third => fourwell_third
  end type fourwell_t

contains

  pure function fourwell_height(self, x, y) result(h)
    class(fourwell_t), intent(in) :: self
    real(wp), intent(in) :: x, y
    real(wp) :: h
    h = fourwell_height_of(self%alpha, self%beta, self%gamma, self%xi, self%h0, x, y)
  end function fourwell_height

  pure subroutine fourwell_derivs(self, x, y, grad, hess)
    class(fourwell_t), intent(in) :: self
    real(wp), intent(in)  :: x, y
    real(wp), intent(out) :: grad(2), hess(2, 2)
    call fourwell_derivs_of(self%alpha, self%beta, self%gamma, self%xi, x, y, grad, hess)
  end subroutine fourwell_derivs

  !> Third derivatives: only H_xxx and H_yyy are non-zero (H_xy = -xi is constant).
  pure subroutine fourwell_third(self, x, y, t3)
    class(fourwell_t), intent(in) :: self
    real(wp), intent(in)  :: x, y
    real(wp), intent(out) :: t3(2, 2, 2)
    t3 = 0
    t3(1, 1, 1) = 3*self%beta*self%gamma*x/sqrt(x*x + self%gamma)**5
    t3(2, 2, 2) = 3*self%beta*self%gamma*y/sqrt(y*y + self%gamma)**5
  end subroutine fourwell_third

  include 'tubes_fourwell_formula.inc'   ! the surface in real(wp)
end module tubes_fourwell
