!> The LAPACK routines tubes calls, declared once (explicit interfaces, double precision).
module tubes_lapack
  use tubes_kinds, only: wp
  implicit none
  private
  public :: dgesv, dgeev, dsyev, dgels, dlasrt, dgetrf, dgetrs, eigen

  interface
    !> Solve A X = B (LU with partial pivoting).
    subroutine dgesv(n, nrhs, a, lda, ipiv, b, ldb, info)
      import :: wp
      integer, intent(in) :: n, nrhs, lda, ldb
      real(wp), intent(inout) :: a(lda, *), b(ldb, *)
      integer, intent(out) :: ipiv(*), info
    end subroutine dgesv
    !> Eigenvalues (wr + i wi) and optionally eigenvectors of a general matrix.
    subroutine dgeev(jobvl, jobvr, n, a, lda, wr, wi, vl, ldvl, vr, ldvr, work, lwork, info)
      import :: wp
      character, intent(in) :: jobvl, jobvr
      integer, intent(in) :: n, lda, ldvl, ldvr, lwork
      real(wp), intent(inout) :: a(lda, *)
      real(wp), intent(out) :: wr(*), wi(*), vl(ldvl, *), vr(ldvr, *), work(*)
      integer, intent(out) :: info
    end subroutine dgeev
    !> Eigenvalues (ascending) and eigenvectors of a symmetric matrix.
    subroutine dsyev(jobz, uplo, n, a, lda, w, work, lwork, info)
      import :: wp
      character, intent(in) :: jobz, uplo
      integer, intent(in) :: n, lda, lwork
      real(wp), intent(inout) :: a(lda, *)
      real(wp), intent(out) :: w(*), work(*)
      integer, intent(out) :: info
    end subroutine dsyev
    !> Least squares min |A x - b| (QR).
    subroutine dgels(trans, m, n, nrhs, a, lda, b, ldb, work, lwork, info)
      import :: wp
      character, intent(in) :: trans
      integer, intent(in) :: m, n, nrhs, lda, ldb, lwork
      real(wp), intent(inout) :: a(lda, *), b(ldb, *)
      real(wp), intent(out) :: work(*)
      integer, intent(out) :: info
    end subroutine dgels
    !> Sort (id = 'I' increasing, 'D' decreasing).
    subroutine dlasrt(id, n, d, info)
      import :: wp
      character, intent(in) :: id
      integer, intent(in) :: n
      real(wp), intent(inout) :: d(*)
      integer, intent(out) :: info
    end subroutine dlasrt
    !> LU factorisation.
    subroutine dgetrf(m, n, a, lda, ipiv, info)
      import :: wp
      integer, intent(in) :: m, n, lda
      real(wp), intent(inout) :: a(lda, *)
      integer, intent(out) :: ipiv(*), info
    end subroutine dgetrf
    !> Solve with an LU factorisation.
    subroutine dgetrs(trans, n, nrhs, a, lda, ipiv, b, ldb, info)
      import :: wp
      character, intent(in) :: trans
      integer, intent(in) :: n, nrhs, lda, ldb
      real(wp), intent(in) :: a(lda, *)
      integer, intent(in) :: ipiv(*)
      real(wp), intent(inout) :: b(ldb, *)
      integer, intent(out) :: info
    end subroutine dgetrs
  end interface
contains

  !> The eigenvalues wr + i wi of the general matrix a (a is kept) and, with vr, its right
  !> eigenvectors (dgeev's layout: a complex pair in columns j (Re) and j + 1 (Im)); stat
  !> TUBES_ENOCONV if dgeev fails, else TUBES_OK.
  subroutine eigen(a, wr, wi, stat, vr)
    use tubes_status, only: TUBES_OK, TUBES_ENOCONV
    real(wp), intent(in) :: a(:, :)
    real(wp), intent(out) :: wr(:), wi(:)
    integer, intent(out) :: stat
    real(wp), intent(out), optional :: vr(:, :)
    real(wp) :: b(size(a, 1), size(a, 1)), vl(1, 1), v1(1, 1), work(64*size(a, 1))
    integer :: n, info
    n = size(a, 1)
    b = a
    if (present(vr)) then
      call dgeev('N', 'V', n, b, n, wr, wi, vl, 1, vr, n, work, size(work), info)
    else
      call dgeev('N', 'N', n, b, n, wr, wi, vl, 1, v1, 1, work, size(work), info)
    end if
    stat = merge(TUBES_ENOCONV, TUBES_OK, info /= 0)
  end subroutine eigen
end module tubes_lapack
