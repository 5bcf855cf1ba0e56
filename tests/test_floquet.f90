!> The Floquet indices nu = (lambda + 1/lambda)/2 of floquet_indices against matrices built with
!> known spectra: block-diagonal symplectic matrices (a trivial Jordan pair, 2x2 blocks of
!> determinant 1 with trace 2 nu (boosts and rotations: the norm of a monodromy, ~2 nu), a
!> complex quartet diag(A, A^-T)) mixed by a symplectic change of basis, in 2, 3 and 4 degrees
!> of freedom; the counts orbit_crossings takes from them; and the tangents floquet_tangent
!> finds at +1 and -1 (Jordan pairs with known kernels).
program test_floquet
  use tubes_kinds, only: wp
  use tubes_orbits, only: floquet_indices, floquet_tangent
  use tubes_study, only: orbit_crossings, BIF_BRANCH, BIF_PERIOD_DOUBLING, BIF_KREIN
  use tubes_lapack, only: dgesv
  use tubes_check, only: check_close, check_rel, check_eq, finish
  implicit none
  real(wp), allocatable :: m(:, :)
  real(wp) :: nre(3), nim(3), r, th, m0(6, 6), sm(6, 6), v(6), want(6)
  complex(wp) :: lam, nuq
  integer :: stat, c(3)

  ! 2 DOF: one hyperbolic pair, nu = 3.5
  m = mixed(2, [3.5_wp])
  call floquet_indices(m, nre(1:1), nim(1:1), stat)
  call check_eq('2 DOF: status', stat, 0)
  call check_rel('2 DOF: nu = 3.5', nre(1), 3.5_wp, 1.0e-13_wp)
  ! 3 DOF: the L1 Lyapunov orbit's kind of spectrum, a large hyperbolic pair and an elliptic one
  m = mixed(3, [1200.0_wp, 0.7_wp])
  call floquet_indices(m, nre(1:2), nim(1:2), stat)
  call check_rel('3 DOF: nu_1 = 1200', nre(1), 1200.0_wp, 1.0e-12_wp)
  call check_close('3 DOF: nu_2 = 0.7 beside 1200', nre(2), 0.7_wp, 1.0e-10_wp)
  call check_close('3 DOF: real', maxval(abs(nim(1:2))), 0.0_wp, 0.0_wp)
  c = orbit_crossings(nre(1:2), nim(1:2))
  call check_eq('3 DOF: one index above +1', c(BIF_BRANCH), 1)
  ! 3 DOF: inverse hyperbolic, nu = -1.3, and elliptic 0.4
  m = mixed(3, [0.4_wp, -1.3_wp])
  call floquet_indices(m, nre(1:2), nim(1:2), stat)
  call check_close('3 DOF: nu = 0.4 (descending)', nre(1), 0.4_wp, 1.0e-12_wp)
  call check_close('3 DOF: nu = -1.3', nre(2), -1.3_wp, 1.0e-12_wp)
  c = orbit_crossings(nre(1:2), nim(1:2))
  call check_eq('3 DOF: one index below -1', c(BIF_PERIOD_DOUBLING), 1)
  call check_eq('3 DOF: none above +1', c(BIF_BRANCH), 0)
  ! 3 DOF: a complex quartet r exp(+-i th), exp(+-i th)/r on the pairs 2 and 3
  r = 1.05_wp
  th = 0.9_wp
  m = quartet(r, th)
  call floquet_indices(m, nre(1:2), nim(1:2), stat)
  lam = r*exp(cmplx(0.0_wp, th, wp))
  nuq = (lam + 1/lam)/2
  call check_close('quartet: Re nu', nre(1), real(nuq), 1.0e-12_wp)
  call check_close('quartet: Re nu (its conjugate)', nre(2), real(nuq), 1.0e-12_wp)
  call check_close('quartet: |Im nu|', abs(nim(1)), abs(aimag(nuq)), 1.0e-12_wp)
  call check_close('quartet: conjugates', nim(1) + nim(2), 0.0_wp, 1.0e-14_wp)
  c = orbit_crossings(nre(1:2), nim(1:2))
  call check_eq('quartet: two complex indices', c(BIF_KREIN), 2)
  call check_eq('quartet: no real index above +1', c(BIF_BRANCH), 0)
  ! 4 DOF (the companion matrix's roots): 5, 0.3, -2
  m = mixed(4, [0.3_wp, 5.0_wp, -2.0_wp])
  call floquet_indices(m, nre, nim, stat)
  call check_eq('4 DOF: status', stat, 0)
  call check_rel('4 DOF: nu = 5', nre(1), 5.0_wp, 1.0e-11_wp)
  call check_close('4 DOF: nu = 0.3', nre(2), 0.3_wp, 1.0e-11_wp)
  call check_close('4 DOF: nu = -2', nre(3), -2.0_wp, 1.0e-11_wp)
  call check_close('4 DOF: real', maxval(abs(nim)), 0.0_wp, 1.0e-11_wp)
  ! the tangents: a Jordan pair at -1 on pair 2 and one at +1 on pair 3 beside the trivial pair on
  ! pair 1 (flow direction e_q1): kernels e_q2 of m + I and e_q3 of m - I off the flow, carried by S
  m0 = 0
  m0(1, 1) = 1; m0(4, 4) = 1; m0(1, 4) = 0.7_wp
  m0(2, 2) = -1; m0(5, 5) = -1; m0(2, 5) = 0.5_wp
  m0(3, 3) = 1; m0(6, 6) = 1; m0(3, 6) = 0.3_wp
  m = conjugated(m0, 3, sm)
  call floquet_tangent(m, sm(:, 1), -1, v, stat)
  want = sm(:, 2)/norm2(sm(:, 2))
  call check_close('tangent at -1: the kernel of m + I', abs(dot_product(v, want)), 1.0_wp, 1.0e-10_wp)
  call floquet_tangent(m, sm(:, 1), 1, v, stat)
  want = sm(:, 3) - dot_product(sm(:, 3), sm(:, 1))/sum(sm(:, 1)**2)*sm(:, 1)   ! off the flow
  want = want/norm2(want)
  call check_close('tangent at +1: the kernel of m - I off the flow', abs(dot_product(v, want)), 1.0_wp, &
                   1.0e-10_wp)
  call check_close('tangent: unit', norm2(v), 1.0_wp, 1.0e-14_wp)
  call finish('test_floquet')
contains
  !> diag over the pairs (q_i, p_i): the trivial Jordan pair on pair 1, [[nu, a], [d, nu]] with
  !> nu^2 - a d = 1 on the others; mixed by a symplectic change of basis.
  function mixed(n, nu) result(mm)
    integer, intent(in) :: n
    real(wp), intent(in) :: nu(:)
    real(wp), allocatable :: mm(:, :)
    real(wp) :: a, d
    integer :: i
    allocate (mm(2*n, 2*n))
    mm = 0
    mm(1, 1) = 1; mm(n + 1, n + 1) = 1; mm(1, n + 1) = 0.7_wp
    do i = 2, n   ! [[nu, a], [d, nu]], nu^2 - a d = 1: a hyperbolic boost or a rotation
      a = sqrt(abs(nu(i - 1)**2 - 1))
      d = sign(a, abs(nu(i - 1)) - 1)
      mm(i, i) = nu(i - 1); mm(i, n + i) = a; mm(n + i, i) = d; mm(n + i, n + i) = nu(i - 1)
    end do
    mm = conjugated(mm, n)
  end function mixed

  !> 3 DOF: the trivial Jordan pair on pair 1, diag(A, A^-T) on (q2, q3, p2, p3) with A = r R(th).
  function quartet(r, th) result(mm)
    real(wp), intent(in) :: r, th
    real(wp) :: mm(6, 6), a(2, 2)
    a = r*reshape([cos(th), sin(th), -sin(th), cos(th)], [2, 2])
    mm = 0
    mm(1, 1) = 1; mm(4, 4) = 1; mm(1, 4) = 0.7_wp
    mm(2:3, 2:3) = a
    mm(5:6, 5:6) = transpose(a)/r**2   ! A^-T = R(th)/r for A = r R(th)
    mm = conjugated(mm, 3)
  end function quartet

  !> S m S^-1, S = [[G, 0], [0, G^-T]] [[I, K], [0, I]] (K symmetric): symplectic.
  function conjugated(mm, n, s_out) result(out)
    real(wp), intent(in) :: mm(:, :)
    integer, intent(in) :: n
    real(wp), intent(out), optional :: s_out(2*n, 2*n)   !! S
    real(wp) :: out(2*n, 2*n), s(2*n, 2*n), g(n, n), gi(n, n), k(n, n), sh(2*n, 2*n), b(2*n, 2*n)
    integer :: i, j, ipiv(2*n), info, ipn(n)
    do j = 1, n
      do i = 1, n
        g(i, j) = 0.1_wp*sin(1.7_wp*i + 2.3_wp*j)
        k(i, j) = 0.2_wp*cos(0.9_wp*(i + j))
      end do
      g(j, j) = g(j, j) + 1
    end do
    gi = 0
    do i = 1, n
      gi(i, i) = 1
    end do
    b(1:n, 1:n) = g
    call dgesv(n, n, b(1:n, 1:n), n, ipn, gi, n, info)   ! gi = G^-1
    sh = 0
    do i = 1, 2*n
      sh(i, i) = 1
    end do
    sh(1:n, n + 1:2*n) = k
    s = 0
    s(1:n, 1:n) = g
    s(n + 1:2*n, n + 1:2*n) = transpose(gi)
    s = matmul(s, sh)
    if (present(s_out)) s_out = s
    ! out = S m S^-1: solve S^T out^T = (S m)^T
    out = transpose(matmul(s, mm))
    b = transpose(s)
    call dgesv(2*n, 2*n, b, 2*n, ipiv, out, 2*n, info)
    out = transpose(out)
  end function conjugated
end program test_floquet
