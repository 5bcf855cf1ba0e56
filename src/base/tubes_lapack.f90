!> The LAPACK routines tubes calls, declared once (explicit interfaces, double precision).
module tubes_lapack
  use tubes_kinds, only: wp
  implicit none
  private
  public :: dgesv, dgeev, dsyev, dgels, dlasrt, dgetrf, dgetrs

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
end module tubes_lapack
