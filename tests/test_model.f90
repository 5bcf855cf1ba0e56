!> Checks of the model layer: the four-well surface (analytic gradient and Hessian against
!> finite differences), the rolling-ball Hamiltonian vector field against the Lagrangian
!> (velocity) form of the equations of motion, the energy, energy conservation of the
!> Hamiltonian flow and the dissipation rate of the damped ball. Units cm and s.
!>
!> Finite-difference tolerances are error models, not fitted numbers: a central difference
!> with step d has truncation error (d^2/6) |f'''| and roundoff error ~ k eps S/d, where S
!> is the sum of the magnitudes of the terms that make up f (each evaluation of f is off by
!> a few ulps of S). Where |f'''| has a closed-form bound it is used; elsewhere the
!> truncation error is estimated by Richardson (see dt_check below).
program test_model
  use tubes_kinds, only: wp
  use tubes_fourwell, only: fourwell_t
  use tubes_ball, only: ball_t, make_ball
  use tubes_hamiltonian, only: damped_t, make_damped
  use tubes_check, only: check_close, check_rel, check_true, check_eq, finish
  use tubes_test_models, only: EPS
  implicit none

  real(wp), parameter :: G = 981.0_wp          ! gravity [cm/s^2] (paper value)
  integer, parameter :: NPT = 11               ! surface test points
  integer, parameter :: NST = 6                ! phase-space test states

  type(fourwell_t) :: surf
  type(ball_t) :: ball
  type(damped_t) :: dball
  real(wp) :: pts(2, NPT), st(4, NST)
  real(wp) :: x, y, d, xp, xm, yp, ym, gr(2), hs(2, 2), grp(2), grm(2), fd, tol, q_hi(2), q_lo(2)
  real(wp) :: m3, m4, s_h, s_g, mm(2, 2), v(2), p(2), z(4), f(4), a_lag(2), a_fd(2), a_fd2(2)
  real(wp) :: dt, tol_v, e_mine, kin, de, de2, r_e, c_damp
  integer :: i, j, k, stat
  character, parameter :: XY(2) = ['x', 'y']
  character(64) :: lbl

  ! Surface test points spread over |x|, |y| <= 15 cm: corners, axes, near the origin and
  ! (1.9, 1.9), where |H_xxx| peaks (x^2 = gamma/4).
  pts = reshape([0.0_wp, 0.0_wp, 15.0_wp, 15.0_wp, -15.0_wp, 15.0_wp, 3.7_wp, -8.2_wp, &
                 -12.5_wp, -4.1_wp, 1.9_wp, 1.9_wp, -7.3_wp, 11.2_wp, 14.1_wp, -0.3_wp, &
                 0.5_wp, -14.8_wp, -2.2_wp, 6.6_wp, 9.9_wp, 3.3_wp], [2, NPT])

  ! Random-ish phase-space states (x, y, vx, vy) [cm, cm/s]; speeds up to 100 cm/s, which
  ! is above what the paper's energies reach (|v| ~ 46 cm/s at 1500 (cm/s)^2 excess).
  st = reshape([3.1_wp, -7.4_wp, 23.0_wp, -41.0_wp, &
                -11.2_wp, 5.5_wp, -60.0_wp, 12.0_wp, &
                0.7_wp, 13.9_wp, 5.0_wp, 80.0_wp, &
                -14.3_wp, -14.8_wp, 35.0_wp, 35.0_wp, &
                8.8_wp, 0.2_wp, -15.0_wp, -70.0_wp, &
                1.9_wp, -1.9_wp, 100.0_wp, 3.0_wp], [4, NST])

  call make_ball(ball, surf, G)

  ! --- 1. gradient against central differences of the height ---------------------------
  ! Only the sqrt terms have non-zero third derivatives (alpha and xi terms are quadratic):
  ! d^3H/dx^3 = 3 beta gamma x/(x^2+gamma)^(5/2), largest at x^2 = gamma/4.
  m3 = 3*surf%beta*surf%gamma*(sqrt(surf%gamma)/2)/(1.25_wp*surf%gamma)**2.5_wp
  d = 1.0e-4_wp   ! near the optimum (3 k eps S/m3)^(1/3) ~ 1e-4 cm for S ~ 80 cm
  do i = 1, NPT
    x = pts(1, i); y = pts(2, i)
    call surf%derivs(x, y, gr, hs)
    ! S: sum of the magnitudes of the terms of H; one evaluation of H is good to ~4 eps S,
    ! so the difference quotient carries <= 8 eps S/(2d) (k = 8 allows a factor 2 margin).
    s_h = surf%alpha*(x*x + y*y) + surf%beta*(sqrt(x*x + surf%gamma) + sqrt(y*y + surf%gamma)) &
          + abs(surf%xi*x*y) + abs(surf%h0)
    tol = m3*d**2/6 + 8*EPS*s_h/d          ! truncation + roundoff, ~1.5e-9 at the corners
    xp = x + d; xm = x - d                 ! divide by the representable step xp - xm
    fd = (surf%height(xp, y) - surf%height(xm, y))/(xp - xm)
    write (lbl, '(a,i0)') 'H_x vs FD of H, point ', i
    call check_close(trim(lbl), gr(1), fd, tol)
    yp = y + d; ym = y - d
    fd = (surf%height(x, yp) - surf%height(x, ym))/(yp - ym)
    write (lbl, '(a,i0)') 'H_y vs FD of H, point ', i
    call check_close(trim(lbl), gr(2), fd, tol)
  end do

  ! --- 2. Hessian against central differences of the analytic gradient -----------------
  ! d^4H/dx^4 = 3 beta gamma (gamma - 4x^2)/(x^2+gamma)^(7/2), largest in size at x = 0:
  ! m4 = 3 beta/gamma^(3/2). The mixed entries are FD of a function linear in the other
  ! variable (-xi y), so they carry roundoff only.
  m4 = 3*surf%beta/surf%gamma**1.5_wp
  d = 1.0e-4_wp
  do i = 1, NPT
    x = pts(1, i); y = pts(2, i)
    call surf%derivs(x, y, gr, hs)
    ! terms of a gradient component: 2 alpha |x|, beta |x|/sx, xi |y| (and likewise for y)
    s_g = 2*surf%alpha*max(abs(x), abs(y)) + surf%beta + surf%xi*max(abs(x), abs(y))
    ! ~1.5e-10; at x = 0 (point 1) the truncation bound 8.7e-11 is attained: H_xxxx peaks there
    tol = m4*d**2/6 + 8*EPS*s_g/d
    do j = 1, 2                        ! column j of the Hessian: d/dx (j = 1), d/dy (j = 2)
      q_hi = [x, y]; q_lo = [x, y]
      q_hi(j) = q_hi(j) + d; q_lo(j) = q_lo(j) - d
      call surf%derivs(q_hi(1), q_hi(2), grp, mm)
      call surf%derivs(q_lo(1), q_lo(2), grm, mm)
      do k = 1, 2
        write (lbl, '(6a,i0)') 'H_', XY(k), XY(j), ' vs FD of H_', XY(k), ', point ', i
        call check_close(trim(lbl), hs(k, j), (grp(k) - grm(k))/(q_hi(j) - q_lo(j)), tol)
      end do
    end do
    write (lbl, '(a,i0)') 'Hessian symmetric, point ', i
    call check_true(trim(lbl), hs(1, 2) == hs(2, 1))
  end do

  ! --- 3. Hamilton's equations against the Lagrangian (velocity) form ------------------
  ! Lagrangian of the rolling ball per unit mass: L = (7/10)(x'^2 + y'^2 + z'^2) - g z on
  ! z = H(x, y). With a normal-force multiplier this gives x'' = -h H_x, y'' = -h H_y,
  !   h = (5g/7 + H_xx x'^2 + 2 H_xy x'y' + H_yy y'^2)/(1 + H_x^2 + H_y^2).
  ! The Hamiltonian field f is checked by dq/dt = v and by the acceleration d/dt v(z(t)),
  ! taken as the directional derivative of z -> v(z) = (5/7) M(q)^-1 p along f.
  dt = 1.0e-5_wp   ! [s]; FD step in time along f (error model: dt_check below)
  do i = 1, NST
    x = st(1, i); y = st(2, i); v = st(3:4, i)
    call surf%derivs(x, y, gr, hs)
    mm = mass_matrix(gr)
    p = 1.4_wp*matmul(mm, v)                  ! p = (7/5) M v
    z = [x, y, p]
    ! one product M v / one solve with M: a few ulps times cond(M) = 1 + |grad H|^2
    ! (the eigenvalues of M are 1 and 1 + |grad H|^2); k = 16 leaves a factor ~4 margin.
    tol_v = 16*EPS*(1 + sum(gr**2))*norm2(v)
    write (lbl, '(a,i0)') 'ball%momentum = (7/5) M v, state ', i
    call check_close(trim(lbl), norm2(ball%momentum([x, y], v) - p), 0.0_wp, 1.4_wp*tol_v)
    write (lbl, '(a,i0)') 'ball%velocity round trip, state ', i
    call check_close(trim(lbl), norm2(ball%velocity(z) - v), 0.0_wp, tol_v)
    write (lbl, '(a,i0)') 'own velocity formula round trip, state ', i
    call check_close(trim(lbl), norm2(my_velocity(z) - v), 0.0_wp, tol_v)
    call ball%eval(0.0_wp, z, f, stat)
    write (lbl, '(a,i0)') 'ball%eval stat, state ', i
    call check_eq(trim(lbl), stat, 0)
    write (lbl, '(a,i0)') 'dq/dt = v, state ', i
    call check_close(trim(lbl), norm2(f(1:2) - v), 0.0_wp, tol_v)

    a_lag = -(5*G/7 + dot_product(v, matmul(hs, v)))/(1 + sum(gr**2))*gr
    a_fd = (my_velocity(z + dt*f) - my_velocity(z - dt*f))/(2*dt)
    a_fd2 = (my_velocity(z + 2*dt*f) - my_velocity(z - 2*dt*f))/(4*dt)
    ! dt_check: no closed-form bound on the third derivative of v along f, so the
    ! truncation error is estimated (Richardson): the central difference D(dt) errs by
    ! c dt^2 + O(dt^4), and |D(2dt) - D(dt)| = 3 |c| dt^2 is three times that error; it is
    ! used whole as the bound. A wrong f shifts D(dt) and D(2dt) alike, so the estimate
    ! stays small and the check fails. Roundoff: v(z) is good to ~tol_v, so a quotient
    ! carries <= tol_v/dt; twice that for the two quotients.
    ! dt = 1e-5 s moves q by <= 1e-3 cm and p by ~1e-2 cm/s: truncation (~1e-7..1e-5)
    ! dominates roundoff (~1e-8) and both stay << |a| ~ 30..800 cm/s^2.
    tol = norm2(a_fd2 - a_fd) + 2*tol_v/dt
    write (lbl, '(a,i0)') 'dv/dt along f = Lagrangian acceleration, state ', i
    call check_close(trim(lbl), norm2(a_fd - a_lag), 0.0_wp, tol)
    write (lbl, '(a,i0)') '  (test is not vacuous: tol << |a|), state ', i
    call check_true(trim(lbl), tol < 1.0e-4_wp*norm2(a_lag))

    ! energy: E = (7/10) v^T M v + g H, with v^T M v = |v|^2 + (grad H . v)^2
    kin = 0.7_wp*(sum(v**2) + dot_product(gr, v)**2)
    e_mine = kin + G*surf%height(x, y)
    ! ball%energy forms |p|^2 - s^2/D (cancellation up to cond(M)) and g H (~4 eps g S)
    s_h = surf%alpha*(x*x + y*y) + surf%beta*(sqrt(x*x + surf%gamma) + sqrt(y*y + surf%gamma)) &
          + abs(surf%xi*x*y) + abs(surf%h0)
    write (lbl, '(a,i0)') 'ball%energy = (7/10) v^T M v + g H, state ', i
    call check_close(trim(lbl), ball%energy(z), e_mine, 16*EPS*((1 + sum(gr**2))*kin + G*s_h))

    ! --- 4. energy conservation: dE/dt = grad E . f = 0, FD of E along f ---------------
    de = (ball%energy(z + dt*f) - ball%energy(z - dt*f))/(2*dt)
    de2 = (ball%energy(z + 2*dt*f) - ball%energy(z - 2*dt*f))/(4*dt)
    ! roundoff of one energy evaluation ~ the bound used just above; truncation as dt_check
    r_e = 16*EPS*((1 + sum(gr**2))*kin + G*s_h)
    write (lbl, '(a,i0)') 'dE/dt = 0 (Hamiltonian flow), state ', i
    call check_close(trim(lbl), de, 0.0_wp, abs(de2 - de) + 2*r_e/dt)
    ! the power exchanged between T and V, g grad H . v, is many orders larger
    write (lbl, '(a,i0)') '  (test is not vacuous: tol << g |grad H . v|), state ', i
    call check_true(trim(lbl), abs(de2 - de) + 2*r_e/dt < 1.0e-6_wp*G*abs(dot_product(gr, v)))
  end do

  ! --- 5. damped ball: dE/dt = -2 c T --------------------------------------------------
  ! dp/dt gains -c p and dE/dt = (dT/dp) . (-c p) = -c p . (5/7) M^-1 p = -2 c T.
  c_damp = 0.37_wp   ! [1/s], any positive value
  call make_damped(dball, ball, c_damp)   ! the generic wrapper: -c p on the momenta
  do i = 1, NST
    x = st(1, i); y = st(2, i); v = st(3:4, i)
    call surf%derivs(x, y, gr, hs)
    p = 1.4_wp*matmul(mass_matrix(gr), v)
    z = [x, y, p]
    kin = 0.7_wp*(sum(v**2) + dot_product(gr, v)**2)
    call dball%eval(0.0_wp, z, f, stat)
    write (lbl, '(a,i0)') 'damped eval stat, state ', i
    call check_eq(trim(lbl), stat, 0)
    de = (ball%energy(z + dt*f) - ball%energy(z - dt*f))/(2*dt)
    de2 = (ball%energy(z + 2*dt*f) - ball%energy(z - 2*dt*f))/(4*dt)
    s_h = surf%alpha*(x*x + y*y) + surf%beta*(sqrt(x*x + surf%gamma) + sqrt(y*y + surf%gamma)) &
          + abs(surf%xi*x*y) + abs(surf%h0)
    r_e = 16*EPS*((1 + sum(gr**2))*kin + G*s_h)
    write (lbl, '(a,i0)') 'damped dE/dt = -2 c T, state ', i
    call check_close(trim(lbl), de, -2*c_damp*kin, abs(de2 - de) + 2*r_e/dt)   ! as in 4.
    write (lbl, '(a,i0)') '  (test is not vacuous: tol << 2 c T), state ', i
    call check_true(trim(lbl), abs(de2 - de) + 2*r_e/dt < 1.0e-4_wp*2*c_damp*kin)
  end do
  ! damping leaves dq/dt alone and adds exactly -c p to dp/dt
  z = [st(1:2, 1), 1.4_wp*matmul(mass_matrix(grad_at(st(1:2, 1))), st(3:4, 1))]
  block
    real(wp) :: f0(4), f1(4)
    call ball%eval(0.0_wp, z, f0, stat)
    call dball%eval(0.0_wp, z, f1, stat)
    call check_true('damped: dq/dt unchanged', all(f1(1:2) == f0(1:2)))
    ! one subtraction: 1 ulp of the larger of |dp/dt|, c |p|
    call check_close('damped: dp/dt = conservative - c p', &
                     norm2(f1(3:4) - (f0(3:4) - c_damp*z(3:4))), &
                     0.0_wp, 2*EPS*(norm2(f0(3:4)) + c_damp*norm2(z(3:4))))
  end block

  call finish('test_model')

contains

  !> M = I + grad H grad H^T, written out.
  pure function mass_matrix(gr) result(m)
    real(wp), intent(in) :: gr(2)
    real(wp) :: m(2, 2)
    m(1, 1) = 1 + gr(1)**2
    m(2, 2) = 1 + gr(2)**2
    m(1, 2) = gr(1)*gr(2)
    m(2, 1) = gr(1)*gr(2)
  end function mass_matrix

  function grad_at(q) result(gr)
    real(wp), intent(in) :: q(2)
    real(wp) :: gr(2), hs(2, 2)
    call surf%derivs(q(1), q(2), gr, hs)
  end function grad_at

  !> v = (5/7) M^-1 p with the explicit 2x2 inverse (det M = 1 + H_x^2 + H_y^2).
  function my_velocity(z) result(v)
    real(wp), intent(in) :: z(4)
    real(wp) :: v(2), gr(2), hs(2, 2), m(2, 2), det
    call surf%derivs(z(1), z(2), gr, hs)
    m = mass_matrix(gr)
    det = m(1, 1)*m(2, 2) - m(1, 2)*m(2, 1)
    v(1) = (m(2, 2)*z(3) - m(1, 2)*z(4))/det
    v(2) = (-m(2, 1)*z(3) + m(1, 1)*z(4))/det
    v = (5.0_wp/7.0_wp)*v
  end function my_velocity

end program test_model
