!> The vector field of the real128 reference solutions (tubes_dop853_qp), in a module of its own
!> so that the kind-generic sources can name it field_rk.
module tubes_qp_field
  use tubes_kinds, only: qp
  implicit none
  private

  !> A vector field dx/dt = f(t, x) in real128.
  type, abstract, public :: qp_field_t
  contains
    procedure(qp_dim_i), deferred :: dim     !! state dimension
    procedure(qp_eval_i), deferred :: eval   !! dx/dt = f(t, x)
  end type qp_field_t

  abstract interface
    pure integer function qp_dim_i(self)
      import :: qp_field_t
      class(qp_field_t), intent(in) :: self
    end function qp_dim_i
    pure subroutine qp_eval_i(self, t, x, dxdt, stat)
      import :: qp_field_t, qp
      class(qp_field_t), intent(in) :: self
      real(qp), intent(in) :: t, x(:)
      real(qp), intent(out) :: dxdt(:)
      integer, intent(out) :: stat     !! 0 ok, > 0 retry with a smaller step, < 0 fatal
    end subroutine qp_eval_i
  end interface

end module tubes_qp_field
