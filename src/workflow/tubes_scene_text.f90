!> What the scenes' console lines are made of besides numbers (tubes_cstrings num): integers as C's
!> %d writes them, and the wall clock their "(0.7 s)" reads.
module tubes_scene_text
  use tubes_kinds, only: wp, i8
  implicit none
  private

  public :: itoa, wall

  !> An integer as C's %d (%ld) writes it.
  interface itoa
    module procedure itoa4, itoa8
  end interface itoa

contains

  pure function itoa4(i) result(s)
    integer, intent(in) :: i
    character(:), allocatable :: s
    s = itoa8(int(i, i8))
  end function itoa4

  pure function itoa8(i) result(s)
    integer(i8), intent(in) :: i
    character(:), allocatable :: s
    character(24) :: b
    write (b, '(i0)') i
    s = trim(b)
  end function itoa8

  !> Wall-clock seconds.
  real(wp) function wall()
    integer(i8) :: c, r
    call system_clock(c, r)
    wall = real(c, wp)/real(r, wp)
  end function wall
end module tubes_scene_text
