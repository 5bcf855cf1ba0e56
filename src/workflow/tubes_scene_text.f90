!> The scenes' console helpers (src/workflow/tubes_scene_*.f90): C's %d (%ld), %-ws and %ws for their
!> tables (numbers: tubes_cstrings num, C's own printf), the wall clock for their timings, and their
!> live progress lines (src/base/tubes_progress_shim.c).
module tubes_scene_text
  use, intrinsic :: iso_c_binding, only: c_char, c_int
  use tubes_kinds, only: wp, i8
  use tubes_cstrings, only: f_to_c
  implicit none
  private

  public :: itoa, ls, rs, wall, progress_line

  !> An integer as C's %d (%ld) writes it.
  interface itoa
    module procedure itoa4, itoa8
  end interface itoa

contains

  !> A progress line on stderr now (not a result: src/base/tubes_progress_shim.c, printed only
  !> where the program turned progress on): every = .true.: one item of a scene's list, at most
  !> one such line a second, the first always; .false.: always.
  subroutine progress_line(text, every)
    character(*), intent(in) :: text
    logical, intent(in) :: every
    interface
      subroutine tubes_progress_line(t, n, e) bind(C, name='tubes_progress_line')
        import :: c_char, c_int
        character(kind=c_char), intent(in) :: t(*)
        integer(c_int), value :: n, e
      end subroutine tubes_progress_line
    end interface
    character(kind=c_char) :: buf(len(text) + 1)
    call f_to_c(text, buf)
    call tubes_progress_line(buf, int(len(text), c_int), int(merge(1, 0, every), c_int))
  end subroutine progress_line

  !> Wall-clock seconds.
  real(wp) function wall()
    integer(i8) :: c, r
    call system_clock(c, r)
    wall = real(c, wp)/real(r, wp)
  end function wall

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

  !> s left-justified in a field of w (C's %-ws).
  pure function ls(s, w) result(r)
    character(*), intent(in) :: s
    integer, intent(in) :: w
    character(:), allocatable :: r
    r = s // repeat(' ', max(0, w - len(s)))
  end function ls

  !> s right-justified in a field of w (C's %ws).
  pure function rs(s, w) result(r)
    character(*), intent(in) :: s
    integer, intent(in) :: w
    character(:), allocatable :: r
    r = repeat(' ', max(0, w - len(s))) // s
  end function rs
end module tubes_scene_text
