!> Classical RK4: measured convergence order (oscillator against the exact solution, rolling
!> ball by Richardson), dense output (Hermite cubic, O(h^4) locally, against the exact
!> flow), evaluation count (f at the step end reused), landing on tmax without sliver
!> steps, backward integration and time-reversal mirror, restart after an outside change
!> of the state, and failure statuses.
program test_rk4
  use tubes_kinds, only: wp
  use tubes_status, only: TUBES_OK, TUBES_EINPUT, TUBES_EMODEL, TUBES_ESTEP, TUBES_EMAXSTEPS
  use tubes_rk4, only: rk4_t
  use tubes_integrator, only: propagate
  use tubes_check, only: check_close, check_true, check_eq, finish
  use tubes_test_models, only: PI, EPS, oscillator_t, nan_oscillator_t, shy_oscillator_t, dense_probe_t, &
                             rotate, oscillator_fixed_step, ball_fixed_step, oscillator_start
  implicit none


  type(rk4_t) :: ig
  type(dense_probe_t) :: probe
  real(wp) :: x(2), xf(2), xr(2), err(3), dif(2), order, h, zs(4, 3), bound, eloc(2), s
  integer :: i, stat
  character(80) :: lbl

  ! === 1. convergence order on the oscillator =============================================
  ! For y' = i y the RK4 step multiplies by R(ih) = 1 + ih - h^2/2 - ih^3/6 + h^4/24, with
  ! arg R = h - h^5/120 + h^7/336 - ... and |R| = 1 - h^6/144 + ... (series of R). The
  ! global error at t is the phase lag t (h^4/120 - h^6/336) and, at right angles to it, the
  ! amplitude loss t h^5/144: |error| = t h^4/120 (1 - 0.36 h^2 + 0.35 h^2 + ...), the two
  ! O(h^2) terms each <= 0.6% at h = 1/8 (tolerance 1%). At t = 10 that is 2.0e-5 at
  ! h = 1/8. h = 1/8, 1/16, 1/32 are exact in binary and divide 10; every error stays >= 1e6
  ! above the roundoff floor (~1e-14 for <= 320 steps), and the O(h^2) terms move the
  ! measured order by < 0.01: window +-0.1.
  do i = 1, 3
    h = 0.125_wp/2**(i - 1)
    call oscillator_fixed_step(ig, h, 'oscillator', 'f7.5', err(i))
    write (*, '(a,f7.5,a,es10.3,a,es10.3,a)') '     h = ', h, '  error at t = 10: ', err(i), &
      '  (t h^4/120 = ', 10*h**4/120, ')'
    ! the leading term t h^4/120 itself, within the O(h^2) correction (< 1% at h <= 1/8)
    write (lbl, '(a,f7.5)') 'oscillator: error = t h^4/120 within 1%, h = ', h
    call check_close(trim(lbl), err(i), 10*h**4/120, 0.01_wp*10*h**4/120)
  end do
  do i = 1, 2
    order = log(err(i)/err(i + 1))/log(2.0_wp)
    write (lbl, '(a,f7.5)') 'oscillator: measured order 4 (+-0.1), from h = ', 0.125_wp/2**(i - 1)
    call check_close(trim(lbl), order, 4.0_wp, 0.1_wp)
  end do

  ! === 2. convergence order on the rolling ball (Richardson) ===============================
  ! From rest at (4, 12.6149) cm, t = 1 s, g = 981: no closed form, so the order comes from
  ! the differences of solutions at h, h/2, h/4 (h = 1/128, 1/256, 1/512 s: exact in binary,
  ! dividing 1): log2(|z_h - z_h/2| / |z_h/2 - z_h/4|) -> 4. The differences (1e-5..1e-6)
  ! are far above roundoff (~1e-11 for 512 steps of |z| ~ 60). The error is C h^4 (1 + c h):
  ! the observed drift of the local order is ~0.1 at h = 1/40 and shrinks with h; the window
  ! +-0.3 still separates order 4 from 3 and 5.
  do i = 1, 3
    call ball_fixed_step(ig, (1.0_wp/128)/2**(i - 1), [1.0_wp], 'ball', 'es9.3', zs(:, i:i))
  end do
  dif(1) = norm2(zs(:, 1) - zs(:, 2))
  dif(2) = norm2(zs(:, 2) - zs(:, 3))
  write (*, '(a,2es10.3)') '     |z_h - z_h/2|, |z_h/2 - z_h/4| at t = 1 s: ', dif
  order = log(dif(1)/dif(2))/log(2.0_wp)
  call check_close('ball: Richardson order 4 (+-0.3), h = 1/128 s', order, 4.0_wp, 0.3_wp)

  ! === 3. dense output ===================================================================
  ! Hermite cubic from x, f at both ends: the remainder of cubic Hermite interpolation is
  ! x''''(xi) th^2 (1 - th)^2 h^4/24 <= h^4/384 per component (|x''''| <= 1 on the unit
  ! circle), sqrt(2) h^4/384 for the 2-vector; the end values carry the step's own local
  ! error h^5/120 (section 1) and propagate into the cubic with weight <= 1, plus h times
  ! the slope error (the slope is f at that value, |df/dx| = 1). Bound:
  ! sqrt(2) h^4/384 + 2 h^5/120. Order from h = 0.2 and 0.1: 4 (+-0.3: the h^5 term of the
  ! bound is 16% of the h^4 term at h = 0.2).
  do i = 1, 2
    h = 0.2_wp/2**(i - 1)
    call oscillator_start(ig, x, h)
    probe = dense_probe_t(nsamp=7)
    call propagate(ig, x, 10.0_wp, stat, observer=probe)
    eloc(i) = probe%err_local
    bound = sqrt(2.0_wp)*h**4/384 + 2*h**5/120
    write (*, '(a,f4.2,a,es10.3,a,es10.3,a,es10.3)') '     h = ', h, ': max local dense error ', &
      eloc(i), ' bound ', bound, ', ends ', probe%err_ends
    write (lbl, '(a,f4.2)') 'dense output: local error within the Hermite bound, h = ', h
    call check_close(trim(lbl), eloc(i), 0.0_wp, bound)
    ! the cubic reproduces the end values: exactly at t_old (th = 0), to a few ulps at t
    ! (th = 1 - rounding of (t - t_old)/h), |x| = 1
    write (lbl, '(a,f4.2)') 'dense output: interpolant hits both step ends (4 eps), h = ', h
    call check_close(trim(lbl), probe%err_ends, 0.0_wp, 4*EPS)
  end do
  order = log(eloc(1)/eloc(2))/log(2.0_wp)
  write (*, '(a,f6.3)') '     measured dense-output order: ', order
  call check_close('dense output: local error O(h^4) (+-0.3)', order, 4.0_wp, 0.3_wp)

  ! === 4. evaluation count and landing ====================================================
  ! f at the end of a step is the next step's first stage: 4 new evaluations per step plus
  ! the initial f(t0, x0). h = 0.1 to t = 1: 10 steps, 41 evaluations.
  call oscillator_start(ig, x, 0.1_wp)
  call propagate(ig, x, 1.0_wp, stat)
  call check_eq('h = 0.1 to t = 1: 10 steps', int(ig%nsteps), 10)
  call check_eq('h = 0.1 to t = 1: nfev = 1 + 4 * 10 (end slope reused)', int(ig%nfev), 41)
  ! dense output needs no further evaluations
  call ig%interp(0.95_wp, xf)
  call check_eq('interp costs no evaluation', int(ig%nfev), 41)
  ! a non-binary h over many steps: t is computed on the grid t0 + k h (one rounding), so
  ! roundoff drift of t never leaves a sliver step: 1e-4 to t = 1 is exactly 10000 steps,
  ! 0.1 to t = 100 exactly 1000
  call oscillator_start(ig, x, 1.0e-4_wp)
  call propagate(ig, x, 1.0_wp, stat)
  call check_eq('h = 1e-4 to t = 1: exactly 10000 steps', int(ig%nsteps), 10000)
  call check_true('h = 1e-4 to t = 1: lands on t = 1', ig%t == 1.0_wp)
  call oscillator_start(ig, x, 0.1_wp)
  call propagate(ig, x, 100.0_wp, stat)
  call check_eq('h = 0.1 to t = 100: exactly 1000 steps', int(ig%nsteps), 1000)
  ! h not dividing the interval: 0.3 to t = 1 is 3 steps of 0.3 and one of 0.1
  call oscillator_start(ig, x, 0.3_wp)
  call propagate(ig, x, 1.0_wp, stat)
  call check_eq('h = 0.3 to t = 1: 4 steps', int(ig%nsteps), 4)
  call check_close('h = 0.3 to t = 1: last step is 0.1', ig%h_used, 0.1_wp, 4*EPS)

  ! === 5. backward integration ============================================================
  ! x(-3) = (cos 3, sin 3); global error t h^4/120 (section 1) = 2.5e-10 at h = 0.01, plus
  ! roundoff ~ 300 steps x 4 eps: tolerance 2 t h^4/120.
  call oscillator_start(ig, x, 0.01_wp)
  call propagate(ig, x, -3.0_wp, stat)
  call check_eq('backward: status', stat, TUBES_OK)
  call check_true('backward: lands on t = -3', ig%t == -3.0_wp)
  call check_close('backward: |x(-3) - (cos 3, sin 3)|', &
                   norm2(x - [cos(3.0_wp), sin(3.0_wp)]), 0.0_wp, 2*3*0.01_wp**4/120)
  ! time reversal (x, v, t) -> (x, -v, -t) maps the oscillator onto itself, and RK4 with -h
  ! on the mirrored state performs the same operations with the v signs flipped: the
  ! backward run mirrors the forward one (4 ulps for the differing grid times)
  xf = x
  call oscillator_start(ig, x, 0.01_wp)
  call propagate(ig, x, 3.0_wp, stat)
  call check_close('backward mirrors forward: x', xf(1), x(1), 4*EPS)
  call check_close('backward mirrors forward: v', xf(2), -x(2), 4*EPS)
  ! dense output in a backward step: local error bound of section 3 with h = 0.01
  call ig%interp(ig%t_old + 0.3_wp*ig%h_used, xr)
  call check_close('dense output in a forward step (bound of section 3)', &
                   norm2(xr - rotate(ig%x_old, 0.3_wp*ig%h_used)), 0.0_wp, &
                   sqrt(2.0_wp)*0.01_wp**4/384 + 2*0.01_wp**5/120)
  call oscillator_start(ig, x)
  call propagate(ig, x, -1.0_wp, stat)
  call ig%interp(ig%t_old + 0.3_wp*ig%h_used, xr)
  call check_true('backward step: h_used < 0', ig%h_used < 0)
  call check_close('dense output in a backward step (bound of section 3)', &
                   norm2(xr - rotate(ig%x_old, 0.3_wp*ig%h_used)), 0.0_wp, &
                   sqrt(2.0_wp)*0.01_wp**4/384 + 2*0.01_wp**5/120)

  ! === 6. restart after an outside change of the state ===================================
  ! The stored f(t, x) belongs to the state the last step returned; if the caller changes
  ! x, the stepper restarts from the new state (bitwise the same as a fresh stepper).
  call oscillator_start(ig, x, 0.1_wp)
  call propagate(ig, x, 1.0_wp, stat)
  x = [0.0_wp, 2.0_wp]
  call propagate(ig, x, 2.0_wp, stat)
  xf = x
  call ig%init(oscillator_t(), t0=1.0_wp)
  ig%h = 0.1_wp
  x = [0.0_wp, 2.0_wp]
  call propagate(ig, x, 2.0_wp, stat)
  call check_true('state changed outside: same result as a fresh start', all(xf == x))

  ! === 7. failure statuses ================================================================
  call oscillator_start(ig, x, 0.0_wp)
  call propagate(ig, x, 1.0_wp, stat)
  call check_eq('h = 0: TUBES_EINPUT', stat, TUBES_EINPUT)
  ig%h = -0.1_wp
  call propagate(ig, x, 1.0_wp, stat)
  call check_eq('h < 0: TUBES_EINPUT', stat, TUBES_EINPUT)
  ! NaN below x = 1/2 (reached at t = pi/3 from (1, 0)): TUBES_EMODEL, with t and x left
  ! at the last accepted step: before pi/3, on the exact solution (global error bound
  ! t h^4/120 of section 1 with h = 0.01, doubled)
  call ig%init(nan_oscillator_t(), t0=0.0_wp)
  ig%h = 0.01_wp
  x = [1.0_wp, 0.0_wp]
  call propagate(ig, x, 10.0_wp, stat)
  call check_eq('NaN model: TUBES_EMODEL', stat, TUBES_EMODEL)
  s = ig%t
  call check_true('NaN model: t left at the last accepted step (< pi/3)', s < PI/3 .and. s > 1)
  call check_close('NaN model: x left at the last accepted step', &
                   norm2(x - rotate([1.0_wp, 0.0_wp], s)), 0.0_wp, 2*s*0.01_wp**4/120)
  ! a model that keeps asking for smaller steps: h/4 per refusal until the step underflows
  call ig%init(shy_oscillator_t(x_min=0.5_wp), t0=0.0_wp)
  ig%h = 0.01_wp
  x = [1.0_wp, 0.0_wp]
  call propagate(ig, x, 10.0_wp, stat)
  call check_eq('model refusing x < 1/2: TUBES_ESTEP', stat, TUBES_ESTEP)
  call check_true('model refusing x < 1/2: steps were retried', ig%nrejected > 0)
  ! it stops where x = 1/2, i.e. at t = pi/3 to within the last accepted step (< h)
  call check_close('model refusing x < 1/2: stopped just before t = pi/3', ig%t, PI/3, 0.01_wp)
  call check_true('model refusing x < 1/2: x still >= 1/2', x(1) >= 0.5_wp)
  ! step budget (propagate): 5 steps of 0.1
  call oscillator_start(ig, x, 0.1_wp, 5)
  call propagate(ig, x, 10.0_wp, stat)
  call check_eq('max_steps = 5: TUBES_EMAXSTEPS', stat, TUBES_EMAXSTEPS)
  call check_close('max_steps = 5: t = 0.5', ig%t, 0.5_wp, 4*EPS)

  call finish('test_rk4')
end program test_rk4
