!> Differentiators for tracked positions (src/experiment/tubes_differentiate.f90): Savitzky-Golay and
!> spectral (FFTW) derivatives of analytic signals sampled like the camera (50 Hz), without and
!> with noise. Checks: exactness (SG on polynomials of degree <= order, spectral on band-limited
!> periodic signals, the edge modes on the polynomials they remove), convergence orders, the
!> end error of the mirror mode against the Taylor bound of its end fit, the noise of both
!> methods against its exact variance, and bad input.
program test_differentiate
  use tubes_kinds, only: wp
  use tubes_status, only: TUBES_OK, TUBES_EINPUT
  use tubes_differentiate, only: diff_spectral, diff_savgol, savgol_weights, lowpass_gain, &
                                 EDGE_PERIODIC, EDGE_ODD, EDGE_MIRROR
  use tubes_check, only: check_close, check_true, check_eq, finish
  use tubes_test_models, only: PI, EPS
  implicit none

  real(wp), parameter :: DT = 0.02_wp              ! the camera: 50 Hz
  integer, parameter :: NCAM = 501                 ! 10 s of it
  real(wp), allocatable :: t(:), x(:), vt(:), v(:), xs(:), w0(:), w1(:), e(:)
  real(wp) :: tol, sw, xmax, errs(3), order_obs, a(4), f(4), ph(4), bound, err_odd, &
              err_mir, lam_sum, lam2_sum, pred, ms, sd, fc
  integer :: p, m, k, i, stat, n, j, nbig
  character(96) :: lbl

  ! === 1. Savitzky-Golay reproduces polynomials of degree <= order (every sample) ==========
  ! One second at 50 Hz; x(t) = sum_k c_k s^k, s = (t - 0.5)/0.5, c_k = (-1)^k/(k + 1):
  ! |x| <= 2.5.
  ! Roundoff: each output is a dot product of the data with weights that the QR of a
  ! Vandermonde matrix (condition <= ~1e2 for degree 5 in [-1, 1]) gives to ~1e2 eps relative;
  ! the tolerance is 1e3 eps sum|w1| max|x| / dt, sum|w1| taken at the worst (end) sample.
  call grid(51, DT, t)
  allocate (x(51), vt(51), v(51), xs(51))
  do p = 1, 5
    m = 2*p + 3
    call poly(t, p, x, vt)
    call diff_savgol(x, DT, p, m, v, xs, stat)
    call check_eq('savgol status', stat, TUBES_OK)
    allocate (w0(m), w1(m))
    call savgol_weights(m, p, 1, w0, w1, stat)
    sw = sum(abs(w1))
    deallocate (w0, w1)
    xmax = maxval(abs(x))
    write (lbl, '(a,i0,a,i0,a)') 'savgol order ', p, ', window ', m, ': exact derivative of degree-p polynomial'
    call check_close(trim(lbl), maxval(abs(v - vt)), 0.0_wp, 1.0e3_wp*EPS*sw*xmax/DT)
    write (lbl, '(a,i0,a)') 'savgol order ', p, ': exact value of degree-p polynomial'
    call check_close(trim(lbl), maxval(abs(xs - x)), 0.0_wp, 1.0e3_wp*EPS*xmax*m)
    ! degree p + 1 is not reproduced at the ends (the check above has teeth): the end error is
    ! the leading Taylor term, ~ c_(p+1) (p+1)! (m h)^p / 0.5 with h = 0.04 in s, 1e-3 or
    ! more here: far above 10x the roundoff tolerance above
    call poly(t, p + 1, x, vt)
    call diff_savgol(x, DT, p, m, v, xs, stat)
    write (lbl, '(a,i0,a)') 'savgol order ', p, ': degree p+1 is not exact (> 10x roundoff tol)'
    call check_true(trim(lbl), maxval(abs(v - vt)) > 1.0e4_wp*EPS*sw*xmax/DT)
  end do

  ! === 2. Savitzky-Golay convergence orders on a sine and a damped oscillation ===============
  ! Fixed window (in samples) while dt halves: the centred derivative of an order-3 fit is
  ! exact for degree 4 (the even terms decouple), so its error is O(h^4); the end samples are
  ! evaluated off-centre and their error is O(h^3). Observed orders from dt = 0.01, 0.005,
  ! 0.0025 on [0, 2] s; the asymptotic constant is reached to within (omega h)^2 ~ 3 %, so the
  ! observed order is checked to +-0.2.
  do k = 1, 2
    do j = 1, 3
      n = nint(2.0_wp/(0.005_wp/2**(j - 1))) + 1
      call grid(n, 0.005_wp/2**(j - 1), t)
      call signal(k, t, x, vt)
      if (allocated(v)) deallocate (v, xs)
      allocate (v(n), xs(n))
      call diff_savgol(x, t(2) - t(1), 3, 9, v, xs, stat)
      errs(j) = maxval(abs(v(5:n - 4) - vt(5:n - 4)))
      e = [abs(v(1) - vt(1)), abs(v(n) - vt(n))]
      if (j == 1) then
        bound = maxval(e)
      else
        order_obs = log(bound/maxval(e))/log(2.0_wp)
        bound = maxval(e)
        write (lbl, '(a,i0,a,i0)') 'savgol order 3 end-sample convergence order, signal ', k, ', dt level ', j
        call check_close(trim(lbl), order_obs, 3.0_wp, 0.2_wp)
      end if
    end do
    order_obs = log(errs(2)/errs(3))/log(2.0_wp)
    write (lbl, '(a,i0)') 'savgol order 3 interior convergence order (4), signal ', k
    call check_close(trim(lbl), order_obs, 4.0_wp, 0.2_wp)
  end do

  ! === 3. spectral: band-limited periodic signals are differentiated to roundoff =============
  ! N = 500 samples over T = 10 s; components with integer cycles k = 3, 13, 47, 120 (0.3 to
  ! 12 Hz). FFT roundoff is ~ eps log2(N) relative to the signal's norm (Higham, ch. 24), and the
  ! derivative multiplies it by at most omega_max; tol = 100 eps log2(N) omega_max sum|a|.
  n = 500
  call grid(n, DT, t)
  deallocate (x, vt, v, xs)
  allocate (x(n), vt(n), v(n), xs(n))
  a = [1.0_wp, 0.5_wp, 0.2_wp, 0.05_wp]
  f = [3, 13, 47, 120]/(n*DT)
  ph = [0.3_wp, 1.1_wp, 2.0_wp, 5.0_wp]
  call sines(t, a, f, ph, x, vt)
  tol = 100*EPS*log(real(n, wp))/log(2.0_wp)*2*PI*maxval(f)*sum(a)
  call diff_spectral(x, DT, 0.0_wp, 0.0_wp, EDGE_PERIODIC, v, xs, stat)
  call check_eq('spectral periodic status', stat, TUBES_OK)
  call check_close('spectral periodic, no filter: derivative of a band-limited signal', &
                   maxval(abs(v - vt)), 0.0_wp, tol)
  call check_close('spectral periodic, no filter: the signal itself', maxval(abs(xs - x)), 0.0_wp, &
                   tol/(2*PI*maxval(f)))
  ! fc = 16 Hz, rolloff 0.4 passes f <= 12.8 Hz untouched and removes f >= 19.2 Hz: a 20 Hz
  ! component (k = 200) added to the data disappears from both outputs
  x = x + 0.3_wp*sin(2*PI*200/(n*DT)*t + 0.4_wp)
  call diff_spectral(x, DT, 16.0_wp, 0.4_wp, EDGE_PERIODIC, v, xs, stat)
  call check_close('spectral periodic, fc = 16 Hz: 20 Hz removed, derivative exact', &
                   maxval(abs(v - vt)), 0.0_wp, tol*2)
  call sines(t, a, f, ph, x, vt)
  call check_close('spectral periodic, fc = 16 Hz: 20 Hz removed, signal exact', &
                   maxval(abs(xs - x)), 0.0_wp, tol/(2*PI*maxval(f))*2)
  call check_close('lowpass gain at the cutoff is 1/2', lowpass_gain(4.0_wp, 4.0_wp, 0.5_wp), &
                   0.5_wp, 4*EPS)

  ! === 4. edge modes on the polynomials they remove exactly (non-periodic) ==================
  ! odd: the line through the end samples; mirror: a quadratic (its end slopes are the exact
  ! slopes of the degree-3 end fits, and the residual is then a constant). Roundoff as in 3,
  ! with the trend's values (|x| <= 2.5) in place of the spectrum's.
  n = NCAM
  call grid(n, DT, t)
  deallocate (x, vt, v, xs)
  allocate (x(n), vt(n), v(n), xs(n))
  call poly(t, 1, x, vt)
  call diff_spectral(x, DT, 5.0_wp, 0.5_wp, EDGE_ODD, v, xs, stat)
  tol = 100*EPS*log(2.0_wp*n)/log(2.0_wp)*2*PI*25*maxval(abs(x))
  call check_close('spectral odd edge: exact derivative of a line', maxval(abs(v - vt)), 0.0_wp, tol)
  call poly(t, 2, x, vt)
  call diff_spectral(x, DT, 5.0_wp, 0.5_wp, EDGE_MIRROR, v, xs, stat)
  allocate (w0(20), w1(20))          ! the end fit of fc = 5 Hz: degree 3 over 2/(fc dt) = 20
  call savgol_weights(20, 3, 1, w0, w1, stat)
  sw = sum(abs(w1))
  deallocate (w0, w1)
  call check_close('spectral mirror edge: exact derivative of a quadratic', maxval(abs(v - vt)), &
                   0.0_wp, tol + 1.0e3_wp*EPS*sw*maxval(abs(x))/DT)

  ! === 5. non-periodic sine, no filter: the mirror mode's end error ==========================
  ! x = sin(2 pi 1.3 t + 0.7) on [0, 10] s at 50 Hz. At the two end samples the derivative is
  ! the end fit's (degree 3 over 7 samples): its error is bounded by the Taylor remainder,
  ! sum_i |w1_i| ((i-1) dt)^4 / 24 max|x''''| / dt. Elsewhere the error comes from the kink the
  ! slope error d leaves in the even extension: its derivative jumps by 2 d, and a truncated
  ! Fourier series overshoots a jump by at most Gibbs' 9 % of it, so 1.2 d bounds the error
  ! near the ends; the check allows 2x the Taylor bound over the whole track.
  a(1) = 2*PI*1.3_wp
  x = sin(a(1)*t + 0.7_wp)
  vt = a(1)*cos(a(1)*t + 0.7_wp)
  allocate (w0(7), w1(7))
  call savgol_weights(7, 3, 1, w0, w1, stat)
  bound = sum([(abs(w1(i))*((i - 1)*DT)**4, i = 1, 7)])/24*a(1)**4/DT
  call diff_spectral(x, DT, 0.0_wp, 0.0_wp, EDGE_MIRROR, v, xs, stat)
  call check_true('spectral mirror end sample within the Taylor bound of its end fit', &
                  max(abs(v(1) - vt(1)), abs(v(n) - vt(n))) <= bound)
  err_mir = maxval(abs(v - vt))
  call check_close('spectral mirror, sine: max error over the track', err_mir, 0.0_wp, 2*bound)
  ! the default is measured: the odd extension's residual has a jump 2 x''(0) in its second
  ! derivative, the mirror's only an O(h^3) slope error, so mirror is the more accurate one
  call diff_spectral(x, DT, 0.0_wp, 0.0_wp, EDGE_ODD, v, xs, stat)
  err_odd = maxval(abs(v - vt))
  call check_true('spectral: mirror edge beats odd edge on a non-periodic sine', err_mir < err_odd)
  call diff_spectral(x, DT, 0.0_wp, 0.0_wp, EDGE_PERIODIC, v, xs, stat)
  call check_true('spectral: mirror edge beats no edge treatment on a non-periodic sine', &
                  err_mir < maxval(abs(v - vt)))
  write (*, '(a,3es11.3)') 'info: sine max error mirror, odd, periodic [1/s]:', err_mir, err_odd, &
    maxval(abs(v - vt))

  ! === 6. spectral mirror convergence on the damped oscillation ==============================
  ! The error is set by the degree-3 end fit, O(h^3) at fixed window; dt = 0.01, 0.005,
  ! 0.0025 on [0, 10] s: observed order 3 +- 0.3 (the kink's spread is resolution-independent).
  do j = 1, 3
    n = nint(10.0_wp/(0.01_wp/2**(j - 1))) + 1
    call grid(n, 0.01_wp/2**(j - 1), t)
    call signal(2, t, x, vt)
    deallocate (v, xs)
    allocate (v(n), xs(n))
    call diff_spectral(x, t(2) - t(1), 0.0_wp, 0.0_wp, EDGE_MIRROR, v, xs, stat)
    errs(j) = maxval(abs(v - vt))
  end do
  call check_close('spectral mirror convergence order on a damped oscillation (dt/2)', &
                   log(errs(1)/errs(2))/log(2.0_wp), 3.0_wp, 0.3_wp)
  call check_close('spectral mirror convergence order on a damped oscillation (dt/4)', &
                   log(errs(2)/errs(3))/log(2.0_wp), 3.0_wp, 0.3_wp)

  ! === 7. noise: the derivative's variance against its exact value ==========================
  ! Periodic band-limited signal plus white Gaussian noise (sigma = 0.05 cm, the synthetic
  ! experiment's default) on N = 2^14 samples at 50 Hz. The spectral derivative of the noise
  ! is Gaussian with a circulant covariance of eigenvalues lambda_k = sigma^2 (omega_k H_k)^2
  ! (Nyquist bin 0), so E[mean square] = sum(lambda)/N exactly and its standard deviation is
  ! sqrt(2 sum(lambda^2))/N; the check allows 5 of them. SG: interior covariance
  ! C(l) = sigma^2 sum_i w1_i w1_(i+l) / dt^2, E = C(0), sd = sqrt(2 sum_l C(l)^2 / N').
  nbig = 2**14
  call grid(nbig, DT, t)
  deallocate (x, vt, v, xs)
  if (allocated(e)) deallocate (e)
  allocate (x(nbig), vt(nbig), v(nbig), xs(nbig), e(nbig))
  a = [1.0_wp, 0.5_wp, 0.2_wp, 0.0_wp]
  f = [3, 13, 47, 1]/(nbig*DT)
  call sines(t, a, f, ph, x, vt)
  call gauss_noise(0.05_wp, e)
  fc = 5
  call diff_spectral(x + e, DT, fc, 0.5_wp, EDGE_PERIODIC, v, xs, stat)
  lam_sum = 0
  lam2_sum = 0
  do k = 0, nbig - 1
    j = min(k, nbig - k)
    if (j == nbig/2) cycle
    pred = (0.05_wp*2*PI*j/(nbig*DT)*lowpass_gain(j/(nbig*DT), fc, 0.5_wp))**2
    lam_sum = lam_sum + pred
    lam2_sum = lam2_sum + pred**2
  end do
  ms = sum((v - vt)**2)/nbig
  sd = sqrt(2*lam2_sum)/nbig
  call check_close('spectral fc = 5 Hz: mean square derivative noise vs exact (5 sd)', ms, &
                   lam_sum/nbig, 5*sd)
  write (*, '(a,2f10.4,a)') 'info: spectral derivative noise rms measured, predicted ', sqrt(ms), &
    sqrt(lam_sum/nbig), ' cm/s'
  m = 15
  call diff_savgol(x + e, DT, 3, m, v, xs, stat)
  deallocate (w0, w1)
  allocate (w0(m), w1(m))
  call savgol_weights(m, 3, m/2 + 1, w0, w1, stat)
  pred = (0.05_wp/DT)**2*sum(w1**2)
  sd = 0
  do j = -(m - 1), m - 1
    sd = sd + ((0.05_wp/DT)**2*sum([(w1(i)*w1(i + j), i = max(1, 1 - j), min(m, m - j))]))**2
  end do
  n = nbig - m + 1
  sd = sqrt(2*sd/n)
  ! the signal's own SG error (O(h^4), < 1e-5 cm/s at these frequencies) is far below sd
  ms = sum((v(m/2 + 1:nbig - m/2) - vt(m/2 + 1:nbig - m/2))**2)/n
  call check_close('savgol order 3, window 15: mean square derivative noise vs exact (5 sd)', ms, &
                   pred, 5*sd)
  write (*, '(a,2f10.4,a)') 'info: savgol derivative noise rms measured, predicted ', sqrt(ms), &
    sqrt(pred), ' cm/s'

  ! === 8. bad input ========================================================================
  n = 50
  call grid(n, DT, t)
  deallocate (x, vt, v, xs)
  allocate (x(n), vt(n), v(n), xs(n))
  x = t
  call diff_savgol(x, DT, 3, 10, v, xs, stat)
  call check_eq('savgol: even window refused', stat, TUBES_EINPUT)
  call diff_savgol(x, DT, 3, 51, v, xs, stat)
  call check_eq('savgol: window > n refused', stat, TUBES_EINPUT)
  call diff_savgol(x, DT, 5, 5, v, xs, stat)
  call check_eq('savgol: order >= window refused', stat, TUBES_EINPUT)
  call diff_savgol(x, DT, 0, 5, v, xs, stat)
  call check_eq('savgol: order 0 refused', stat, TUBES_EINPUT)
  call diff_savgol(x, 0.0_wp, 3, 5, v, xs, stat)
  call check_eq('savgol: dt = 0 refused', stat, TUBES_EINPUT)
  call diff_spectral(x, -DT, 0.0_wp, 0.0_wp, EDGE_MIRROR, v, xs, stat)
  call check_eq('spectral: dt < 0 refused', stat, TUBES_EINPUT)
  call diff_spectral(x, DT, 5.0_wp, 2.0_wp, EDGE_MIRROR, v, xs, stat)
  call check_eq('spectral: rolloff >= 2 refused', stat, TUBES_EINPUT)
  call diff_spectral(x, DT, 5.0_wp, 0.5_wp, 7, v, xs, stat)
  call check_eq('spectral: unknown edge mode refused', stat, TUBES_EINPUT)
  call diff_spectral(x(1:3), DT, 5.0_wp, 0.5_wp, EDGE_MIRROR, v(1:3), xs(1:3), stat)
  call check_eq('spectral: n < 4 refused', stat, TUBES_EINPUT)
  call diff_spectral(x, DT, 5.0_wp, 0.5_wp, EDGE_MIRROR, v, xs, stat, end_order=3, end_window=3)
  call check_eq('spectral: end window <= end order refused', stat, TUBES_EINPUT)

  call finish('test_differentiate')

contains

  subroutine grid(n, h, t)
    integer, intent(in) :: n
    real(wp), intent(in) :: h
    real(wp), allocatable, intent(out) :: t(:)
    integer :: i
    allocate (t(n))
    do i = 1, n
      t(i) = (i - 1)*h
    end do
  end subroutine grid

  !> x = sum_{k=0}^{deg} (-1)^k/(k+1) s^k, s = (t - tm)/tm with tm the middle of t, and its
  !> time derivative.
  subroutine poly(t, deg, x, v)
    real(wp), intent(in) :: t(:)
    integer, intent(in) :: deg
    real(wp), intent(out) :: x(:), v(:)
    real(wp) :: s(size(t)), tm
    integer :: k
    tm = 0.5_wp*(t(1) + t(size(t)))
    s = (t - tm)/tm
    x = 0
    v = 0
    do k = 0, deg
      x = x + (-1)**k/(k + 1.0_wp)*s**k
      if (k > 0) v = v + (-1)**k/(k + 1.0_wp)*k*s**(k - 1)/tm
    end do
  end subroutine poly

  !> 1: sin(2 pi 1.3 t + 0.7); 2: the damped oscillation exp(-0.2 t) cos(8.3 t + 0.4).
  subroutine signal(kind, t, x, v)
    integer, intent(in) :: kind
    real(wp), intent(in) :: t(:)
    real(wp), allocatable, intent(out) :: x(:), v(:)
    real(wp) :: w
    allocate (x(size(t)), v(size(t)))
    if (kind == 1) then
      w = 2*PI*1.3_wp
      x = sin(w*t + 0.7_wp)
      v = w*cos(w*t + 0.7_wp)
    else
      x = exp(-0.2_wp*t)*cos(8.3_wp*t + 0.4_wp)
      v = exp(-0.2_wp*t)*(-0.2_wp*cos(8.3_wp*t + 0.4_wp) - 8.3_wp*sin(8.3_wp*t + 0.4_wp))
    end if
  end subroutine signal

  subroutine sines(t, a, f, ph, x, v)
    real(wp), intent(in) :: t(:), a(:), f(:), ph(:)
    real(wp), intent(out) :: x(:), v(:)
    integer :: k
    x = 0
    v = 0
    do k = 1, size(a)
      x = x + a(k)*sin(2*PI*f(k)*t + ph(k))
      v = v + a(k)*2*PI*f(k)*cos(2*PI*f(k)*t + ph(k))
    end do
  end subroutine sines

  !> Gaussian deviates of standard deviation sigma (Box-Muller on the intrinsic generator
  !> with a fixed seed: the test is reproducible).
  subroutine gauss_noise(sigma, e)
    real(wp), intent(in) :: sigma
    real(wp), intent(out) :: e(:)
    integer, allocatable :: seed(:)
    real(wp) :: u(2)
    integer :: ns, i
    call random_seed(size=ns)
    allocate (seed(ns))
    seed = [(1234567 + 7919*i, i = 1, ns)]
    call random_seed(put=seed)
    do i = 1, size(e)
      call random_number(u)
      e(i) = sigma*sqrt(-2*log(1 - u(1)))*cos(2*PI*u(2))
    end do
  end subroutine gauss_noise
end program test_differentiate
