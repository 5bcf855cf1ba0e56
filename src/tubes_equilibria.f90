!> Critical points of the surface (equilibria of the rolling ball, p = 0), their Morse index,
!> names and, at rank-1 saddles, the linearized Hamiltonian flow (LAPACK dgeev).
module tubes_equilibria
  use tubes_kinds, only: wp
  use tubes_ball, only: ball_t, ROLL
  use tubes_status, only: TUBES_OK, TUBES_EINPUT, TUBES_ENOCONV
  implicit none
  private

  real(wp), parameter :: PI = acos(-1.0_wp)

  !> One critical point of H.
  type, public :: equilibrium_t
    real(wp) :: q(2) = 0            !! position (x, y) [cm]
    real(wp) :: height = 0          !! H(x, y) [cm]
    real(wp) :: energy = 0          !! g H [(cm/s)^2]
    real(wp) :: grad_norm = 0       !! |grad H| at q [1], the Newton residual
    real(wp) :: curv(2) = 0         !! Hessian eigenvalues, ascending [1/cm]
    integer :: morse = -1           !! Morse index: 0 well, 1 rank-1 saddle, 2 rank-2 saddle
    character(len=8) :: name = ''   !! W<quadrant>, S<ij> (joins wells i and j), R<k>
    real(wp) :: lambda = 0          !! rank-1 only: real eigenvalue of the flow [1/s]
    real(wp) :: omega = 0           !! rank-1 only: frequency of the centre pair [rad/s]
    real(wp) :: evec(4, 4) = 0      !! rank-1 only: columns u(+lambda), s(-lambda), Re c, Im c
  end type equilibrium_t

  public :: find_equilibria, linearize, rest_jacobian, quadrant

  interface
    subroutine dgeev(jobvl, jobvr, n, a, lda, wr, wi, vl, ldvl, vr, ldvr, work, lwork, info)
      import :: wp
      character, intent(in) :: jobvl, jobvr
      integer, intent(in) :: n, lda, ldvl, ldvr, lwork
      real(wp), intent(inout) :: a(lda, *)
      real(wp), intent(out) :: wr(*), wi(*), vl(ldvl, *), vr(ldvr, *), work(*)
      integer, intent(out) :: info
    end subroutine dgeev
    subroutine dsyev(jobz, uplo, n, a, lda, w, work, lwork, info)
      import :: wp
      character, intent(in) :: jobz, uplo
      integer, intent(in) :: n, lda, lwork
      real(wp), intent(inout) :: a(lda, *)
      real(wp), intent(out) :: w(*), work(*)
      integer, intent(out) :: info
    end subroutine dsyev
  end interface

