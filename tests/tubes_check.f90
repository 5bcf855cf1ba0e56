!> Checks for the self-checking test programs: each failed check prints one FAIL line,
!> and finish() ends with `error stop 1` when any check failed.
module tubes_check
  use tubes_kinds, only: wp
  implicit none
  private
  public :: check_close, check_rel, check_true, check_eq, finish

  !> Failed checks so far in this program (the one mutable state a test program owns).
  integer, save :: nfail = 0
  integer, save :: nchecks = 0

contains

  !> |got - want| <= tol.
  subroutine check_close(name, got, want, tol)
    character(*), intent(in) :: name
    real(wp), intent(in) :: got, want, tol
    nchecks = nchecks + 1
    if (.not. (abs(got - want) <= tol)) then
      nfail = nfail + 1
      write (*, '(a,a,a,es24.16,a,es24.16,a,es10.3,a,es10.3)') 'FAIL ', name, ': got ', got, &
        ' want ', want, ' |diff| ', abs(got - want), ' tol ', tol
    else
      write (*, '(a,a,a,es10.3,a,es10.3,a)') 'ok   ', name, ' (|diff| ', abs(got - want), &
        ' <= ', tol, ')'
    end if
  end subroutine check_close

  !> |got - want| <= tol |want|.
  subroutine check_rel(name, got, want, tol)
    character(*), intent(in) :: name
    real(wp), intent(in) :: got, want, tol
    call check_close(name, got, want, tol*abs(want))
  end subroutine check_rel

  subroutine check_true(name, cond, detail)
    character(*), intent(in) :: name
    logical, intent(in) :: cond
    character(*), intent(in), optional :: detail
    nchecks = nchecks + 1
    if (.not. cond) then
      nfail = nfail + 1
      if (present(detail)) then
        write (*, '(a,a,a,a)') 'FAIL ', name, ': ', detail
      else
        write (*, '(a,a)') 'FAIL ', name
      end if
    else
      write (*, '(a,a)') 'ok   ', name
    end if
  end subroutine check_true

  subroutine check_eq(name, got, want)
    character(*), intent(in) :: name
    integer, intent(in) :: got, want
    character(64) :: d
    write (d, '(a,i0,a,i0)') 'got ', got, ' want ', want
    call check_true(name, got == want, trim(d))
  end subroutine check_eq

  !> Summary line; error stop 1 if anything failed.
  subroutine finish(program_name)
    character(*), intent(in) :: program_name
    if (nfail > 0) then
      write (*, '(i0,a,i0,a,a)') nfail, ' of ', nchecks, ' check(s) FAILED in ', program_name
      error stop 1
    end if
    write (*, '(a,i0,a,a)') 'all ', nchecks, ' checks passed in ', program_name
  end subroutine finish
end module tubes_check
