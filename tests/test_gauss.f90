!> Gauss-Legendre collocation (tubes_gauss): tableau order conditions, measured convergence
!> orders (oscillator, rolling ball), conservation of the quadratic invariant, bounded energy
!> error on the ball over 1000 s against DOP853's drift, time reversibility, the two stage
!> solvers, dense output, extrapolated starting guesses, and failure statuses.
program test_gauss
  use, intrinsic :: ieee_arithmetic, only: ieee_is_nan
  use tubes_kinds, only: wp
  use tubes_status, only: TUBES_OK, TUBES_EVENT, TUBES_EINPUT, TUBES_EMODEL, TUBES_ENOCONV
  use tubes_gauss, only: gauss_t, gauss_tableau, collocation_tableau
  use tubes_dop853, only: dop853_t
  use tubes_integrator, only: integrator_t, propagate, plane_t
  use tubes_field, only: vector_field_t
  use tubes_fourwell, only: fourwell_t
  use tubes_ball, only: ball_t, make_ball
  use tubes_variational, only: variational_t, make_variational, stm_start
  use tubes_check, only: check_close, check_rel, check_true, check_eq, finish
  use tubes_test_models, only: X0_BALL, PI, EPS, oscillator_t, nan_oscillator_t, dense_probe_t, rotate
  implicit none

  integer, parameter :: SMAX = 4
  real(wp), parameter :: COND_V(2:4) = [6.2_wp, 35.7_wp, 283.3_wp]   !! cond_inf of Vandermonde

  type(gauss_t) :: ig
  type(dop853_t) :: dp
  type(ball_t) :: ball
  type(variational_t) :: var
  type(dense_probe_t), allocatable :: probe(:)
  real(wp) :: a(SMAX, SMAX), b(SMAX), c(SMAX), av(SMAX, SMAX), bv(SMAX), aref(SMAX, SMAX)
  real(wp) :: x(2), xf(2), xb(2), z(4), zs(2, 4, 3), err(3), h, order, tol, lhs, rhs, sabs
  real(wp) :: de, emax(2, 2), drift(2), dif(2), amp, xmax, phi(4, 4), zv(20)
  real(wp) :: p0, p1, p2, dp_, q, cpade, pm(2, 2), rhoj
  complex(wp) :: wz, zc
  integer :: s, i, j, k, m, stat, nbad
  integer :: nit(2)
  character(100) :: lbl

  ! === 1. tableaux ========================================================================
  ! Roundoff model (as in test_dop853): a coefficient is its exact value rounded (1/2 ulp),
  ! possibly after a few rounded operations (closed forms: <= ~4 ulps); a sum of n products
  ! evaluated in floating point is off by ~n eps (sum of |terms|) (Higham's gamma_n). Each
  ! tolerance below is 4 (n + s) eps times the sum of |terms|: the computation's worst-case
  ! operation count plus the coefficients' own few ulps.
  ! s = 4, a_ij: 30-digit values from mpmath (50-digit arithmetic: roots of the shifted
  ! Legendre polynomial P_4(2c - 1), a_ij = int_0^c_i l_j by adaptive quadrature), an
  ! independent reference for the quadrature formula in gauss_tableau.
  aref(1, :) = [0.0869637112843634643432659873055_wp, -0.026604180084998793313385130477_wp, &
                0.0126274626894047245150568805746_wp, -0.00355514968579568315691098184957_wp]
  aref(2, :) = [0.188118117499868071650685545087_wp, 0.163036288715636535656734012695_wp, &
                -0.027880428602470895224151106419_wp, 0.0067355005945381555153986690857_wp]
  aref(3, :) = [0.167191921974188773171133305525_wp, 0.353953006033743966537619131808_wp, &
                0.163036288715636535656734012695_wp, -0.0141906949311411429641535704762_wp]
  aref(4, :) = [0.177482572254522611843442956461_wp, 0.313445114741868346798411144814_wp, &
                0.352676757516271864626853155866_wp, 0.0869637112843634643432659873055_wp]
  do s = 2, 4
    call gauss_tableau(s, a(1:s, 1:s), b(1:s), c(1:s), stat)
    write (lbl, '(a,i0)') 'tableau: status, s = ', s
    call check_eq(trim(lbl), stat, TUBES_OK)
    ! nodes: roots of the shifted Legendre polynomial P_s(2c - 1) (Bonnet's recurrence). A
    ! Newton step P_s/P_s' from each node must move it by no more than its evaluation error:
    ! c is rounded (1/2 ulp), P_s(x) by the recurrence has ~s eps of relative error in
    ! terms of size <= 1 and |P_s'| >= ~s at the roots: <= 4 eps
    nbad = 0
    do i = 1, s
      q = 2*c(i) - 1
      p0 = 1
      p1 = q
      do k = 1, s - 1
        p2 = ((2*k + 1)*q*p1 - k*p0)/(k + 1)
        p0 = p1
        p1 = p2
      end do
      dp_ = s*(q*p1 - p0)/(q*q - 1)     ! (x^2 - 1) P_s' = s (x P_s - P_(s-1))
      if (.not. abs(p1/dp_)/2 <= 4*EPS) nbad = nbad + 1   ! /2: from x = 2c - 1 back to c
    end do
    write (lbl, '(a,i0)') 'tableau: nodes are the roots of P_s(2c - 1), s = ', s
    call check_eq(trim(lbl), nbad, 0)
    ! B(2s): sum_i b_i c_i^(k-1) = 1/k, k = 1..2s; and the order is exactly 2s
    nbad = 0
    do k = 1, 2*s
      sabs = sum(abs(b(1:s)*c(1:s)**(k - 1)))
      if (.not. abs(sum(b(1:s)*c(1:s)**(k - 1)) - 1.0_wp/k) <= 4*(k + s)*EPS*sabs) nbad = nbad + 1
    end do
    write (lbl, '(a,i0)') 'tableau: B(2s) sum b c^(k-1) = 1/k, k <= 2s, s = ', s
    call check_eq(trim(lbl), nbad, 0)
    ! k = 2s + 1 fails (order exactly 2s) by the Gauss quadrature error for x^(2s) on [0, 1],
    ! 1/(2s+1) - sum b c^(2s) = (s!)^4/((2s+1) ((2s)!)^2) = 5.6e-3, 3.6e-4, 2.3e-5
    write (lbl, '(a,i0)') 'tableau: B(2s + 1) defect = (s!)^4/((2s+1) ((2s)!)^2), s = ', s
    sabs = sum(abs(b(1:s)*c(1:s)**(2*s)))
    call check_close(trim(lbl), 1.0_wp/(2*s + 1) - sum(b(1:s)*c(1:s)**(2*s)), &
                     gamma(s + 1.0_wp)**4/((2*s + 1)*gamma(2*s + 1.0_wp)**2), 4*(3*s + 1)*EPS*sabs)
    ! C(s): sum_j a_ij c_j^(k-1) = c_i^k / k, k = 1..s
    nbad = 0
    do k = 1, s
      do i = 1, s
        lhs = sum(a(i, 1:s)*c(1:s)**(k - 1))
        sabs = sum(abs(a(i, 1:s)*c(1:s)**(k - 1))) + c(i)**k/k
        if (.not. abs(lhs - c(i)**k/k) <= 4*(k + s)*EPS*sabs) nbad = nbad + 1
      end do
    end do
    write (lbl, '(a,i0)') 'tableau: C(s) sum_j a_ij c_j^(k-1) = c_i^k/k, k <= s, s = ', s
    call check_eq(trim(lbl), nbad, 0)
    ! D(s): sum_i b_i c_i^(k-1) a_ij = b_j (1 - c_j^k)/k, k = 1..s
    nbad = 0
    do k = 1, s
      do j = 1, s
        lhs = sum(b(1:s)*c(1:s)**(k - 1)*a(1:s, j))
        rhs = b(j)*(1 - c(j)**k)/k
        sabs = sum(abs(b(1:s)*c(1:s)**(k - 1)*a(1:s, j))) + abs(rhs)
        if (.not. abs(lhs - rhs) <= 4*(k + s)*EPS*sabs) nbad = nbad + 1
      end do
    end do
    write (lbl, '(a,i0)') 'tableau: D(s) sum_i b_i c_i^(k-1) a_ij = b_j (1 - c_j^k)/k, s = ', s
    call check_eq(trim(lbl), nbad, 0)
    ! symplecticity b_i a_ij + b_j a_ji = b_i b_j and symmetry a_ij + a_(s+1-i, s+1-j) = b_j,
    ! c_i + c_(s+1-i) = 1 (what makes the method time-reversible)
    nbad = 0
    do i = 1, s
      do j = 1, s
        sabs = abs(b(i)*a(i, j)) + abs(b(j)*a(j, i)) + abs(b(i)*b(j))
        lhs = b(i)*a(i, j) + b(j)*a(j, i)
        if (.not. abs(lhs - b(i)*b(j)) <= 4*(2 + s)*EPS*sabs) nbad = nbad + 1
        sabs = abs(a(i, j)) + abs(a(s + 1 - i, s + 1 - j)) + abs(b(j))
        lhs = a(i, j) + a(s + 1 - i, s + 1 - j)
        if (.not. abs(lhs - b(j)) <= 4*(2 + s)*EPS*sabs) nbad = nbad + 1
      end do
      if (.not. abs(c(i) + c(s + 1 - i) - 1) <= 4*(2 + s)*EPS) nbad = nbad + 1
    end do
    write (lbl, '(a,i0)') 'tableau: symplectic and symmetric, s = ', s
    call check_eq(trim(lbl), nbad, 0)
    ! the general collocation solver (Vandermonde, dgesv) agrees with the closed forms: LU
    ! with partial pivoting has a backward error of ~s eps, so the forward error is <= s
    ! cond(V) eps, with cond_inf(V) = 6.2, 35.7, 283.3 for the Gauss nodes (V(i, k) =
    ! c_i^(k-1); numpy.linalg.cond)
    call collocation_tableau(c(1:s), av(1:s, 1:s), bv(1:s), stat)
    write (lbl, '(a,i0)') 'tableau: Vandermonde collocation solve = closed form, s = ', s
    tol = s*COND_V(s)*EPS
    call check_true(trim(lbl), stat == TUBES_OK .and. &
                    maxval(abs(av(1:s, 1:s) - a(1:s, 1:s))) <= tol .and. &
                    maxval(abs(bv(1:s) - b(1:s))) <= tol)
  end do
  ! a_ij of s = 4 against the mpmath reference: the quadrature a_ij = c_i sum_k b_k l_j(c_i c_k)
  ! has 4 terms of ~8 rounded operations each, |l_j| <= 1.3 on [0, 1], sum_k b_k = 1: within
  ! ~8 eps; the reference itself is exact to 30 digits
  call gauss_tableau(4, a, b, c, stat)
  write (*, '(a,es10.3)') '     s = 4: max |a - a_mpmath| / eps = ', maxval(abs(a - aref))/EPS
  call check_close('tableau: s = 4 a_ij = 30-digit reference', maxval(abs(a - aref)), 0.0_wp, 8*EPS)
  call gauss_tableau(5, a, b, c, stat)
  call check_eq('tableau: s = 5 is TUBES_EINPUT', stat, TUBES_EINPUT)

  ! === 2. convergence order on the oscillator ==============================================
  ! Global error at t = 10 of a method of order 2s: C t h^(2s). A symmetric method's error
  ! expands in even powers, C h^(2s) (1 + d h^2 + ...), so the order measured from h and
  ! h/2 is off by log2((1 + d h^2)/(1 + d h^2/4)) ~ 1.1 d h^2: at h = 1 (omega h = 1)
  ! d ~ 0.06 (measured: 3.93 from h = 1, 1/2 for s = 2): window 2s -+ 0.25.
  ! h = 1, 1/2, 1/4 divide 10 exactly (no remainder step); the smallest error (s = 4,
  ! h = 1/4: 6e-12) is > 1000x the roundoff floor (~40 steps of a few ulps ~ 1e-14).
  do s = 2, 4
    do i = 1, 3
      h = 1.0_wp/2**(i - 1)
      call start(ig, oscillator_t(), s, h)
      x = [1.0_wp, 0.0_wp]
      call propagate(ig, x, 10.0_wp, stat)
      write (lbl, '(a,i0,a,f5.3)') 'oscillator gauss', 2*s, ': status, h = ', h
      call check_eq(trim(lbl), stat, TUBES_OK)
      err(i) = norm2(x - rotate([1.0_wp, 0.0_wp], 10.0_wp))
    end do
    write (*, '(a,i0,a,3es10.3)') '     gauss', 2*s, ' errors at t = 10, h = 1, 1/2, 1/4: ', err
    ! error constant: a step maps w = x + i v to R(-i h) w, R the (s,s) Pade approximant of
    ! exp, with exp(z) - R(z) = +-(s!)^2/((2s)! (2s+1)!) z^(2s+1) + O(z^(2s+2)); |R| = 1, so
    ! the error is a phase error of t/h such terms: t C h^(2s). At h = 1/4 the O(h^2)
    ! relative correction is ~0.06/16 (from the h = 1 order above): window 2%
    cpade = gamma(s + 1.0_wp)**2/(gamma(2*s + 1.0_wp)*gamma(2*s + 2.0_wp))
    write (lbl, '(a,i0,a)') 'oscillator gauss', 2*s, &
      ' error at h = 1/4 = 10 (s!)^2/((2s)!(2s+1)!) h^2s'
    call check_rel(trim(lbl), err(3), 10*cpade*0.25_wp**(2*s), 0.02_wp)
    do i = 1, 2
      order = log(err(i)/err(i + 1))/log(2.0_wp)
      write (lbl, '(a,i0,a,f5.3,a,f5.3)') 'oscillator order of gauss', 2*s, ' from h = ', &
        1.0_wp/2**(i - 1), ' and ', 0.5_wp/2**(i - 1)
      call check_close(trim(lbl), order, 2.0_wp*s, 0.25_wp)
    end do
  end do

  ! === 3. convergence order on the rolling ball (Richardson) ===============================
  ! From rest at (4, 12.614863819914357) cm to t = 1 s, no exact solution: z_h - z_(h/2)
  ! = C h^p (1 - 2^-p) + ..., so successive differences shrink by 2^p. The motion's time
  ! scale is ~0.05 s (test_dop853, section 4); h = 1/32, 1/64, 1/128 s (exact in binary: no
  ! remainder steps) keeps h below it, and the smallest difference (gauss8, h/2 vs h/4,
  ! 2.4e-11 cm) stays > 100x above the roundoff floor (~3e-14 cm, measured between 1/256
  ! and 1/512 s). Even-power error expansion as in 2, with h/0.05 s <= 0.6: window -+ 0.5.
  ! Measure: RMS of the position differences at t = 0.25, 0.5, 0.75, 1 s (robust against
  ! a zero crossing of one component's error coefficient, see test_dop853).
  call make_ball(ball, fourwell_t(), 981.0_wp)
  do s = 2, 4
    do i = 1, 3
      call start(ig, ball, s, (1.0_wp/32)/2**(i - 1))
      z = X0_BALL
      do k = 1, 4
        call propagate(ig, z, 0.25_wp*k, stat)
        if (stat /= TUBES_OK) exit
        zs(:, k, i) = z(1:2)
      end do
      write (lbl, '(a,i0,a,es8.2)') 'ball gauss', 2*s, ': status, h = ', ig%h
      call check_eq(trim(lbl), stat, TUBES_OK)
    end do
    dif(1) = sqrt(sum((zs(:, :, 1) - zs(:, :, 2))**2)/8)
    dif(2) = sqrt(sum((zs(:, :, 2) - zs(:, :, 3))**2)/8)
    order = log(dif(1)/dif(2))/log(2.0_wp)
    write (*, '(a,i0,a,2es10.3,a,f6.3)') '     gauss', 2*s, ' RMS position differences [cm]: ', &
      dif, '  order ', order
    write (lbl, '(a,i0,a)') 'ball Richardson order of gauss', 2*s, ' (h = 1/32, 1/64, 1/128 s)'
    call check_close(trim(lbl), order, 2.0_wp*s, 0.5_wp)
  end do

  ! === 4. quadratic invariant of the oscillator ============================================
  ! Gauss methods conserve quadratic invariants exactly (symplectic condition of section 1),
  ! so |x|^2 = 1 is kept up to the stage solution and roundoff. Per step: the new state
  ! x + h sum b_i F_i is rounded (<= 1 ulp per component after ~s + 1 additions of terms of
  ! size <= |x| = 1, ~(s + 1) eps), the simplified Newton iteration is exact for a linear
  ! field up to that same roundoff: |x|^2 moves by <= 2 (s + 1) eps per step at worst,
  ! and these errors add up at most linearly: 2 (s + 1) N eps after N steps.
  ! Long run: h = 1/2 to t = 1000 (2000 steps, omega h = 1/2).
  do s = 2, 4
    call start(ig, oscillator_t(), s, 0.5_wp)
    x = [1.0_wp, 0.0_wp]
    de = 0
    do k = 1, 100
      call propagate(ig, x, 10.0_wp*k, stat)
      if (stat /= TUBES_OK) exit
      de = max(de, abs(x(1)**2 + x(2)**2 - 1))
    end do
    write (lbl, '(a,i0)') 'oscillator to t = 1000: status, gauss', 2*s
    call check_eq(trim(lbl), stat, TUBES_OK)
    write (*, '(a,i0,a,es10.3,a,es10.3)') '     gauss', 2*s, &
      ' max | |x|^2 - 1 | over 2000 steps: ', de, ' = eps x ', de/EPS
    write (lbl, '(a,i0)') 'oscillator |x|^2 conserved to roundoff over 2000 steps, gauss', 2*s
    call check_close(trim(lbl), de, 0.0_wp, 2*(s + 1)*2000*EPS)
  end do

  ! === 5. energy over 1000 s on the ball: bounded (gauss4) versus drift (DOP853) ==========
  ! The energy error e(t) = (E(t) - E0)/E0 sampled every second. A symplectic method keeps
  ! e bounded (it conserves a modified energy within O(h^4)); DOP853 at a loose tolerance
  ! makes a systematic error each step, and e grows linearly. Two measures:
  !   ratio = max |e| over the last tenth / max |e| over the first tenth: ~1 for a bounded
  !           stationary oscillation, ~10 for a linear drift; the threshold sqrt(10) ~ 3.16
  !           (geometric midpoint) separates them;
  !   drift = |least-squares slope x T| / max |e|: ~1 for a linear drift (e = r t gives
  !           exactly 1), ~0 for a stationary oscillation; threshold 1/2.
  ! gauss4 with h = 1/32 s (exact in binary; 32000 steps, e ~ 1e-5) and DOP853 with
  ! rtol = atol = 1e-7 (~20000 steps).
  call start(ig, ball, 2, 1.0_wp/32)
  call energy_run(ig, emax(:, 1), drift(1), stat)
  call check_eq('ball 1000 s gauss4: status', stat, TUBES_OK)
  call dp%init(ball, t0=0.0_wp)
  dp%rtol = 1.0e-7_wp
  dp%atol = 1.0e-7_wp
  call energy_run(dp, emax(:, 2), drift(2), stat)
  call check_eq('ball 1000 s DOP853: status', stat, TUBES_OK)
  write (*, '(a,2es10.3,a,f7.3,a,f7.3)') '     gauss4 max|e| first/last tenth ', emax(:, 1), &
    '  ratio ', emax(2, 1)/emax(1, 1), '  drift ', drift(1)
  write (*, '(a,2es10.3,a,f7.3,a,f7.3)') '     DOP853 max|e| first/last tenth ', emax(:, 2), &
    '  ratio ', emax(2, 2)/emax(1, 2), '  drift ', drift(2)
  call check_true('ball 1000 s gauss4: energy error bounded (ratio < sqrt(10))', &
                  emax(2, 1) < sqrt(10.0_wp)*emax(1, 1))
  call check_true('ball 1000 s gauss4: no drift (|slope T| < max|e|/2)', drift(1) < 0.5_wp)
  call check_true('ball 1000 s DOP853 rtol 1e-7: energy error grows (ratio > sqrt(10))', &
                  emax(2, 2) > sqrt(10.0_wp)*emax(1, 2))
  call check_true('ball 1000 s DOP853 rtol 1e-7: drifts (|slope T| > max|e|/2)', drift(2) > 0.5_wp)

  ! === 6. time reversibility ==============================================================
  ! The method is symmetric: stepping back with -h undoes a step exactly when the stage
  ! equations are solved exactly. Forward to T and back to 0 with the same (binary-exact)
  ! step sizes returns to the start up to the per-step roundoff and iteration errors.
  ! Oscillator (the flow does not amplify errors): 2N steps of <= 2 (s + 1) eps each (as in
  ! section 4) on a state of size 1: tolerance 2 (s + 1) 2N eps.
  do s = 2, 4
    call start(ig, oscillator_t(), s, 0.25_wp)
    x = [1.0_wp, 0.0_wp]
    call propagate(ig, x, 100.0_wp, stat)
    m = int(ig%nsteps)
    call propagate(ig, x, 0.0_wp, stat)
    write (lbl, '(a,i0)') 'oscillator forward 100 and back: status, gauss', 2*s
    call check_eq(trim(lbl), stat, TUBES_OK)
    write (lbl, '(a,i0)') 'oscillator forward 100 and back: 400 + 400 steps, t = 0, gauss', 2*s
    call check_true(trim(lbl), m == 400 .and. ig%nsteps == 800 .and. ig%t == 0)
    write (*, '(a,i0,a,es10.3)') '     gauss', 2*s, ' oscillator |x(0 <- 100 <- 0) - x0| = ', &
      norm2(x - [1.0_wp, 0.0_wp])
    write (lbl, '(a,i0)') 'oscillator forward 100 and back to the start, gauss', 2*s
    call check_close(trim(lbl), norm2(x - [1.0_wp, 0.0_wp]), 0.0_wp, 2*(s + 1)*800*EPS)
  end do
  ! Rolling ball, T = 1 s, h = 1/32 s, gauss4, whose global error there (~2e-4 cm, section
  ! 3) is what a non-symmetric method of the same order would leave after the round trip.
  ! For the symmetric one: an error made at time t reaches the start
  ! multiplied by the backward flow map, |Phi(0, t)| = |Phi(t, 0)^-1| <= |Phi(t, 0)| in the
  ! 1-norm/inf-norm pair for a symplectic Phi (Phi^-1 = -Omega Phi^T Omega). Per step the
  ! error is <= newton_tol max|z| (the stopping rule) plus a few ulps of max|z| (~(s + 1)
  ! eps as above): 2N (10 + 3) eps max|z| max_t |Phi|, with max_t |Phi|_1 from DOP853 on
  ! the variational equations (rtol 1e-10: 3 digits are plenty for a tolerance).
  call make_variational(var, ball)
  call dp%init(var, t0=0.0_wp)
  dp%rtol = 1.0e-10_wp
  dp%atol = 1.0e-10_wp
  zv = stm_start(X0_BALL)
  amp = 1
  xmax = maxval(abs(X0_BALL))
  do k = 1, 64
    call propagate(dp, zv, k/64.0_wp, stat)
    phi = reshape(zv(5:20), [4, 4])
    amp = max(amp, maxval(sum(abs(phi), 1)), maxval(sum(abs(phi), 2)))
    xmax = max(xmax, maxval(abs(zv(1:4))))
  end do
  call start(ig, ball, 2, 1.0_wp/32)
  z = X0_BALL
  call propagate(ig, z, 1.0_wp, stat)
  call propagate(ig, z, 0.0_wp, stat)
  call check_eq('ball forward 1 s and back: status', stat, TUBES_OK)
  tol = 2*32*(10 + 3)*EPS*xmax*amp
  write (*, '(a,es10.3,a,f7.2,a,es10.3)') '     ball |z(0 <- 1 <- 0) - z0|_inf = ', &
    maxval(abs(z - X0_BALL)), ', max |Phi| = ', amp, ', tolerance ', tol
  call check_close('ball forward 1 s and back to the start (gauss4)', maxval(abs(z - X0_BALL)), &
                   0.0_wp, tol)

  ! === 7. fixed point versus Newton ========================================================
  ! Both iterations stop with an increment <= newton_tol max|x| and then differ from the
  ! exact stage solution by less than that (contraction < 1/2 at these steps), so each step
  ! differs by <= 2 newton_tol max|x| + roundoff ((s + 1) eps each, section 4): over N
  ! steps (no amplification on the oscillator) <= N (2 x 10 + 2 (s + 1)) eps.
  do s = 2, 4
    do i = 1, 2
      call start(ig, oscillator_t(), s, 0.5_wp)
      if (i == 2) ig%solver = 'fixed_point'
      x = [1.0_wp, 0.0_wp]
      call propagate(ig, x, 10.0_wp, stat)
      write (lbl, '(a,a,a,i0)') 'oscillator ', trim(ig%solver), ': status, gauss', 2*s
      call check_eq(trim(lbl), stat, TUBES_OK)
      if (i == 1) xf = x
      nit(i) = int(ig%niter)
    end do
    write (*, '(a,i0,a,es10.3,a,2i6)') '     gauss', 2*s, ' oscillator |fixed point - Newton| = ', &
      norm2(x - xf), ', iterations (Newton, fixed point) ', nit
    write (lbl, '(a,i0)') 'oscillator: fixed point = Newton to the iteration tolerance, gauss', 2*s
    call check_close(trim(lbl), norm2(x - xf), 0.0_wp, 20*(2*10 + 2*(s + 1))*EPS)
  end do
  ! the same on the ball (64 steps of 1/64 s, gauss6), with the amplification max|Phi| and
  ! the scale max|z| of section 6
  do i = 1, 2
    call start(ig, ball, 3, 1.0_wp/64)
    if (i == 2) ig%solver = 'fixed_point'
    z = X0_BALL
    call propagate(ig, z, 1.0_wp, stat)
    if (i == 1) zs(:, 1, 1) = z(1:2)
    nit(i) = int(ig%niter)
    write (lbl, '(a,a)') 'ball gauss6 ', trim(ig%solver)
    call check_eq(trim(lbl), stat, TUBES_OK)
  end do
  tol = 64*(2*10 + 2*4)*EPS*xmax*amp
  write (*, '(a,es10.3,a,2i6,a,es10.3)') '     ball |fixed point - Newton| = ', &
    maxval(abs(z(1:2) - zs(:, 1, 1))), ', iterations (Newton, fixed point) ', nit, &
    ', tolerance ', tol
  call check_close('ball: fixed point = Newton to the iteration tolerance', &
                   maxval(abs(z(1:2) - zs(:, 1, 1))), 0.0_wp, tol)
  ! Fixed-point iteration Z <- h (A (x) J) Z converges only if the spectral radius h rho(A)
  ! |omega| < 1; for gauss4 the eigenvalues of A are 1/4 -+ i/(4 sqrt 3), rho(A) =
  ! 1/sqrt(12), so on the oscillator (omega = 1) the limit is h = sqrt(12) = 3.46.
  ! At h = 5 it diverges: TUBES_ENOCONV, and t, x and the dense output stay at the last
  ! accepted step. Newton (exact for a linear field) takes the same step.
  call start(ig, oscillator_t(), 2, 2.0_wp)
  ig%solver = 'fixed_point'
  x = [1.0_wp, 0.0_wp]
  call propagate(ig, x, 4.0_wp, stat)
  call check_eq('fixed point h = 2 (h rho(A) = 0.58): converges', stat, TUBES_OK)
  call ig%interp(3.0_wp, xb)
  xf = x
  ig%h = 5.0_wp
  call propagate(ig, x, 20.0_wp, stat)
  call check_eq('fixed point h = 5 (h rho(A) = 1.44): TUBES_ENOCONV', stat, TUBES_ENOCONV)
  call check_true('fixed point failure: t and x stay at the last accepted step', &
                  ig%t == 4 .and. all(x == xf))
  call ig%interp(3.0_wp, xf)
  call check_true('fixed point failure: dense output still that of the last step', all(xf == xb))
  ! Newton takes the step: on x' = v, v' = -x, w = x + i v obeys w' = -i w, and gauss4 maps
  ! w to R(-i h) w with R(z) = (1 + z/2 + z^2/12)/(1 - z/2 + z^2/12), the (2,2) Pade
  ! approximant of exp. Tolerance: the Newton matrix is exact for a linear field, so the
  ! stages are exact up to roundoff once an increment is <= newton_tol |x| = 10 eps; x_new
  ! uses F at the iterate before that increment: h |J| 10 eps = 50 eps; the final sum
  ! x + h sum b_i F_i of terms up to h |F| = 5 rounds to ~(s + 1)(1 + h) eps = 18 eps.
  ig%solver = 'newton'
  wz = cmplx(x(1), x(2), wp)
  call propagate(ig, x, 9.0_wp, stat)
  call check_eq('Newton h = 5 on the same state: TUBES_OK', stat, TUBES_OK)
  zc = cmplx(0.0_wp, -5.0_wp, wp)
  wz = wz*(1 + zc/2 + zc**2/12)/(1 - zc/2 + zc**2/12)
  write (*, '(a,es10.3)') '     Newton h = 5: |x - R(-5i) x| = ', abs(cmplx(x(1), x(2), wp) - wz)
  call check_close('Newton h = 5: x = Pade R(-5i) x(4)', abs(cmplx(x(1), x(2), wp) - wz), 0.0_wp, &
                   (50 + 18)*EPS)

  ! The same limit on the ball's first step from rest: there J = [[0, V], [-g K, 0]] (p = 0),
  ! so J^2 = diag(V (-g K), ...) and rho(J) = sqrt(rho(V (-g K))) (2x2 eigenvalues in closed
  ! form; V = jac(1:2, 3:4), -g K = jac(3:4, 1:2)). Fixed point from a zero guess: converges
  ! for h rho(A) rho(J) < 1, diverges (TUBES_ENOCONV, not a NaN from the model) above.
  call ball%jacobian(0.0_wp, X0_BALL, phi, stat)
  pm = matmul(phi(1:2, 3:4), phi(3:4, 1:2))
  p0 = (pm(1, 1) + pm(2, 2))/2                       ! half trace
  p1 = pm(1, 1)*pm(2, 2) - pm(1, 2)*pm(2, 1)         ! determinant
  rhoj = sqrt(max(abs(p0 + sqrt(max(p0**2 - p1, 0.0_wp))), abs(p0 - sqrt(max(p0**2 - p1, 0.0_wp)))))
  write (*, '(a,f8.4,a,f7.4,a)') '     ball at rest: rho(J) = ', rhoj, &
    ' 1/s, fixed-point limit h = ', sqrt(12.0_wp)/rhoj, ' s (gauss4)'
  do i = 1, 2
    call start(ig, ball, 2, 0.2_wp + (i - 1)*0.3_wp)
    ig%solver = 'fixed_point'
    z = X0_BALL
    call ig%step(z, 10.0_wp, stat)
    write (lbl, '(a,f4.2,a,f5.3)') 'ball fixed point, first step h = ', ig%h, &
      ': h rho(A) rho(J) = ', ig%h*rhoj/sqrt(12.0_wp)
    if (i == 1) then
      call check_eq(trim(lbl)//', converges', stat, TUBES_OK)
    else
      call check_eq(trim(lbl)//', TUBES_ENOCONV', stat, TUBES_ENOCONV)
      call check_true('ball fixed point failure: t and x untouched', &
                      ig%t == 0 .and. all(z == X0_BALL))
    end if
  end do

  ! === 8. dense output =====================================================================
  ! interp is the collocation polynomial (degree s) through x_old and the stage values: its
  ! local error inside a step is O(h^(s+1)) (not the 2s of the step end). Sampled against the
  ! exact flow from the step's start at theta = j/16, j = 1..15, over t in [0, 10] for h and
  ! h/2: measured order s + 1 (window -+ 0.5: higher terms at omega h <= 1/2).
  ! The end of one step's polynomial is the next step's start: u(1) = x_old + h sum_j F_j
  ! q_j(1) with q_j(1) = b_j up to the ~7 ulps of the Vandermonde solve for q (section 1),
  ! times h |F| <= 1: <= 16 eps.
  allocate (probe(2))
  do s = 2, 4
    do i = 1, 2
      probe(i) = dense_probe_t(nsamp=15)
      call start(ig, oscillator_t(), s, 0.5_wp/2**(i - 1))
      x = [1.0_wp, 0.0_wp]
      call propagate(ig, x, 10.0_wp, stat, observer=probe(i))
      err(i) = probe(i)%err_local
    end do
    order = log(err(1)/err(2))/log(2.0_wp)
    write (*, '(a,i0,a,2es10.3,a,f6.3,a,es10.3)') '     gauss', 2*s, &
      ' dense output local error h = 1/2, 1/4: ', err(1:2), '  order ', order, &
      '  joins ', max(probe(1)%err_join, probe(2)%err_join)
    write (lbl, '(a,i0,a,i0)') 'dense output local order of gauss', 2*s, ' = s + 1 = ', s + 1
    call check_close(trim(lbl), order, s + 1.0_wp, 0.5_wp)
    write (lbl, '(a,i0)') 'dense output continuous across steps, gauss', 2*s
    call check_close(trim(lbl), max(probe(1)%err_join, probe(2)%err_join), 0.0_wp, 16*EPS)
  end do
  ! an event located on the dense output: x = 0 falling at pi/2, gauss8 with h = 1/4. The
  ! state error at the event is the interpolation error, at most err_local of gauss8 at
  ! h = 1/4 (printed above; sampled at 15 points per step), plus the global error at the
  ! step start (< 1e-13, section 2), over |dx/dt| = 1: bound err_local
  call start(ig, oscillator_t(), 4, 0.25_wp)
  x = [1.0_wp, 0.0_wp]
  call propagate(ig, x, 10.0_wp, stat, event=plane_t(k=1, c=0.0_wp, direction=-1))
  call check_eq('event x = 0 (gauss8): status TUBES_EVENT', stat, TUBES_EVENT)
  call check_close('event x = 0 (gauss8): t = pi/2', ig%t, PI/2, err(2))

  ! === 9. extrapolated starting guess ======================================================
  ! Iterations with the guess from the previous step's collocation polynomial versus zero
  ! stage increments, ball from rest to t = 10 s, h = 1/64 s, Newton. Counters: Newton
  ! evaluates f at the s stages once per iteration and the Jacobian once per step, so
  ! nfev = s niter and njac = nsteps exactly.
  do s = 2, 4
    do i = 1, 2
      call start(ig, ball, s, 1.0_wp/64)
      ig%extrapolate = i == 1
      z = X0_BALL
      call propagate(ig, z, 10.0_wp, stat)
      nit(i) = int(ig%niter)
      if (i == 1) then
        write (lbl, '(a,i0)') 'ball to 10 s: nfev = s niter, njac = nsteps = 640, gauss', 2*s
        call check_true(trim(lbl), stat == TUBES_OK .and. ig%nfev == s*ig%niter .and. &
                        ig%njac == ig%nsteps .and. ig%nsteps == 640)
      end if
    end do
    write (*, '(a,i0,a,f6.3,a,f6.3)') '     gauss', 2*s, ' iterations per step: extrapolated ', &
      nit(1)/640.0_wp, ', zero guess ', nit(2)/640.0_wp
    write (lbl, '(a,i0)') 'extrapolated guess saves iterations, gauss', 2*s
    call check_true(trim(lbl), nit(1) < nit(2))
  end do
  ! fixed point: no Jacobian
  call start(ig, ball, 2, 1.0_wp/64)
  ig%solver = 'fixed_point'
  z = X0_BALL
  call propagate(ig, z, 1.0_wp, stat)
  call check_true('fixed point: njac = 0, nfev = s niter', stat == TUBES_OK .and. ig%njac == 0 &
                  .and. ig%nfev == 2*ig%niter)

  ! === 10. backward integration, remainder step ============================================
  ! x(-3) = (cos 3, sin 3) with h = 1/4 (12 steps); error: the phase error of section 2,
  ! t C h^8 = 3 x 3.94e-8 x 4^-8 = 1.8e-12; tolerance twice that
  call start(ig, oscillator_t(), 4, 0.25_wp)
  x = [1.0_wp, 0.0_wp]
  call propagate(ig, x, -3.0_wp, stat)
  call check_eq('backward: status', stat, TUBES_OK)
  call check_true('backward: lands on t = -3 in 12 steps', ig%t == -3.0_wp .and. ig%nsteps == 12)
  call check_close('backward: x(-3) = (cos 3, sin 3)', norm2(x - [cos(3.0_wp), sin(3.0_wp)]), &
                   0.0_wp, 3.6e-12_wp)
  ! the oscillator is time-reversal symmetric ((x, v, t) -> (x, -v, -t)): the forward run
  ! mirrors the backward one up to the order of floating-point operations (4 ulps)
  xb = x
  call start(ig, oscillator_t(), 4, 0.25_wp)
  x = [1.0_wp, 0.0_wp]
  call propagate(ig, x, 3.0_wp, stat)
  call check_close('backward mirrors forward: x', xb(1), x(1), 4*EPS)
  call check_close('backward mirrors forward: v', xb(2), -x(2), 4*EPS)
  ! h = 0.3 to t = 10: 33 steps and a shortened last one landing exactly on 10; h = 0.1
  ! (inexact in binary) to t = 1000 in one call: exactly 10000 steps, no sliver step from
  ! the drift of t
  call start(ig, oscillator_t(), 2, 0.3_wp)
  x = [1.0_wp, 0.0_wp]
  call propagate(ig, x, 10.0_wp, stat)
  call check_true('h = 0.3 to t = 10: 34 steps, lands on 10', stat == TUBES_OK .and. &
                  ig%nsteps == 34 .and. ig%t == 10)
  call start(ig, oscillator_t(), 2, 0.1_wp)
  x = [1.0_wp, 0.0_wp]
  call propagate(ig, x, 1000.0_wp, stat)
  call check_true('h = 0.1 to t = 1000: 10000 steps, lands on 1000', stat == TUBES_OK .and. &
                  ig%nsteps == 10000 .and. ig%t == 1000)

  ! === 11. failure statuses, settings ======================================================
  ! changing the stage count mid-run: gauss4 to t = 5, gauss8 to t = 10 (h = 1/4); error
  ! bound: the phase errors of section 2, 5 h^4/720 + 5 x 3.94e-8 h^8, +10%
  call start(ig, oscillator_t(), 2, 0.25_wp)
  x = [1.0_wp, 0.0_wp]
  call propagate(ig, x, 5.0_wp, stat)
  ig%stages = 4
  call propagate(ig, x, 10.0_wp, stat)
  call check_true('stages 2 -> 4 mid-run: status, lands on t = 10', &
                  stat == TUBES_OK .and. ig%t == 10)
  call check_close('stages 2 -> 4 mid-run: x(10)', norm2(x - rotate([1.0_wp, 0.0_wp], 10.0_wp)), &
                   0.0_wp, 1.1_wp*5*(0.25_wp**4/720 + 3.94e-8_wp*0.25_wp**8))
  call start(ig, oscillator_t(), 2, 0.25_wp)
  call ig%interp(0.1_wp, x)
  call check_true('interp before the first step: NaN', all(ieee_is_nan(x)))
  call start(ig, oscillator_t(), 2, 0.0_wp)
  x = [1.0_wp, 0.0_wp]
  call ig%step(x, 1.0_wp, stat)
  call check_eq('h = 0: TUBES_EINPUT', stat, TUBES_EINPUT)
  ig%h = 0.1_wp
  ig%stages = 5
  call ig%step(x, 1.0_wp, stat)
  call check_eq('stages = 5: TUBES_EINPUT', stat, TUBES_EINPUT)
  ig%stages = 2
  ig%solver = 'broyden'
  call ig%step(x, 1.0_wp, stat)
  call check_eq('solver = broyden: TUBES_EINPUT', stat, TUBES_EINPUT)
  ig%solver = 'newton'
  call ig%step(x, 0.0_wp, stat)
  call check_eq('tmax = t: TUBES_EINPUT', stat, TUBES_EINPUT)
  call check_true('bad input: t, x untouched', ig%t == 0 .and. all(x == [1.0_wp, 0.0_wp]) &
                  .and. ig%nsteps == 0)
  ! the model returns NaN with stat < 0 once x < 1/2 (t > pi/3): with h = 0.1 the step from
  ! t = 1 has stages at 1.02, 1.08 s, the second past pi/3 = 1.047: TUBES_EMODEL, t and x
  ! left at t = 1 (10 steps; t summed with compensation: within 2 ulps), x = cos 1 within
  ! the global error t h^4/720 = 1.39e-7 (section 2) + 10% for the O(h^2) terms
  call start(ig, nan_oscillator_t(), 2, 0.1_wp)
  x = [1.0_wp, 0.0_wp]
  call propagate(ig, x, 10.0_wp, stat)
  call check_eq('NaN model: TUBES_EMODEL', stat, TUBES_EMODEL)
  call check_true('NaN model: 10 accepted steps', ig%nsteps == 10)
  call check_close('NaN model: t left at 1', ig%t, 1.0_wp, 2*EPS)
  call check_close('NaN model: x = cos(1) at the last accepted step', x(1), cos(1.0_wp), &
                   1.1_wp*0.1_wp**4/720)
  ! Newton with max_iter = 1 cannot confirm convergence (the first increment is the whole
  ! correction): TUBES_ENOCONV rather than an unchecked step
  call start(ig, ball, 2, 1.0_wp/64)
  ig%max_iter = 1
  z = X0_BALL
  call propagate(ig, z, 1.0_wp, stat)
  call check_eq('ball max_iter = 1: TUBES_ENOCONV', stat, TUBES_ENOCONV)
  call check_true('ball max_iter = 1: state untouched', ig%t == 0 .and. all(z == X0_BALL))

  call finish('test_gauss')

contains

  !> Fresh integrator with default settings (intent(out) resets every component): s stages,
  !> step h, from t = 0.
  subroutine start(g, f, s, h)
    type(gauss_t), intent(out) :: g
    class(vector_field_t), intent(in) :: f
    integer, intent(in) :: s
    real(wp), intent(in) :: h
    call g%init(f, t0=0.0_wp)
    g%stages = s
    g%h = h
  end subroutine start

  !> Integrate the ball from rest for 1000 s sampling the relative energy error every
  !> second: max |e| over the first and last 100 s, and |least-squares slope x 1000| / max|e|.
  subroutine energy_run(g, em, dr, stat)
    class(integrator_t), intent(inout) :: g
    real(wp), intent(out) :: em(2), dr
    integer, intent(out) :: stat
    integer, parameter :: N = 1000
    real(wp) :: zz(4), e, sx, sy, sxx, sxy, emx
    integer :: kk
    zz = X0_BALL
    em = 0
    emx = 0
    sx = 0; sy = 0; sxx = 0; sxy = 0
    do kk = 1, N
      call propagate(g, zz, real(kk, wp), stat)
      if (stat /= TUBES_OK) return
      e = (ball%energy(zz) - ball%energy(X0_BALL))/ball%energy(X0_BALL)
      if (kk <= N/10) em(1) = max(em(1), abs(e))
      if (kk > N - N/10) em(2) = max(em(2), abs(e))
      emx = max(emx, abs(e))
      sx = sx + kk
      sy = sy + e
      sxx = sxx + real(kk, wp)**2
      sxy = sxy + kk*e
    end do
    dr = abs((N*sxy - sx*sy)/(N*sxx - sx*sx))*N/emx
  end subroutine energy_run

end program test_gauss
