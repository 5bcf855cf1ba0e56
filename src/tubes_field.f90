!> The abstract vector field dx/dt = f(t, x). Models extend it; integrators see only this.
module tubes_field
  use tubes_kinds, only: wp
  implicit none
  private

  type, abstract, public :: vector_field_t
  contains
    procedure(dim_i), deferred :: dim     !! state dimension
    procedure(eval_i), deferred :: eval   !! dx/dt = f(t, x)
  end type vector_field_t

  abstract interface
    pure integer function dim_i(self)
      import :: vector_field_t
      class(vector_field_t), intent(in) :: self
    end function dim_i
    pure subroutine eval_i(self, t, x, dxdt, stat)
      import :: vector_field_t, wp
      class(vector_field_t), intent(in) :: self   ! a model is read-only while integrating
      real(wp), intent(in)  :: t, x(:)
      real(wp), intent(out) :: dxdt(:)
      integer, intent(out)  :: stat               !! 0 ok, >0 retry with a smaller step, <0 fatal
    end subroutine eval_i
  end interface
end module tubes_field
