!> Integration methods by code (the same numbers as TUBES_METHOD_* in include/tubes.h).
module tubes_methods
  use tubes_integrator, only: integrator_t
  use tubes_dop853, only: dop853_t
  use tubes_status, only: TUBES_OK, TUBES_EINPUT
  implicit none
  private
  integer, parameter, public :: METHOD_DOP853 = 1   !! Hairer's DOP853, variable step
  public :: new_integrator

contains

  !> Allocate an integrator of the given method code.
  subroutine new_integrator(method, ig, stat)
    integer, intent(in) :: method
    class(integrator_t), allocatable, intent(out) :: ig
    integer, intent(out) :: stat
    stat = TUBES_OK
    select case (method)
    case (METHOD_DOP853)
      allocate (dop853_t :: ig)
    case default
      stat = TUBES_EINPUT
    end select
  end subroutine new_integrator
end module tubes_methods
