!> Quad-precision reference solutions (tubes_reference, tubes_dop853_qp): the real128 tableau,
!> an oscillator against cos/sin in real128, the real128 ball against the double model and
!> against its own energy (Hamilton's equations), convergence in tol, energy conservation, and
!> agreement with tubes' DOP853 in double on the benchmark problem.
program test_reference
  use tubes_kinds, only: wp, qp, i8
  use tubes_status, only: TUBES_OK, TUBES_EINPUT
  use tubes_dop853_qp, only: dop853_qp_solve, qp_tableau_a, qp_tableau_e3, qp_tableau_e5, &
                             qp_nodes, QP_NS
  use tubes_dop853_tableau, only: tableau_a, tableau_e3, tableau_e5, C
  use tubes_reference, only: reference_solution, ball_qp_t, ball_qp_from_params, REF_TOL_MIN
  use tubes_models, only: conservative_ball
  use tubes_ball, only: ball_t
  use tubes_dop853, only: dop853_t
  use tubes_integrator, only: propagate
  use tubes_check, only: check_close, check_rel, check_true, check_eq, finish
  use tubes_test_models, only: X0_BALL, EPS, qp_oscillator_t
  implicit none

  integer, parameter :: NSX = 16
  real(qp), parameter :: EPSQ = epsilon(1.0_qp)
  ! the paper's parameters as the double values every double run uses (tubes_models)
  real(wp), parameter :: PARAMS(10) = [0.07_wp, 1.017_wp, 15.103_wp, 0.00656_wp, 12.065_wp, &
                                       981.0_wp, 0.0_wp, 0.0_wp, 0.0_wp, 0.0_wp]

  real(qp) :: a(NSX, NSX), e3(QP_NS + 1), e5(QP_NS + 1), cq(NSX), b(QP_NS + 1), res, scale
  real(qp) :: xq(2), x4(4), f4(4), fd(4), xp(4), hq, e0, xs(4, 5), tq, pq(10)
  real(qp) :: tols(5), ratio
  real(wp) :: xd(4), xr(4), xr2(4), f_d(4), err12, err14, est, tol_d, xdd(4, 2), x_wp(4)
  real(wp) :: bw(QP_NS + 1)
  type(ball_qp_t) :: bq
  type(ball_t) :: bd
  type(dop853_t) :: ig
  integer(i8) :: nst, nfe, nst2(5)
  integer :: i, j, k, stat, nbad
  logical :: ok
  character(96) :: lbl

  ! === 1. the real128 tableau ==============================================================
  ! Same decimal strings as tubes_dop853_tableau: rounded to double they give exactly the
  ! double table (double rounding qp -> double differs from decimal -> double only when a
  ! value lies within 2^-113 of a double halfway point: odds ~1e-17 per coefficient).
  ! e3 is computed (b minus three literals) in each precision: there one rounding of a
  ! difference separates them, 1 ulp of the largest term.
  a = qp_tableau_a()
  e3 = qp_tableau_e3()
  e5 = qp_tableau_e5()
  cq = qp_nodes()
  call check_true('qp tableau rounds to the double tableau (a, e5, c exactly)', &
                  all(real(a, wp) == tableau_a()) .and. all(real(e5, wp) == tableau_e5()) .and. &
                  all(real(cq, wp) == C))
  bw = 0
  bw(1:QP_NS) = tableau_a_row13()
  call check_true('qp tableau: e3 within 1 ulp of its terms of the double e3', &
                  all(abs(real(e3, wp) - tableau_e3()) <= EPS*(abs(tableau_e3()) + abs(bw))))
  ! Order conditions in real128. Every coefficient is printed with >= 28 significant digits,
  ! so it is within 5e-28 (relative) of the exact value; a condition sum_j w_j = v then holds
  ! to 5e-28 sum_j |w_j| plus the real128 roundoff n eps_q sum |w_j|. Tolerance: 1e-27 sum |w|.
  nbad = 0
  do i = 2, QP_NS + 1
    res = abs(sum(a(i, 1:i - 1)) - cq(i))
    if (.not. res <= 1.0e-27_qp*(sum(abs(a(i, :))) + cq(i))) nbad = nbad + 1
  end do
  call check_eq('qp tableau: row sums of a = c to 1e-27 (stages 2..13)', nbad, 0)
  b = a(QP_NS + 1, 1:QP_NS + 1)
  nbad = 0
  scale = 0
  do k = 1, 8
    res = abs(sum(b*cq(1:QP_NS + 1)**(k - 1)) - 1.0_qp/k)
    scale = max(scale, res/sum(abs(b*cq(1:QP_NS + 1)**(k - 1))))
    if (.not. res <= 1.0e-27_qp*sum(abs(b*cq(1:QP_NS + 1)**(k - 1)))) nbad = nbad + 1
  end do
  write (*, '(a,es10.2)') '     worst quadrature residual / sum|terms| in real128: ', real(scale, wp)
  call check_eq('qp tableau: sum b c^(k-1) = 1/k, k = 1..8, to 1e-27', nbad, 0)
  nbad = 0
  do i = 3, QP_NS + 1
    res = abs(dot_product(a(i, 1:i - 1), cq(1:i - 1)) - cq(i)**2/2)
    if (.not. res <= 1.0e-27_qp*(sum(abs(a(i, 1:i - 1)*cq(1:i - 1))) + cq(i)**2)) nbad = nbad + 1
  end do
  call check_eq('qp tableau: sum_j a_ij c_j = c_i^2/2 (i >= 3) to 1e-27', nbad, 0)
  call check_true('qp tableau: sum e3 = sum e5 = 0 to 1e-27', &
                  abs(sum(e3)) <= 1.0e-27_qp*sum(abs(e3)) .and. abs(sum(e5)) <= 1.0e-27_qp*sum(abs(e5)))

  ! === 2. oscillator in real128 against cos/sin in real128 =================================
  ! From (1, 0) to t = 10: x = cos 10, v = -sin 10. Bound of test_dop853 section 6: a step
  ! accepted with err <= 1 changes each component by <= 2 tol (1 + |x|) <= 4 tol; the
  ! rotation does not amplify, so after N steps the error is <= 4 N tol. At tol = 1e-28
  ! that is ~1e-24; the aim of the references (1e-25) is checked separately.
  do k = 1, 2
    tq = 10.0_qp**(-20 - 4*k)
    xq = [1.0_qp, 0.0_qp]
    call dop853_qp_solve(qp_oscillator_t(), 0.0_qp, xq, 10.0_qp, tq, tq, stat, nsteps=nst)
    est = real(norm2(xq - [cos(10.0_qp), -sin(10.0_qp)]), wp)
    write (*, '(a,es8.1,a,i0,a,es10.3)') '     qp oscillator tol ', real(tq, wp), ': ', nst, &
      ' steps, error at t = 10: ', est
    write (lbl, '(a,es8.1)') 'qp oscillator: status, tol ', real(tq, wp)
    call check_eq(trim(lbl), stat, TUBES_OK)
    write (lbl, '(a,es8.1)') 'qp oscillator: error <= 4 N tol, tol ', real(tq, wp)
    call check_close(trim(lbl), est, 0.0_wp, real(4*nst*tq, wp))
    if (k == 2) call check_close('qp oscillator, tol 1e-28: error <= 1e-25 (the aim)', est, 0.0_wp, &
                                 1.0e-25_wp)
  end do

  ! === 3. the real128 ball is the double model =============================================
  ! (a) against tubes_ball in double at 6 states: the double evaluation carries roundoff of
  ! a few ulps of its largest intermediate (g |grad H| ~ 1e3 and |u Hess v|): 64 eps times
  ! max(|f|, g) bounds it.
  call conservative_ball(PARAMS, bd, stat)
  call ball_qp_from_params(real(PARAMS, qp), bq, stat)
  call check_eq('ball_qp_from_params: status', stat, TUBES_OK)
  ok = .true.
  do i = 1, 6
    xd = [3*cos(1.1_wp*i), 4*sin(0.7_wp*i) + 2, 40*cos(0.3_wp*i), 30*sin(1.7_wp*i)]
    call bd%eval(0.0_wp, xd, f_d, stat)
    call bq%eval(0.0_qp, real(xd, qp), f4, stat)
    ok = ok .and. all(abs(real(f4, wp) - f_d) <= 64*EPS*max(maxval(abs(f_d)), bd%g))
    ok = ok .and. abs(real(bq%energy(real(xd, qp)), wp) - bd%energy(xd)) <= 64*EPS*abs(bd%energy(xd))
  end do
  call check_true('qp ball: f and E agree with tubes_ball (double) to 64 eps', ok)
  ! (b) Hamilton's equations in real128: dq/dt = dE/dp, dp/dt = -dE/dq by 5-point central
  ! differences of the real128 energy, step 1e-6: truncation h^4/30 |E^(5)| ~ 1e-25 and
  ! roundoff ~ eps_q |E| / h ~ 1e-24 (|E| ~ 3e3). 1e-22 absolute (relative 1e-24 of |f|
  ! ~ 1e2) would fail for any double-precision constant left in the real128 code (1e-17).
  hq = 1.0e-6_qp
  ok = .true.
  scale = 0
  do i = 1, 6
    x4 = real([3*cos(1.1_wp*i), 4*sin(0.7_wp*i) + 2, 40*cos(0.3_wp*i), 30*sin(1.7_wp*i)], qp)
    call bq%eval(0.0_qp, x4, f4, stat)
    do j = 1, 4
      fd(j) = (8*(en(j, hq) - en(j, -hq)) - (en(j, 2*hq) - en(j, -2*hq)))/(12*hq)
    end do
    fd = [fd(3), fd(4), -fd(1), -fd(2)]
    scale = max(scale, maxval(abs(fd - f4)))
    ok = ok .and. all(abs(fd - f4) <= 1.0e-22_qp)
  end do
  write (*, '(a,es10.2)') '     qp ball: max |f - J grad E| (5-point, h = 1e-6): ', real(scale, wp)
  call check_true('qp ball: f = J grad E in real128 to 1e-22 (|f| ~ 1e2)', ok)

  ! === 4. convergence as tol decreases (benchmark start, t = 1 s) ==========================
  ! The step control of DOP853 (err ~ h^8, true local error ~ h^9, N ~ tol^(-1/8)) gives a
  ! global error proportional to tol: successive differences at tol = 1e-18, ..., 1e-26
  ! shrink by 100 each. Window [30, 300]: the step sequence changes discretely with tol.
  tols = [1.0e-18_qp, 1.0e-20_qp, 1.0e-22_qp, 1.0e-24_qp, 1.0e-26_qp]
  do k = 1, 5
    call reference_solution(real(PARAMS, qp), real(X0_BALL, qp), 1.0_qp, tols(k), xs(:, k), &
                            stat, nsteps=nst2(k))
    write (lbl, '(a,es8.1)') 'qp ball to t = 1: status, tol ', real(tols(k), wp)
    call check_eq(trim(lbl), stat, TUBES_OK)
  end do
  scale = maxval(abs(xs(:, 5)))
  do k = 1, 3
    ratio = maxval(abs(xs(:, k + 1) - xs(:, k)))/maxval(abs(xs(:, k + 2) - xs(:, k + 1)))
    write (*, '(a,es8.1,a,es10.3,a,f7.1,a,i0,a)') '     tol ', real(tols(k), wp), &
      ': |x(tol) - x(tol/100)|/max|x| = ', real(maxval(abs(xs(:, k + 1) - xs(:, k)))/scale, wp), &
      ', ratio to the next ', real(ratio, wp), ' (', nst2(k), ' steps)'
    write (lbl, '(a,es8.1,a)') 'qp ball: difference shrinks x100 per tol/100 from tol ', &
      real(tols(k), wp), ' (window [30, 300])'
    call check_true(trim(lbl), ratio >= 30 .and. ratio <= 300)
  end do
  ! error of the tol = 1e-26 run: the last difference / 99 (geometric tail of ratio 100)
  est = real(maxval(abs(xs(:, 5) - xs(:, 4)))/99/scale, wp)
  write (*, '(a,es10.3)') '     estimated relative error at tol 1e-26, t = 1: ', est
  call check_true('qp ball, tol 1e-26, t = 1: estimated relative error <= 1e-25', est <= 1.0e-25_wp)
  ! energy: E is conserved by the flow; its drift is the integration error (roundoff of E
  ! itself ~1e-33)
  e0 = bq%energy(real(X0_BALL, qp))
  est = real(abs(bq%energy(xs(:, 5)) - e0)/abs(e0), wp)
  write (*, '(a,es10.3)') '     qp ball, tol 1e-26: |E(1) - E0|/E0 = ', est
  call check_true('qp ball, tol 1e-26: energy conserved to 1e-25 relative', est <= 1.0e-25_wp)

  ! === 5. double and real128 interfaces ====================================================
  call reference_solution(PARAMS, X0_BALL, 1.0_wp, 1.0e-18_wp, x_wp, stat)
  call check_true('wp variant = real128 variant rounded to double (same inputs)', &
                  stat == TUBES_OK .and. all(x_wp == real(xs(:, 1), wp)))
  pq = real(PARAMS, qp)
  pq(7) = 0.025_qp
  call reference_solution(pq, real(X0_BALL, qp), 1.0_qp, 1.0e-20_qp, x4, stat)
  call check_eq('damped model refused (conservative only)', stat, TUBES_EINPUT)
  pq(7) = 0
  pq(8) = 0.002_qp
  call reference_solution(pq, real(X0_BALL, qp), 1.0_qp, 1.0e-20_qp, x4, stat)
  call check_eq('rolling resistance refused (conservative only)', stat, TUBES_EINPUT)
  call reference_solution(PARAMS, X0_BALL, 1.0_wp, 0.0_wp, x_wp, stat)
  call check_eq('tol = 0 refused', stat, TUBES_EINPUT)
  call reference_solution(PARAMS, X0_BALL, 1.0_wp, real(REF_TOL_MIN/10, wp), x_wp, stat)
  call check_eq('tol below REF_TOL_MIN refused', stat, TUBES_EINPUT)

  ! === 6. tubes' DOP853 in double against the reference =====================================
  ! (a) t = 1 s (the flow amplifies little): the double run at tol 1e-12 must be within the
  ! linear-accumulation bound of section 2, 4 N tol (1 + max|x|), of the real128 solution
  ! (section 4, tol 1e-20, error ~1e-22).
  call ig%init(bd, t0=0.0_wp)
  ig%rtol = 1.0e-12_wp
  ig%atol = 1.0e-12_wp
  xd = X0_BALL
  call propagate(ig, xd, 1.0_wp, stat)
  scale = maxval(abs(xs(:, 2)))
  err12 = maxval(abs(xd - real(xs(:, 2), wp)))
  write (*, '(a,i0,a,es10.3)') '     tubes DOP853 double, tol 1e-12, t = 1: ', ig%nsteps, &
    ' steps, relative error ', err12/real(scale, wp)
  call check_close('DOP853 double tol 1e-12, t = 1, vs reference: <= 4 N tol (1 + max|x|)', &
                   err12, 0.0_wp, 4*(ig%nsteps + 1)*1.0e-12_wp*(1 + real(scale, wp)))
  ! (b) the benchmark to t = 10 s. Reference at tol 1e-20; its own error is estimated by the
  ! run at 1e-22 (difference / 0.99, section 4). With global error proportional to tol
  ! (section 4) the double run at 1e-14 is ~100x closer to the reference than the one at
  ! 1e-12 (until roundoff, ~1e-13 relative in double, takes over): check err14 <= err12/10,
  ! and that the reference resolves err14 (its own error < err14/10).
  call reference_solution(PARAMS, X0_BALL, 10.0_wp, 1.0e-20_wp, xr, stat, nsteps=nst, nfev=nfe)
  call check_eq('reference to t = 10, tol 1e-20: status', stat, TUBES_OK)
  call reference_solution(PARAMS, X0_BALL, 10.0_wp, 1.0e-22_wp, xr2, stat)
  scale = maxval(abs(real(xr2, qp)))
  est = maxval(abs(xr - xr2))/real(scale, wp)/0.99_wp
  write (*, '(a,i0,a,i0,a,es10.3)') '     reference t = 10, tol 1e-20: ', nst, ' steps, ', nfe, &
    ' f evaluations; estimated relative error ', est
  do k = 1, 2
    tol_d = 10.0_wp**(-10 - 2*k)
    call ig%init(bd, t0=0.0_wp)
    ig%rtol = tol_d
    ig%atol = tol_d
    xdd(:, k) = X0_BALL
    call propagate(ig, xdd(:, k), 10.0_wp, stat)
    write (*, '(a,es8.1,a,i0,a,es10.3)') '     tubes DOP853 double, tol ', tol_d, ': ', ig%nsteps, &
      ' steps, relative error at t = 10: ', maxval(abs(xdd(:, k) - xr2))/real(scale, wp)
  end do
  err12 = maxval(abs(xdd(:, 1) - xr2))
  err14 = maxval(abs(xdd(:, 2) - xr2))
  call check_true('DOP853 double, t = 10: tol 1e-14 at least 10x closer to the reference than 1e-12', &
                  err14 <= err12/10)
  call check_true('reference tol 1e-20, t = 10, resolves the double error (own error < err14/10)', &
                  est*real(scale, wp) < err14/10)

  call finish('test_reference')

contains

  !> The 8th-order weights b (row 13 of a) of the double tableau.
  function tableau_a_row13() result(r)
    real(wp) :: r(QP_NS), aa(NSX, NSX)
    aa = tableau_a()
    r = aa(QP_NS + 1, 1:QP_NS)
  end function tableau_a_row13

  !> Energy with component j of x4 shifted by dh.
  real(qp) function en(j, dh)
    integer, intent(in) :: j
    real(qp), intent(in) :: dh
    xp = x4
    xp(j) = xp(j) + dh
    en = bq%energy(xp)
  end function en
end program test_reference
