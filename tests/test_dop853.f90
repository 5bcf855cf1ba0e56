!> DOP853: tableau order conditions, convergence order with fixed steps (oscillator and
!> rolling ball), dense output, adaptive mode (energy and tolerance proportionality), an
!> event, backward integration and failure statuses.
program test_dop853
  use tubes_kinds, only: wp
  use tubes_status, only: TUBES_OK, TUBES_EVENT, TUBES_EMODEL, TUBES_EMAXSTEPS
  use tubes_dop853_tableau, only: NS, NSX, C, tableau_a, tableau_e3, tableau_e5, tableau_d
  use tubes_dop853, only: dop853_t
  use tubes_integrator, only: propagate, plane_t
  use tubes_fourwell, only: fourwell_t
  use tubes_ball, only: ball_t, make_ball
  use tubes_check, only: check_close, check_rel, check_true, check_eq, finish
  use tubes_test_models, only: X0_BALL, PI, EPS, oscillator_t, nan_oscillator_t, dense_probe_t, rotate, oscillator_fixed_step, &
                               ball_fixed_step, oscillator_start
  implicit none


  type(dop853_t) :: ig
  type(ball_t) :: ball
  type(dense_probe_t) :: probe(2)
  integer, parameter :: MAXTREE = 200   ! rooted trees with up to 8 vertices
  real(wp) :: a(NSX, NSX), e3(NSX), e5(NSX), b(NSX), d(4, NSX), w7(NSX, 7), bth(NSX)
  real(wp) :: bth_abs(NSX), th, worst, tol, s
  real(wp) :: phi(NSX, MAXTREE), phi_abs(NSX, MAXTREE), tgam(MAXTREE)
  integer :: tord(MAXTREE), ntree, nbad
  real(wp) :: x(2), xf(2), err(3), order, h, z(4), zs(4, 8, 3), e0, erel(2), tl(2), dif(2)
  integer :: i, k, stat, nsteps_fwd
  character(80) :: lbl

  ! === 1. tableau ==========================================================================
  ! Roundoff model for every identity below: a coefficient is the 30-digit value rounded
  ! (1/2 ulp), and a sum of n products computed in floating point is off by at most
  ! ~n eps (sum of |terms|) (Higham's gamma_n). Each tolerance is that bound with the
  ! worst-case n of the computation, against the same expression evaluated in |.|.
  a = tableau_a()
  e3 = 0
  e5 = 0
  e3(1:NS + 1) = tableau_e3()
  e5(1:NS + 1) = tableau_e5()
  d = tableau_d()
  call check_true('tableau: a strictly lower triangular', &
                  all([(all(a(i, i:NSX) == 0), i = 1, NSX)]))
  do i = 1, NSX
    write (lbl, '(a,i0)') 'tableau: row sum of a = c, stage ', i
    call check_close(trim(lbl), sum(a(i, 1:i - 1)), C(i), NSX*EPS*(sum(abs(a(i, :))) + C(i)))
  end do
  ! Simplifying assumption C(2) used by the construction: sum_j a_ij c_j = c_i^2/2, i >= 3
  do i = 3, NSX
    write (lbl, '(a,i0)') 'tableau: sum_j a_ij c_j = c_i^2/2, stage ', i
    call check_close(trim(lbl), dot_product(a(i, :), C), C(i)**2/2, &
                     NSX*EPS*(sum(abs(a(i, :)*C)) + C(i)**2))
  end do
  b = 0
  b(1:NS) = a(NS + 1, 1:NS)   ! the 8th-order weights are the FSAL row
  ! quadrature conditions sum b c^(k-1) = 1/k for k <= 8 (bushy trees); (NS + k) covers
  ! the k-1 products of the power and the NS-term sum
  do k = 1, 8
    write (lbl, '(a,i0)') 'tableau: sum b c^(k-1) = 1/k, k = ', k
    call check_close(trim(lbl), sum(b*C**(k - 1)), 1.0_wp/k, &
                     (NS + k)*EPS*sum(abs(b*C**(k - 1))))
  end do
  ! ... and the order is exactly 8: the k = 9 condition fails by far more than roundoff
  ! (the violation is 2.7e-5; 1e-8 is a floor well above the 1e-14 roundoff)
  call check_true('tableau: k = 9 quadrature condition violated (order exactly 8)', &
                  abs(sum(b*C**8) - 1.0_wp/9) > 1.0e-8_wp)
  ! error weights: consistency (sum 0)
  call check_close('tableau: sum e3 = 0', sum(e3), 0.0_wp, NSX*EPS*sum(abs(e3)))
  call check_close('tableau: sum e5 = 0', sum(e5), 0.0_wp, NSX*EPS*sum(abs(e5)))

  ! All Butcher order conditions b . Phi(t) = 1/gamma(t) for the 200 rooted trees t with
  ! |t| <= 8 (the quadrature conditions above are the bushy trees; the nonlinear ones
  ! are what the oscillator of section 2 cannot see). Phi(t) for t = [t1, ..., tm] is the
  ! stage vector prod_k (A Phi(t_k)) (elementwise), gamma(t) = |t| prod_k gamma(t_k).
  ! Roundoff: |t| levels of NSX-term products: tolerance (|t| + 1) NSX eps |b| . Phi_abs(t)
  ! with Phi_abs built from |A|.
  call build_trees()
  call check_true('trees: 1, 1, 2, 4, 9, 20, 48, 115 rooted trees of orders 1..8', &
                  all([(count(tord(1:ntree) == k), k = 1, 8)] == [1, 1, 2, 4, 9, 20, 48, 115]))
  nbad = 0
  worst = 0
  do i = 1, ntree
    tol = (tord(i) + 1)*NSX*EPS*dot_product(abs(b), phi_abs(:, i))
    worst = max(worst, abs(dot_product(b, phi(:, i)) - 1/tgam(i))/tol)
    if (.not. abs(dot_product(b, phi(:, i)) - 1/tgam(i)) <= tol) nbad = nbad + 1
  end do
  write (*, '(a,es9.2)') '     worst |b . Phi - 1/gamma| / tolerance over 200 trees: ', worst
  call check_eq('tableau: all 200 order conditions of order <= 8 hold (b)', nbad, 0)
  ! embedded weights: bhat = b - e is a 5th-order (e5) and a 3rd-order (e3) method on the
  ! 13 stages (the 13th is the FSAL stage), so e . Phi(t) = 0 for |t| <= 5 resp. 3, and
  ! the e5 method is exactly of order 5 (an order-6 condition fails by >> roundoff)
  nbad = 0
  do i = 1, ntree
    if (tord(i) <= 5) then
      if (.not. abs(dot_product(e5, phi(:, i))) <= &
          (tord(i) + 1)*NSX*EPS*dot_product(abs(e5), phi_abs(:, i))) nbad = nbad + 1
    end if
    if (tord(i) <= 3) then
      if (.not. abs(dot_product(e3, phi(:, i))) <= &
          (tord(i) + 1)*NSX*EPS*dot_product(abs(e3), phi_abs(:, i))) nbad = nbad + 1
    end if
  end do
  call check_eq('tableau: e5 . Phi(t) = 0 for |t| <= 5, e3 . Phi(t) = 0 for |t| <= 3', nbad, 0)
  call check_true('tableau: e5 violates an order-6 condition (> 1e-8; it is 4.5e-4)', &
                  maxval(abs(matmul(e5, phi(:, 1:ntree))), mask=tord(1:ntree) == 6) > 1.0e-8_wp)
  ! Dense output: interp uses x_old + theta (D1 + th1 (D2 + theta (D3 + th1 (D4 + ...))))
  ! with D1 = h b.k, D2 = h k1 - D1, D3 = 2 D1 - h (k13 + k1), D(3+j) = h d(j,:).k, so its
  ! weights b(theta) must satisfy b(theta) . Phi(t) = theta^|t|/gamma(t) for |t| <= 7
  ! (order 7) at every theta, and fail at order 8.
  w7(:, 1) = b
  w7(:, 2) = -b
  w7(1, 2) = w7(1, 2) + 1
  w7(:, 3) = 2*b
  w7(1, 3) = w7(1, 3) - 1
  w7(NS + 1, 3) = w7(NS + 1, 3) - 1
  do k = 1, 4
    w7(:, 3 + k) = d(k, :)
  end do
  nbad = 0
  worst = 0
  do k = 1, 9
    th = k/10.0_wp
    bth = dense_weights(w7, th)
    bth_abs = dense_weights(abs(w7), th)
    do i = 1, ntree
      ! 8 Horner levels on top of the tree levels
      tol = (tord(i) + 9)*NSX*EPS*dot_product(bth_abs, phi_abs(:, i))
      if (tord(i) <= 7) then
        if (.not. abs(dot_product(bth, phi(:, i)) - th**tord(i)/tgam(i)) <= tol) nbad = nbad + 1
      else
        worst = max(worst, abs(dot_product(bth, phi(:, i)) - th**tord(i)/tgam(i)))
      end if
    end do
  end do
  call check_eq('tableau: dense output order conditions |t| <= 7 at theta = 0.1..0.9', nbad, 0)
  call check_true('tableau: dense output is exactly order 7 (order-8 defect > 1e-8)', &
                  worst > 1.0e-8_wp)

  ! === 2. fixed-step convergence on the oscillator ========================================
  ! Global error of an order-8 method: C t h^8 (1 + O(h)). With t = 10 the error is 1.6e-12
  ! at h = 0.2 and at the roundoff floor (~1e-14, ~100 steps of a few ulps) from h = 0.1
  ! on, so h = 0.2, 0.1, 0.05 would measure roundoff. h = 1.25, 0.625, 0.3125 s are exact
  ! in binary and divide 10 (8, 16, 32 equal steps, no remainder step), and every error
  ! stays >= 1000x above the floor (roundoff then moves the measured order by < 0.01).
  ! The O(h) terms shift the measured order by ~log2((1 + c h)/(1 + c h/2)); the window
  ! [7.5, 8.5] allows for that at omega h ~ 1.
  do i = 1, 3
    h = 1.25_wp/2**(i - 1)
    call oscillator_fixed_step(ig, h, 'fixed step oscillator', 'f6.4', err(i))
    write (*, '(a,f6.4,a,es10.3)') '     h = ', h, '  error at t = 10: ', err(i)
  end do
  do i = 1, 2
    order = log(err(i)/err(i + 1))/log(2.0_wp)
    write (lbl, '(a,f6.4,a,f6.4)') 'oscillator order from h = ', 1.25_wp/2**(i - 1), &
      ' and ', 0.625_wp/2**(i - 1)
    call check_close(trim(lbl), order, 8.0_wp, 0.5_wp)    ! window [7.5, 8.5], see above
  end do

  ! === 3. dense output =====================================================================
  ! The interpolant has order 7: local error O(h^8) per step, which does not accumulate.
  ! Sampled against the exact flow from the step's start (local) it shows h^8; against the
  ! exact solution (global) it adds the O(h^8) global error of the steps. Measured order
  ! from h = 0.625 and 0.3125 (as in 2; errors >= 5e-11, far above roundoff): expect ~8;
  ! >= 6.5 still rejects a 6th-order interpolant.
  do i = 1, 2
    h = 0.625_wp/2**(i - 1)
    call oscillator_start(ig, x, h)
    call propagate(ig, x, 10.0_wp, stat, observer=probe(i))
    write (lbl, '(a,f6.4)') 'dense output run: status, h = ', h
    call check_eq(trim(lbl), stat, TUBES_OK)
    write (*, '(a,f6.4,a,es10.3,a,es10.3)') '     h = ', h, '  dense error global ', &
      probe(i)%err_global, '  local ', probe(i)%err_local
    ! at theta = 0 the interpolant is x_old exactly; at theta = 1 it is x_old + (x_new -
    ! x_old): two roundings of ulps of |x| = 1, plus theta = (t - t_old)/h itself, off 1 by
    ! up to ulp(t)/h with t <= 10, times |dx/dtheta| = h |f| = h: 10 eps. Total <= 14 eps.
    write (lbl, '(a,f6.4)') 'dense output reproduces the step ends, h = ', h
    call check_close(trim(lbl), probe(i)%err_ends, 0.0_wp, 14*EPS)
  end do
  call check_true('observer called on every step', probe(1)%nsteps == 16)  ! 10/0.625
  order = log(probe(1)%err_global/probe(2)%err_global)/log(2.0_wp)
  write (*, '(a,f6.2)') '     dense output order (global) ', order
  call check_true('dense output order (global) >= 6.5', order >= 6.5_wp)
  order = log(probe(1)%err_local/probe(2)%err_local)/log(2.0_wp)
  write (*, '(a,f6.2)') '     dense output order (local)  ', order
  call check_true('dense output order (local) >= 6.5', order >= 6.5_wp)

  ! === 4. order on the rolling ball by Richardson ==========================================
  ! From rest at (4, 12.614863819914357) cm (1500 (cm/s)^2 above the saddles) to t = 2 s.
  ! Without an exact solution: z_h - z_{h/2} = C h^8 (1 - 2^-8) + O(h^9), so successive
  ! differences shrink by 2^p. Choice of h: the motion's time scale is sqrt(gamma)/v_max
  ! ~ 3.9 cm / 83 cm/s ~ 0.05 s (the ridge term has complex singularities sqrt(gamma) away),
  ! so h must stay below it for h^8 to dominate; and DOP853's errors are so small that the
  ! h/2-vs-h/4 difference must stay >= ~100x above the roundoff floor of ~3e-13 cm (the
  ! difference between h/4 and h/8 runs at h = 1/40 s). h = 1/32 s (exact in binary, so
  ! the runs land on the sample times without remainder steps) meets both: the second
  ! difference is ~3e-11 cm. A step of ~2e-3 s would compare roundoff (~1e-13).
  ! The remaining h^9 terms are not negligible at h/0.05 s ~ 0.6: window [7, 9]. (Scanning
  ! h from 1/64 to 1/24 s, the RMS measure gives 8.0 to 9.2; from ~0.045 s up the run is
  ! pre-asymptotic and it wanders up to ~10.5.)
  ! Two measures: |x_h - x_{h/2}| at t = 2 s, and the RMS of the position
  ! differences at t = 0.25, 0.5, ..., 2 s (robust against a zero of one component's error
  ! coefficient at one time, which makes a single-component ratio meaningless: y at
  ! t = 2 s gives 11.8 at h = 1/40 s for that reason).
  call make_ball(ball, fourwell_t(), 981.0_wp)
  do i = 1, 3
    call ball_fixed_step(ig, (1.0_wp/32)/2**(i - 1), 0.25_wp*[(k, k=1, 8)], 'ball fixed step', 'es8.2', &
                         zs(:, :, i))
  end do
  dif(1) = abs(zs(1, 8, 1) - zs(1, 8, 2))
  dif(2) = abs(zs(1, 8, 2) - zs(1, 8, 3))
  write (*, '(a,2es10.3)') '     |x_h - x_h/2|, |x_h/2 - x_h/4| at t = 2 s [cm]: ', dif
  order = log(dif(1)/dif(2))/log(2.0_wp)
  call check_close('ball Richardson order (x at t = 2 s)', order, 8.0_wp, 1.0_wp)  ! [7, 9]
  dif(1) = sqrt(sum((zs(1:2, :, 1) - zs(1:2, :, 2))**2)/16)
  dif(2) = sqrt(sum((zs(1:2, :, 2) - zs(1:2, :, 3))**2)/16)
  write (*, '(a,2es10.3)') '     RMS position differences over 8 times [cm]: ', dif
  order = log(dif(1)/dif(2))/log(2.0_wp)
  call check_close('ball Richardson order (RMS over t = 0.25..2 s)', order, 8.0_wp, 1.0_wp)

  ! === 5. adaptive mode on the ball =======================================================
  ! Each accepted step keeps the RMS over the 4 components of (local error estimate)/
  ! (atol + rtol |z_i|) below 1, so |dz_i| <= 2 tol (1 + |z_i|) per step (sqrt(4) = 2).
  ! The energy moves by sum |dE/dz_i| |dz_i|, and sum |dE/dz_i| (1 + |z_i|) <~ 4 E here
  ! (2T from the momenta, |q . g grad H| ~ E from the positions, plus the 1s): at most
  ! 8 tol E per step. Energy errors of a non-symplectic method drift rather than average
  ! out, so the bound is linear in the step count: |dE|/E <= 8 N tol (~6.5e-9 for the
  ! ~810 steps at tol = 1e-12). The estimate is of a lower-order embedded solution, so the
  ! true error of the 8th-order result is far below it: the run gives ~1e-12.
  tl = [1.0e-8_wp, 1.0e-12_wp]
  do i = 1, 2
    call ig%init(ball, t0=0.0_wp)
    ig%h = 0
    ig%rtol = tl(i)
    ig%atol = tl(i)
    z = X0_BALL
    e0 = ball%energy(z)
    call propagate(ig, z, 10.0_wp, stat)
    write (lbl, '(a,es7.1)') 'adaptive ball: status, tol = ', tl(i)
    call check_eq(trim(lbl), stat, TUBES_OK)
    write (lbl, '(a,es7.1)') 'adaptive ball: lands on t = 10 s, tol = ', tl(i)
    call check_true(trim(lbl), ig%t == 10.0_wp)
    erel(i) = abs(ball%energy(z) - e0)/e0
    write (*, '(a,es7.1,a,es10.3,a,i0,a,i0)') '     tol ', tl(i), ': |E(10) - E0|/E0 = ', &
      erel(i), ', steps ', ig%nsteps, ', rejected ', ig%nrejected
    write (lbl, '(a,es7.1)') 'adaptive ball: relative energy error <= 8 N tol, tol = ', tl(i)
    call check_close(trim(lbl), erel(i), 0.0_wp, 8*ig%nsteps*tl(i))
  end do
  ! tolerance proportionality: h ~ tol^(1/8) and error ~ h^8, so the error scales like tol:
  ! 1e4 from 1e-8 to 1e-12; asking for a factor 100 leaves two decades for the controller's
  ! imperfect proportionality and for roundoff at tol = 1e-12
  call check_true('adaptive ball: energy error shrinks >= 100x from tol 1e-8 to 1e-12', &
                  erel(1) >= 100*erel(2))

  ! === 6. events: x = 0 on the oscillator from (1, 0) ====================================
  ! Fixed steps h = 0.1: the event time error is the state error at the event over
  ! |dx/dt| = 1. Sections 2 and 3 measured, at h = 0.3125, a global error of 6e-11 and an
  ! interpolant error of 1e-10 (to t = 10); at h = 0.1 both are (0.32)^8 ~ 1e-4 times
  ! that (~1e-14), and Illinois stops at a bracket of 4 eps. 1e-12 leaves a factor ~50.
  call oscillator_start(ig, x, 0.1_wp)
  call propagate(ig, x, 10.0_wp, stat, event=plane_t(k=1, c=0.0_wp, direction=-1))
  call check_eq('event (fixed h): status TUBES_EVENT', stat, TUBES_EVENT)
  call check_close('event (fixed h): time = pi/2', ig%t, PI/2, 1.0e-12_wp)
  call check_close('event (fixed h): x(1) = 0', x(1), 0.0_wp, 1.0e-12_wp)  ! g = x(1) at root
  call check_close('event (fixed h): x(2) = -1', x(2), -1.0_wp, 1.0e-12_wp)
  ! Adaptive, rtol = atol = 1e-12 (bound of section 5: |dz_i| <= 2 tol (1 + |z_i|) <= 4 tol
  ! per step, accumulating linearly over N steps; the rotation does not amplify errors):
  ! state error <= 4 N tol, interpolant another 4 tol, Illinois 4 eps.
  call ig%init(oscillator_t(), t0=0.0_wp)
  ig%h = 0
  ig%rtol = 1.0e-12_wp
  ig%atol = 1.0e-12_wp
  x = [1.0_wp, 0.0_wp]
  call propagate(ig, x, 10.0_wp, stat, event=plane_t(k=1, c=0.0_wp, direction=-1))
  call check_eq('event (adaptive): status TUBES_EVENT', stat, TUBES_EVENT)
  tol = 4*(ig%nsteps + 1)*ig%rtol + 8*EPS
  call check_close('event (adaptive): time = pi/2', ig%t, PI/2, tol)
  call check_close('event (adaptive): x(2) = -1', x(2), -1.0_wp, tol)
  ! rising direction: the first upward crossing of x = 0 is at 3 pi/2
  call oscillator_start(ig, x)
  call propagate(ig, x, 10.0_wp, stat, event=plane_t(k=1, c=0.0_wp, direction=1))
  call check_eq('event (rising): status TUBES_EVENT', stat, TUBES_EVENT)
  call check_close('event (rising): time = 3 pi/2', ig%t, 1.5_wp*PI, &
                   4*(ig%nsteps + 1)*ig%rtol + 8*EPS)
  ! a later propagate continues from the event state (the stepper restarts there);
  ! ig%nsteps counts the steps of both calls
  call propagate(ig, x, 2*PI, stat)
  call check_eq('continue after event: status', stat, TUBES_OK)
  call check_close('continue after event: x(2 pi) = 1', x(1), 1.0_wp, &
                   4*(ig%nsteps + 1)*ig%rtol + 8*EPS)

  ! === 7. backward integration ============================================================
  ! x(-3) = (cos 3, sin 3); bound 4 N tol as in 6.
  call oscillator_start(ig, x)
  call propagate(ig, x, -3.0_wp, stat)
  call check_eq('backward: status', stat, TUBES_OK)
  call check_true('backward: lands on t = -3', ig%t == -3.0_wp)
  write (*, '(a,i0,a,es10.3)') '     backward: ', ig%nsteps, ' steps, error ', &
    norm2(x - [cos(3.0_wp), sin(3.0_wp)])
  call check_close('backward: x(-3) = cos 3', x(1), cos(3.0_wp), 4*ig%nsteps*ig%rtol)
  call check_close('backward: v(-3) = sin 3', x(2), sin(3.0_wp), 4*ig%nsteps*ig%rtol)
  ! time reversal: (x, v, t) -> (x, -v, -t) maps the oscillator and (1, 0) to themselves,
  ! so the backward run must mirror the forward one step for step: the same step count and
  ! the same numbers up to the order of floating-point operations (4 ulps)
  nsteps_fwd = int(ig%nsteps)
  xf = x
  call oscillator_start(ig, x)
  call propagate(ig, x, 3.0_wp, stat)
  call check_eq('backward mirrors forward: step count', nsteps_fwd, int(ig%nsteps))
  call check_close('backward mirrors forward: x', xf(1), x(1), 4*EPS)
  call check_close('backward mirrors forward: v', xf(2), -x(2), 4*EPS)

  ! === 8. failure statuses ================================================================
  ! The model returns NaN with stat < 0 once x < 1/2 (after t = pi/3 from (1, 0)).
  call ig%init(nan_oscillator_t(), t0=0.0_wp)
  ig%h = 0
  x = [1.0_wp, 0.0_wp]
  call propagate(ig, x, 10.0_wp, stat)
  call check_eq('NaN model: status TUBES_EMODEL', stat, TUBES_EMODEL)
  ! outputs stay at the last accepted step: finite, before pi/3, on the exact solution
  ! (bound 4 N tol of 6)
  call check_true('NaN model: t, x left at the last accepted step', &
                  all(abs(x) <= 1) .and. ig%t < PI/3 .and. ig%t > 0)
  s = ig%t
  call check_close('NaN model: x = cos(t) at the last accepted step', x(1), cos(s), &
                   4*(ig%nsteps + 1)*ig%rtol)
  ! step budget: fixed h = 0.1 towards t = 10 with max_steps = 5
  call oscillator_start(ig, x, 0.1_wp, 5)
  call propagate(ig, x, 10.0_wp, stat)
  call check_eq('max_steps = 5: status TUBES_EMAXSTEPS', stat, TUBES_EMAXSTEPS)
  call check_eq('max_steps = 5: five steps taken', int(ig%nsteps), 5)
  call check_close('max_steps = 5: t = 0.5', ig%t, 0.5_wp, 8*EPS)   ! five additions of 0.1
  ! truncation of 5 steps of 0.1 is ~1e-17 (section 2 scaled by h^8): roundoff only,
  ! a few ulps per step
  call check_close('max_steps = 5: x = cos(0.5)', x(1), cos(0.5_wp), 1.0e-14_wp)

  ! === regressions found in review ==========================================================
  ! a restarted propagate must not re-detect the event it stopped at: successive falling
  ! zeros of cos t are pi/2 + 2 pi k (the restart point has g = roundoff of either sign)
  call ig%init(oscillator_t(), t0=0.0_wp)
  ig%rtol = 1.0e-12_wp
  ig%atol = 1.0e-12_wp
  ig%max_steps = 100000
  x = [1.0_wp, 0.0_wp]
  do k = 0, 2
    call propagate(ig, x, 100.0_wp, stat, event=plane_t(k=1, c=0.0_wp, direction=-1))
    write (lbl, '(a,i0)') 'restarted event lands on pi/2 + 2 pi k, k = ', k
    ! adaptive bound as above: 4 (N + 1) tol per unit of amplitude, N accepted steps so far
    call check_close(trim(lbl), ig%t, PI/2 + 2*PI*k, 4*(ig%nsteps + 1)*ig%rtol)
  end do
  ! evaluation count: fixed h = 0.1 to t = 1 is 10 steps of 12 new stages (FSAL) plus the
  ! initial f(t0, x0): 121; no extra sliver step from roundoff drift of t
  call osc_fixed(0.1_wp, 1.0_wp)
  call check_eq('fixed h = 0.1 to t = 1: 10 steps', int(ig%nsteps), 10)
  call check_eq('fixed h = 0.1 to t = 1: nfev = 1 + 12 * 10', int(ig%nfev), 121)
  ! and at large t, where ulp(t) >> 64 eps h: h = 0.02 to t = 1000 is 50000 steps exactly
  call osc_fixed(0.02_wp, 1000.0_wp)
  call check_eq('fixed h = 0.02 to t = 1000: 50000 steps, no sliver steps', int(ig%nsteps), 50000)

  call finish('test_dop853')

contains

  !> The oscillator from (1, 0) with fixed step h to t_end (a step budget of twice the steps).
  subroutine osc_fixed(h, t_end)
    real(wp), intent(in) :: h, t_end
    call oscillator_start(ig, x, h, 2*nint(t_end/h))
    call propagate(ig, x, t_end, stat)
  end subroutine osc_fixed

  !> All rooted trees with 1..8 vertices: order, density gamma, and the stage vectors
  !> Phi(t) (with A) and Phi_abs(t) (with |A|), by attaching multisets of smaller trees
  !> (as non-increasing index lists) to a new root.
  subroutine build_trees()
    real(wp) :: ones(NSX)
    integer :: n, nprev
    ones = 1
    ntree = 1
    tord(1) = 1
    tgam(1) = 1
    phi(:, 1) = ones
    phi_abs(:, 1) = ones
    do n = 2, 8
      nprev = ntree
      call grow(n, n - 1, nprev, ones, ones, 1.0_wp)
    end do
  end subroutine build_trees

  recursive subroutine grow(n, rem, maxidx, prod, prod_abs, gam)
    integer, intent(in) :: n, rem, maxidx
    real(wp), intent(in) :: prod(NSX), prod_abs(NSX), gam
    integer :: j
    if (rem == 0) then
      ntree = ntree + 1
      tord(ntree) = n
      tgam(ntree) = n*gam
      phi(:, ntree) = prod
      phi_abs(:, ntree) = prod_abs
      return
    end if
    do j = maxidx, 1, -1
      if (tord(j) > rem) cycle
      call grow(n, rem - tord(j), j, prod*matmul(a, phi(:, j)), &
                prod_abs*matmul(abs(a), phi_abs(:, j)), gam*tgam(j))
    end do
  end subroutine grow

  !> Weights b(theta) of the dense output, Horner form as in dop853_interp.
  pure function dense_weights(w, theta) result(bt)
    real(wp), intent(in) :: w(NSX, 7), theta
    real(wp) :: bt(NSX), t1
    t1 = 1 - theta
    bt = theta*(w(:, 1) + t1*(w(:, 2) + theta*(w(:, 3) + t1*(w(:, 4) + theta*(w(:, 5) &
         + t1*(w(:, 6) + theta*w(:, 7)))))))
  end function dense_weights

end program test_dop853
