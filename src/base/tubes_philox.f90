!> Counter-based random numbers: Philox4x64-10 (Salmon, Moraes, Dror & Shaw, "Parallel random
!> numbers: as easy as 1, 2, 3", SC11; numpy.random.Philox is the same generator), and normal
!> deviates from it by Box-Muller. A draw is a pure function of (key, counter): the noise of
!> trajectory k at step n is philox(key = seed, counter = (n, k, stream, 0)), whatever thread, MPI
!> rank or lane integrates it and in whatever order: no generator state to carry, copy or share.
!> Unsigned 64-bit words are held in integer(16) in [0, 2^64). tests/test_noise.f90 checks the
!> words against numpy's Philox.
module tubes_philox
  use tubes_kinds, only: wp, PI
  implicit none
  private

  integer, parameter :: I16 = selected_int_kind(38)
  integer(I16), parameter :: TWO32 = 4294967296_I16
  integer(I16), parameter :: TWO64 = TWO32*TWO32
  integer(I16), parameter :: M0 = int(z'D2E7470EE14C6C93', I16), M1 = int(z'CA5A826395121157', I16)
  integer(I16), parameter :: W0 = int(z'9E3779B97F4A7C15', I16), W1 = int(z'BB67AE8584CAA73B', I16)

  public :: philox4x64, philox_normals, I16

contains

  !> The high and low 64-bit words of a * b (a, b in [0, 2^64)).
  pure subroutine mulhilo(a, b, hi, lo)
    integer(I16), intent(in) :: a, b
    integer(I16), intent(out) :: hi, lo
    integer(I16) :: a0, a1, b0, b1, p00, mid
    a0 = modulo(a, TWO32)
    a1 = a/TWO32
    b0 = modulo(b, TWO32)
    b1 = b/TWO32
    p00 = a0*b0
    mid = a0*b1 + a1*b0 + p00/TWO32                 ! < 3 2^64: no overflow in 128 bits
    lo = modulo(mid, TWO32)*TWO32 + modulo(p00, TWO32)
    hi = a1*b1 + mid/TWO32
  end subroutine mulhilo

  !> Philox4x64-10 of counter ctr (4 words) and key (2 words): 4 words in [0, 2^64).
  pure function philox4x64(ctr, key) result(x)
    integer(I16), intent(in) :: ctr(4), key(2)
    integer(I16) :: x(4), k(2), hi0, lo0, hi1, lo1
    integer :: r
    x = ctr
    k = key
    do r = 1, 10
      call mulhilo(M0, x(1), hi0, lo0)
      call mulhilo(M1, x(3), hi1, lo1)
      x = [ieor(ieor(hi1, x(2)), k(1)), lo1, ieor(ieor(hi0, x(4)), k(2)), lo0]
      k = modulo(k + [W0, W1], TWO64)
    end do
  end function philox4x64

  !> Four standard normal deviates from counter ctr and key: the 53 high bits of each word as a
  !> uniform in (0, 1], two Box-Muller pairs.
  pure function philox_normals(ctr, key) result(z)
    integer(I16), intent(in) :: ctr(4), key(2)
    real(wp) :: z(4), u(4), r
    integer(I16) :: w(4)
    integer :: j
    w = philox4x64(ctr, key)
    u = (real(w/2048_I16, wp) + 1)*2.0_wp**(-53)   ! (0, 1]
    do j = 1, 3, 2
      r = sqrt(-2*log(u(j)))
      z(j) = r*cos(2*PI*u(j + 1))
      z(j + 1) = r*sin(2*PI*u(j + 1))
    end do
  end function philox_normals
end module tubes_philox