contains

  !> Quadrant 1..4 of (x, y), 0 on an axis.
  pure integer function quadrant(q)
    real(wp), intent(in) :: q(2)
    quadrant = 0
    if (q(1) > 0 .and. q(2) > 0) quadrant = 1
    if (q(1) < 0 .and. q(2) > 0) quadrant = 2
    if (q(1) < 0 .and. q(2) < 0) quadrant = 3
    if (q(1) > 0 .and. q(2) < 0) quadrant = 4
  end function quadrant

  !> Newton's method on grad H = 0 from q; converged when the step is below roundoff.
  subroutine newton(ball, q, ok)
    type(ball_t), intent(in) :: ball
    real(wp), intent(inout) :: q(2)
    logical, intent(out) :: ok
    real(wp) :: gr(2), hs(2, 2), det, dq(2), scale
    integer :: it
    ok = .false.
    do it = 1, 60
      call ball%surf%derivs(q(1), q(2), gr, hs)
      det = hs(1, 1)*hs(2, 2) - hs(1, 2)*hs(2, 1)
      if (abs(det) < 1.0e-14_wp) return
      dq = [hs(2, 2)*gr(1) - hs(1, 2)*gr(2), hs(1, 1)*gr(2) - hs(2, 1)*gr(1)]/det
      scale = max(1.0_wp, sqrt(sum(dq**2)))   ! damp long steps to 1 cm
      q = q - dq/scale
      if (sqrt(sum(dq**2)) <= 1.0e-14_wp*max(1.0_wp, sqrt(sum(q**2)))) then
        ok = .true.
        return
      end if
    end do
    ok = sqrt(sum(gr**2)) <= 1.0e-13_wp
  end subroutine newton

  !> Eigenvalues (ascending) of the Hessian of H at q.
  subroutine hessian_eigs(ball, q, ev, vecs)
    type(ball_t), intent(in) :: ball
    real(wp), intent(in) :: q(2)
    real(wp), intent(out) :: ev(2), vecs(2, 2)
    real(wp) :: gr(2), work(16)
    integer :: info
    call ball%surf%derivs(q(1), q(2), gr, vecs)
    call dsyev('V', 'U', 2, vecs, 2, ev, work, 16, info)
  end subroutine hessian_eigs

  !> Steepest descent of H from q into a minimum (used to name saddles by their wells).
  subroutine descend(ball, q)
    type(ball_t), intent(in) :: ball
    real(wp), intent(inout) :: q(2)
    real(wp) :: gr(2), hs(2, 2), a, qn(2), h0
    integer :: it
    logical :: ok
    a = 1.0_wp
    do it = 1, 20000
      call ball%surf%derivs(q(1), q(2), gr, hs)
      if (sqrt(sum(gr**2)) < 1.0e-6_wp) exit
      h0 = ball%surf%height(q(1), q(2))
      do
        qn = q - a*gr
        if (ball%surf%height(qn(1), qn(2)) < h0 .or. a < 1.0e-12_wp) exit
        a = a/2
      end do
      q = qn
      a = min(2*a, 10.0_wp)
    end do
    call newton(ball, q, ok)
  end subroutine descend

  !> All critical points of H in |x|, |y| <= box, by Newton from an n_grid x n_grid grid,
  !> deduplicated, classified and named. Sorted: wells, rank-1 saddles, rank-2, by name.
  subroutine find_equilibria(ball, box, n_grid, eqs, stat)
    type(ball_t), intent(in) :: ball
    real(wp), intent(in) :: box        !! half-width of the search box [cm]
    integer, intent(in) :: n_grid      !! starting points per axis (>= 2)
    type(equilibrium_t), allocatable, intent(out) :: eqs(:)
    integer, intent(out) :: stat
    type(equilibrium_t), allocatable :: found(:)
    type(equilibrium_t) :: e
    real(wp) :: q(2), gr(2), hs(2, 2), vecs(2, 2), qa(2), qb(2), dup_tol
    integer :: i, j, n, k, wa, wb, nr, order(64), m
    logical :: ok, dup
    stat = TUBES_OK
    if (box <= 0 .or. n_grid < 2) then
      stat = TUBES_EINPUT
      return
    end if
    allocate (found(64))
    n = 0
    dup_tol = 1.0e-6_wp*max(1.0_wp, box)
    do i = 0, n_grid - 1
      do j = 0, n_grid - 1
        q = [-box + 2*box*i/(n_grid - 1), -box + 2*box*j/(n_grid - 1)]
        call newton(ball, q, ok)
        if (.not. ok) cycle
        if (any(abs(q) > box*(1 + 1.0e-12_wp))) cycle
        dup = .false.
        do k = 1, n
          if (sqrt(sum((found(k)%q - q)**2)) < dup_tol) dup = .true.
        end do
        if (dup .or. n == size(found)) cycle
        n = n + 1
        found(n)%q = q
      end do
    end do
    ! classify
    do k = 1, n
      q = found(k)%q
      call ball%surf%derivs(q(1), q(2), gr, hs)
      found(k)%grad_norm = sqrt(sum(gr**2))
      found(k)%height = ball%surf%height(q(1), q(2))
      found(k)%energy = ball%g*found(k)%height
      call hessian_eigs(ball, q, found(k)%curv, vecs)
      found(k)%morse = count(found(k)%curv < 0)
    end do
    ! names: wells by quadrant; rank-1 saddles by the wells their descent reaches
    nr = 0
    do k = 1, n
      select case (found(k)%morse)
      case (0)
        write (found(k)%name, '(a,i0)') 'W', quadrant(found(k)%q)
      case (1)
        call hessian_eigs(ball, found(k)%q, found(k)%curv, vecs)
        qa = found(k)%q + 1.0e-3_wp*vecs(:, 1)
        qb = found(k)%q - 1.0e-3_wp*vecs(:, 1)
        call descend(ball, qa)
        call descend(ball, qb)
        wa = quadrant(qa)
        wb = quadrant(qb)
        write (found(k)%name, '(a,i0,i0)') 'S', min(wa, wb), max(wa, wb)
        call linearize(ball, found(k)%q, found(k)%lambda, found(k)%omega, found(k)%evec, stat)
        if (stat /= TUBES_OK) return
      case default
        nr = nr + 1
        write (found(k)%name, '(a,i0)') 'R', nr
      end select
    end do
    ! sort by (morse, name): insertion sort on a small list
    m = n
    order(1:m) = [(i, i = 1, m)]
    do i = 2, m
      j = i
      do while (j > 1)
        if (before(found(order(j)), found(order(j - 1)))) then
          k = order(j); order(j) = order(j - 1); order(j - 1) = k
          j = j - 1
        else
          exit
        end if
      end do
    end do
    allocate (eqs(m))
    do i = 1, m
      e = found(order(i))
      eqs(i) = e
    end do
  end subroutine find_equilibria

  pure logical function before(a, b)
    type(equilibrium_t), intent(in) :: a, b
    if (a%morse /= b%morse) then
      before = a%morse < b%morse
    else
      before = llt(a%name, b%name)
    end if
  end function before

  !> Jacobian of Hamilton's equations at a rest point (grad H = 0, p = 0):
  !> [[0, (5/7) I], [-g Hess H, 0]] (the kinetic terms are quadratic in p).
  subroutine rest_jacobian(ball, q, jac)
    type(ball_t), intent(in) :: ball
    real(wp), intent(in) :: q(2)
    real(wp), intent(out) :: jac(4, 4)
    real(wp) :: gr(2), hs(2, 2)
    call ball%surf%derivs(q(1), q(2), gr, hs)
    jac = 0
    jac(1, 3) = ROLL
    jac(2, 4) = ROLL
    jac(3:4, 1:2) = -ball%g*hs
  end subroutine rest_jacobian

  !> Linearized flow at a rank-1 saddle: eigenvalues +-lambda, +-i omega (LAPACK dgeev) and
  !> eigenvectors as columns u, s, Re c, Im c, unit length, largest component positive.
  subroutine linearize(ball, q, lambda, omega, evec, stat)
    type(ball_t), intent(in) :: ball
    real(wp), intent(in) :: q(2)
    real(wp), intent(out) :: lambda, omega, evec(4, 4)
    integer, intent(out) :: stat
    real(wp) :: jac(4, 4), wr(4), wi(4), vl(1, 1), vr(4, 4), work(64), v(4), nrm
    integer :: info, k, iu, is, ic
    stat = TUBES_OK
    call rest_jacobian(ball, q, jac)
    call dgeev('N', 'V', 4, jac, 4, wr, wi, vl, 1, vr, 4, work, 64, info)
    if (info /= 0) then
      stat = TUBES_ENOCONV
      return
    end if
    iu = maxloc(wr, 1)
    is = minloc(wr, 1)
    ic = maxloc(wi, 1)       ! dgeev stores the pair as columns ic (Re) and ic+1 (Im)
    lambda = wr(iu)
    omega = wi(ic)
    if (lambda <= 0 .or. omega <= 0) then
      stat = TUBES_EINPUT    ! not a saddle x centre
      return
    end if
    evec(:, 1) = vr(:, iu)
    evec(:, 2) = vr(:, is)
    evec(:, 3) = vr(:, ic)
    evec(:, 4) = vr(:, ic + 1)
    do k = 1, 4
      v = evec(:, k)
      nrm = sqrt(sum(v**2))
      if (nrm > 0) v = v/nrm
      if (v(maxloc(abs(v), 1)) < 0 .and. k <= 2) v = -v
      evec(:, k) = v
    end do
  end subroutine linearize
end module tubes_equilibria
