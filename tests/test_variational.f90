!> Analytic Jacobian of the rolling ball and the state transition matrix (variational
!> equations) against finite differences and against invariants: a Hamiltonian flow's STM is
!> symplectic (Phi^T Omega Phi = Omega), and Liouville gives det Phi = exp(trace(J) t) =
!> exp(-2 c t) with damping.
program test_variational
  use tubes_kinds, only: wp
  use tubes_field, only: fd_jacobian
  use tubes_fourwell, only: fourwell_t
  use tubes_ball, only: ball_t, make_ball
  use tubes_hamiltonian, only: damped_t, make_damped
  use tubes_variational, only: variational_t, make_variational, stm_start
  use tubes_dop853, only: dop853_t
  use tubes_integrator, only: propagate
  use tubes_check, only: check_close, check_true, finish
  implicit none
  type(ball_t) :: ball
  type(damped_t) :: damped
  type(fourwell_t) :: surf
  type(variational_t) :: var
  type(dop853_t) :: ig
  real(wp) :: states(4, 5), jac(4, 4), jfd(4, 4), t3(2, 2, 2), gp(2), gm(2), hp(2, 2), hm(2, 2)
  real(wp) :: z(20), phi(4, 4), omega(4, 4), x(4), xp(4), xm(4), phifd(4, 4), d, sc, det
  integer :: k, j, stat
  character(64) :: lbl

  call make_ball(ball, fourwell_t(), 981.0_wp)
  states(:, 1) = [4.0_wp, 12.6_wp, 0.0_wp, 0.0_wp]
  states(:, 2) = [6.1_wp, -0.3_wp, 35.0_wp, -12.0_wp]
  states(:, 3) = [-3.0_wp, 7.5_wp, -60.0_wp, 80.0_wp]
  states(:, 4) = [10.0_wp, 10.0_wp, 5.0_wp, 150.0_wp]
  states(:, 5) = [-0.33_wp, 6.1_wp, 20.0_wp, -1.0_wp]

  ! third derivatives against central differences of the analytic Hessian (step 1e-5 cm:
  ! truncation ~ d^2 |H''''| ~ 1e-11, roundoff ~ eps/d ~ 1e-11)
  do k = 1, 5
    call surf%third(states(1, k), states(2, k), t3)
    d = 1.0e-5_wp
    call surf%derivs(states(1, k) + d, states(2, k), gp, hp)
    call surf%derivs(states(1, k) - d, states(2, k), gm, hm)
    write (lbl, '(a,i0)') 'third derivatives vs FD of the Hessian, x, state ', k
    call check_true(trim(lbl), all(abs(t3(:, :, 1) - (hp - hm)/(2*d)) <= 1.0e-9_wp))
    call surf%derivs(states(1, k), states(2, k) + d, gp, hp)
    call surf%derivs(states(1, k), states(2, k) - d, gm, hm)
    write (lbl, '(a,i0)') 'third derivatives vs FD of the Hessian, y, state ', k
    call check_true(trim(lbl), all(abs(t3(:, :, 2) - (hp - hm)/(2*d)) <= 1.0e-9_wp))
  end do

  ! Jacobian against central differences (fd_jacobian: step eps^(1/3) |x|, error
  ! ~ eps^(2/3) (|f'''| + |f|) ~ 1e-10 relative; allow 1e-7 of the largest entry)
  do k = 1, 5
    call ball%jacobian(0.0_wp, states(:, k), jac, stat)
    call fd_jacobian(ball, 0.0_wp, states(:, k), jfd, stat)
    sc = maxval(abs(jfd))
    write (lbl, '(a,i0)') 'ball Jacobian vs finite differences, state ', k
    call check_close(trim(lbl), maxval(abs(jac - jfd))/sc, 0.0_wp, 1.0e-7_wp)
  end do
  call make_damped(damped, ball, 0.4_wp)
  call damped%jacobian(0.0_wp, states(:, 3), jac, stat)
  call fd_jacobian(damped, 0.0_wp, states(:, 3), jfd, stat)
  call check_close('damped Jacobian vs finite differences', maxval(abs(jac - jfd))/maxval(abs(jfd)), &
                   0.0_wp, 1.0e-7_wp)
  ! trace of the conservative Jacobian vanishes (Hamiltonian: div f = 0), to roundoff of the
  ! largest entries (~ g |Hess| ~ 1e3)
  call ball%jacobian(0.0_wp, states(:, 3), jac, stat)
  call check_close('trace J = 0 (divergence-free)', jac(1, 1) + jac(2, 2) + jac(3, 3) + jac(4, 4), &
                   0.0_wp, 1.0e-12_wp*maxval(abs(jac)))

  ! STM over 0.5 s from the benchmark start (dE = 1500)
  call make_variational(var, ball)
  z = stm_run(var)
  phi = reshape(z(5:20), [4, 4])
  ! symplectic: Phi^T Omega Phi = Omega, Omega = [[0, I], [-I, 0]]. Entries of Phi reach
  ! ~1e2; an integration at tol 1e-12 keeps the invariant to ~1e-12 |Phi|^2 per unit time
  omega = 0
  omega(1, 3) = 1; omega(2, 4) = 1; omega(3, 1) = -1; omega(4, 2) = -1
  sc = maxval(abs(phi))**2
  call check_close('STM is symplectic: |Phi^T Omega Phi - Omega| / |Phi|^2', &
                   maxval(abs(matmul(transpose(phi), matmul(omega, phi)) - omega))/sc, 0.0_wp, 1.0e-10_wp)
  call check_close('det Phi = 1 (Liouville)', det4(phi), 1.0_wp, 1.0e-9_wp*sc**2)
  ! against central differences of the flow map (delta 1e-5 in each coordinate: truncation
  ! ~ delta^2 |d3 flow| and the integration error 1e-12/delta ~ 1e-7, relative to |Phi|)
  do j = 1, 4
    d = 1.0e-5_wp*max(1.0_wp, abs(z(j)))
    x = [4.0_wp, 12.614863819914357_wp, 0.0_wp, 0.0_wp]
    xp = x
    xp(j) = xp(j) + d
    xm = x
    xm(j) = xm(j) - d
    phifd(:, j) = (flow(xp) - flow(xm))/(2*d)
  end do
  call check_close('STM vs finite differences of the flow map, relative', &
                   maxval(abs(phi - phifd))/maxval(abs(phi)), 0.0_wp, 1.0e-6_wp)

  ! damped flow: det Phi = exp(trace J t) = exp(-2 c t) exactly (Liouville)
  call make_variational(var, damped)
  z = stm_run(var)
  phi = reshape(z(5:20), [4, 4])
  det = det4(phi)
  call check_close('damped: det Phi = exp(-2 c t)', det, exp(-2*0.4_wp*0.5_wp), &
                   1.0e-9_wp*maxval(abs(phi))**4)
  call finish('test_variational')

