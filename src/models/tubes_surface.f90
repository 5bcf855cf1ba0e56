!> A height function z = H(x, y) on which the ball rolls.
!> New surfaces extend surface_t; models, integrators and scenes see only this interface.
module tubes_surface
  use tubes_kinds, only: wp
  implicit none
  private

  !> Abstract surface: height, gradient and Hessian, all analytic.
  type, abstract, public :: surface_t
  contains
    procedure(height_i), deferred :: height   !! H(x, y) [cm]
    procedure(derivs_i), deferred :: derivs   !! gradient [1] and Hessian [1/cm]
    procedure(third_i), deferred :: third     !! third derivatives [1/cm^2]
  end type surface_t

  abstract interface
    pure function height_i(self, x, y) result(h)
      import :: surface_t, wp
      class(surface_t), intent(in) :: self
      real(wp), intent(in) :: x, y   !! position [cm]
      real(wp) :: h                  !! height [cm]
    end function height_i
    pure subroutine derivs_i(self, x, y, grad, hess)
      import :: surface_t, wp
      class(surface_t), intent(in) :: self
      real(wp), intent(in)  :: x, y        !! position [cm]
      real(wp), intent(out) :: grad(2)     !! (H_x, H_y) [1]
      real(wp), intent(out) :: hess(2, 2)  !! [[H_xx, H_xy], [H_xy, H_yy]] [1/cm]
    end subroutine derivs_i
    pure subroutine third_i(self, x, y, t3)
      import :: surface_t, wp
      class(surface_t), intent(in) :: self
      real(wp), intent(in)  :: x, y            !! position [cm]
      real(wp), intent(out) :: t3(2, 2, 2)     !! t3(i, j, k) = d^3 H / dq_i dq_j dq_k [1/cm^2]
    end subroutine third_i
  end interface
end module tubes_surface
