!> Strings across the C boundary: a NUL-terminated C char array as a Fortran string and back.
!> The one definition for the C API, the namelist reader, the f2py facade and the library
!> wrappers (GSL, SUNDIALS, the Taylor kernels' messages).
module tubes_cstrings
  use, intrinsic :: iso_c_binding, only: c_char, c_null_char
  implicit none
  private
  public :: c_to_f, f_to_c, num
contains
  !> The characters of c before its first NUL (all of c if it has none). Reads nothing past the
  !> NUL, so a section of an assumed-size C string is safe to pass.
  pure function c_to_f(c) result(s)
    character(kind=c_char), intent(in) :: c(:)
    character(:), allocatable :: s
    integer :: n, k
    n = 0
    do while (n < size(c))
      if (c(n + 1) == c_null_char) exit
      n = n + 1
    end do
    allocate (character(n) :: s)
    do k = 1, n
      s(k:k) = c(k)
    end do
  end function c_to_f

  !> s without its trailing blanks into c, NUL-terminated and NUL-padded (cut to size(c) - 1
  !> characters).
  pure subroutine f_to_c(s, c)
    character(*), intent(in) :: s
    character(kind=c_char), intent(out) :: c(:)
    integer :: k
    c = c_null_char
    do k = 1, min(len_trim(s), size(c) - 1)
      c(k) = s(k:k)
    end do
  end subroutine f_to_c

  !> v as C's printf writes it with the conversion spec (".6g", "g", ".1f"; src/base/tubes_format_shim.c):
  !> messages written in Fortran read as the program's others.
  function num(v, spec) result(s)
    use, intrinsic :: iso_c_binding, only: c_double, c_int
    real(c_double), intent(in) :: v
    character(*), intent(in), optional :: spec
    character(:), allocatable :: s
    interface
      subroutine tubes_format_real(v, spec, out, len) bind(C, name='tubes_format_real')
        import :: c_double, c_char, c_int
        real(c_double), value :: v
        character(kind=c_char), intent(in) :: spec(*)
        character(kind=c_char), intent(out) :: out(*)
        integer(c_int), value :: len
      end subroutine tubes_format_real
    end interface
    character(kind=c_char) :: buf(48)
    character(kind=c_char) :: sp(9)
    if (present(spec)) then
      call f_to_c(spec, sp)
    else
      call f_to_c('g', sp)
    end if
    call tubes_format_real(v, sp, buf, 48_c_int)
    s = c_to_f(buf)
  end function num
end module tubes_cstrings
