!> A test ensemble: item k's reals are (k, sqrt(k)), its integer 3k; item 5 fails (status -1).
module test_ensemble_items
  use tubes_kinds, only: wp
  use tubes_ensemble, only: ensemble_t, ens_out_t
  implicit none
  private

  type, extends(ensemble_t), public :: squares_t
    real(wp) :: scale = 1
  contains
    procedure :: item => squares_item
  end type squares_t

contains

  subroutine squares_item(self, k, out)
    class(squares_t), intent(in) :: self
    integer, intent(in) :: k
    type(ens_out_t), intent(inout) :: out
    out%r(:, k) = self%scale*[real(k, wp), sqrt(real(k, wp))]
    out%i(1, k) = 3*k
    if (k == 5) out%st(k) = -1
  end subroutine squares_item
end module test_ensemble_items

!> The ensemble layer (src/parallel/tubes_ensemble.f90) on one rank: every item's results in its
!> column whatever the chunks and threads; skipped items left at 0 and TUBES_OK; TUBES_FAULT
!> fails the item it names (numbered from `first`) without computing it, and only in its loop.
program test_ensemble
  use, intrinsic :: iso_c_binding, only: c_int, c_char, c_null_char
  use tubes_kinds, only: wp
  use tubes_check, only: check_true, check_eq, finish
  use tubes_status, only: TUBES_OK, TUBES_EFAULT
  use tubes_ensemble, only: ens_out_t, ens_run, ens_reuse_ok
  use test_ensemble_items, only: squares_t
  implicit none
  interface
    integer(c_int) function setenv(name, val, overwrite) bind(C, name='setenv')
      import :: c_int, c_char
      character(kind=c_char), intent(in) :: name(*), val(*)
      integer(c_int), value :: overwrite
    end function setenv
  end interface
  integer, parameter :: N = 23
  type(squares_t) :: sq
  type(ens_out_t) :: one, chunked, skipped, faulted
  logical :: skip(N)
  integer :: k, ok
  real(wp) :: expect(2, N)
  expect = reshape([(real(k, wp), sqrt(real(k, wp)), k = 1, N)], [2, N])
  call ens_run(sq, N, one, 2, 1, threads=1)
  call check_true('ensemble: item k in column k', all(one%r == expect) .and. all(one%i(1, :) == 3*[(k, k = 1, N)]))
  call check_true('ensemble: statuses in place', one%st(5) == -1 .and. count(one%st /= TUBES_OK) == 1)
  call ens_run(sq, N, chunked, 2, 1, chunk=4, threads=2)
  call check_true('ensemble: chunks of 4 over 2 threads: the same', all(chunked%r == one%r) .and. &
                  all(chunked%i == one%i) .and. all(chunked%st == one%st))
  skip = mod([(k, k = 1, N)], 3) == 0
  call ens_run(sq, N, skipped, 2, 1, skip=skip)
  call check_true('ensemble: skipped items left at 0, TUBES_OK', all(skipped%r(:, 3:N:3) == 0) .and. &
                  all(skipped%st(3:N:3) == TUBES_OK) .and. all(skipped%r(:, 1:N:3) == expect(:, 1:N:3)))
  call check_true('ensemble: one rank may reuse results', ens_reuse_ok('seed'))
  ok = setenv('TUBES_FAULT'//c_null_char, 'seed:12'//c_null_char, 1_c_int)
  call check_eq('ensemble: setenv', ok, 0)
  call check_true('ensemble: no reuse under an injected fault', .not. ens_reuse_ok('seed'))
  call ens_run(sq, N, faulted, 2, 1, fault='seed', first=10)
  call check_true('ensemble: TUBES_FAULT seed:12 with first = 10 fails item 3, not computed', &
                  faulted%st(3) == TUBES_EFAULT .and. all(faulted%r(:, 3) == 0) .and. faulted%i(1, 3) == 0)
  call check_true('ensemble: the other items computed', all(faulted%r(:, 4:) == expect(:, 4:)) .and. &
                  faulted%st(5) == -1 .and. count(faulted%st /= TUBES_OK) == 2)
  call ens_run(sq, N, faulted, 2, 1, fault='sample')
  call check_true('ensemble: another loop is not faulted', all(faulted%st == one%st))
  call finish('test_ensemble')
end program test_ensemble