contains

  !> The variational equations v from the benchmark start (dE = 1500) over 0.5 s (DOP853, tol
  !> 1e-12): the state and the STM in stm_start's layout.
  function stm_run(v) result(zz)
    type(variational_t), intent(in) :: v
    real(wp) :: zz(20)
    call ig%init(v, 0.0_wp)
    ig%rtol = 1.0e-12_wp
    ig%atol = 1.0e-12_wp
    zz = stm_start([4.0_wp, 12.614863819914357_wp, 0.0_wp, 0.0_wp])
    call propagate(ig, zz, 0.5_wp, stat)
  end function stm_run

  !> The ball's flow map over 0.5 s from x0 (DOP853, tol 1e-13).
  function flow(x0) result(xx)
    real(wp), intent(in) :: x0(4)
    real(wp) :: xx(4)
    call ig%init(ball, 0.0_wp)
    ig%rtol = 1.0e-13_wp
    ig%atol = 1.0e-13_wp
    xx = x0
    call propagate(ig, xx, 0.5_wp, stat)
  end function flow

  !> Determinant by cofactor expansion (independent of LAPACK).
  pure real(wp) function det4(a)
    real(wp), intent(in) :: a(4, 4)
    integer :: c, r, cc, rr, ci
    real(wp) :: m(3, 3)
    det4 = 0
    do c = 1, 4
      ci = 0
      do cc = 1, 4
        if (cc == c) cycle
        ci = ci + 1
        rr = 0
        do r = 2, 4
          rr = rr + 1
          m(rr, ci) = a(r, cc)
        end do
      end do
      det4 = det4 + (-1)**(c + 1)*a(1, c)*(m(1, 1)*(m(2, 2)*m(3, 3) - m(2, 3)*m(3, 2)) &
             - m(1, 2)*(m(2, 1)*m(3, 3) - m(2, 3)*m(3, 1)) + m(1, 3)*(m(2, 1)*m(3, 2) - m(2, 2)*m(3, 1)))
    end do
  end function det4
end program test_variational
