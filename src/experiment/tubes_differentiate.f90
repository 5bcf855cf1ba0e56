!> Velocities from sampled positions (tracked trajectories): two differentiators that return
!> the derivative and the smoothed signal of uniformly sampled data x(1:n), spacing dt.
!>
!> - diff_spectral: FFT (FFTW3) of the signal made smooth at its ends, a raised-cosine low-pass
!>   filter, and the derivative as i omega in frequency space. Non-periodic tracks are handled by
!>   subtracting a trend and extending the residual symmetrically (edge modes below).
!> - diff_savgol: Savitzky-Golay, the least-squares polynomial of degree `order` over `window`
!>   samples; at the ends the window is shifted (the first/last `window` samples) and the fit is
!>   evaluated off-centre, so every output uses the same polynomial degree.
!>
!> Accuracy and the choice of edge mode are measured in tests/test_differentiate.f90 and
!> docs/experiment-data.md.
module tubes_differentiate
  use, intrinsic :: iso_c_binding   ! all of it: fftw3.f03 declares its interfaces with many C kinds
  use tubes_kinds, only: wp, PI
  use tubes_status, only: TUBES_OK, TUBES_EINPUT
  implicit none
  private
  include 'fftw3.f03'

  integer, parameter, public :: EDGE_PERIODIC = 0  !! the signal is taken as periodic (no treatment)
  !> subtract the line through the two end samples, extend the residual oddly (a sine series)
  integer, parameter, public :: EDGE_ODD = 1
  !> subtract a quadratic whose end slopes are local least-squares estimates of x' at the ends,
  !> extend the residual evenly (a cosine series); the default
  integer, parameter, public :: EDGE_MIRROR = 2

  public :: diff_spectral, diff_savgol, savgol_weights, lowpass_gain

  !> FFTW plans kept between transforms by the caller that holds this (python/tubes_f2py.f90's
  !> differentiate_spectral keeps one for the Python session), for the next transform of their
  !> size and direction: making a plan (its twiddle factors, its problem's hash) was nearly all of
  !> a column's time for a few hundred samples. The last PLANS_MAX made are kept; then the oldest
  !> is destroyed. Without it (diff_spectral's plans absent) each transform makes and destroys its
  !> own: the same plan, the same bits.
  integer, parameter :: PLANS_MAX = 64
  type, public :: fft_plans_t
    integer :: n(PLANS_MAX) = -1
    logical :: forward(PLANS_MAX) = .false.
    type(c_ptr) :: plan(PLANS_MAX) = c_null_ptr
    integer :: next = 1
  end type fft_plans_t

contains

  !> Gain of the zero-phase low-pass filter at frequency f [Hz]: 1 up to
  !> cutoff (1 - rolloff/2), a raised cosine down to 0 at cutoff (1 + rolloff/2), with gain 1/2
  !> at the cutoff. cutoff <= 0: no filter (gain 1).
  pure real(wp) function lowpass_gain(f, cutoff, rolloff) result(gain)
    real(wp), intent(in) :: f        !! frequency [Hz] (>= 0)
    real(wp), intent(in) :: cutoff   !! half-gain frequency [Hz]; <= 0 means no filtering
    real(wp), intent(in) :: rolloff  !! width of the transition band / cutoff [1], 0 <= rolloff < 2
    real(wp) :: f1, f2
    gain = 1
    if (cutoff <= 0) return
    f1 = cutoff*(1 - rolloff/2)
    f2 = cutoff*(1 + rolloff/2)
    if (f <= f1) then
      gain = 1
    else if (f >= f2) then
      gain = 0
    else
      gain = 0.5_wp*(1 + cos(PI*(f - f1)/(f2 - f1)))
    end if
  end function lowpass_gain

  !> Spectral derivative of x sampled every dt: v = dx/dt and the filtered signal xs.
  !> The signal is made smooth at its ends according to `edge` (EDGE_*), transformed with
  !> FFTW (r2c of the extended residual), multiplied by the low-pass gain (lowpass_gain) and,
  !> for v, by i omega; the Nyquist bin of the derivative is set to zero. EDGE_MIRROR estimates
  !> the end slopes by a least-squares polynomial of degree end_order over end_window samples
  !> at each end (defaults below); the derivative at the two end samples is that estimate.
  !> stat: TUBES_OK, or TUBES_EINPUT (n < 4, dt <= 0, bad rolloff/edge/end fit, size mismatch).
  subroutine diff_spectral(x, dt, cutoff, rolloff, edge, v, xs, stat, end_order, end_window, plans)
    real(wp), intent(in) :: x(:)             !! samples [any unit]
    real(wp), intent(in) :: dt               !! sample spacing [s]
    real(wp), intent(in) :: cutoff           !! low-pass half-gain frequency [Hz]; <= 0: none
    real(wp), intent(in) :: rolloff          !! transition width / cutoff [1], 0 <= rolloff < 2
    integer, intent(in) :: edge              !! EDGE_PERIODIC, EDGE_ODD or EDGE_MIRROR
    real(wp), intent(out) :: v(:)            !! derivative [unit/s]
    real(wp), intent(out) :: xs(:)           !! filtered signal [unit]
    integer, intent(out) :: stat
    !> EDGE_MIRROR: degree of the end-slope fits (default 3)
    integer, intent(in), optional :: end_order
    !> EDGE_MIRROR: samples of the end-slope fits (default: two cutoff periods, at least
    !> end_order + 4; end_order + 4 without a filter; at most n)
    integer, intent(in), optional :: end_window
    !> plans kept between calls (fft_plans_t); absent: each transform plans anew (the same bits)
    type(fft_plans_t), intent(inout), optional :: plans
    real(wp), allocatable :: r(:), trend(:), dtrend(:), ext(:), w0(:), w1(:)
    complex(wp), allocatable :: spec(:), dspec(:)
    real(wp) :: big_t, d0, d1, f, gain, s
    integer :: n, nn, k, q, me
    v = 0
    xs = 0
    stat = TUBES_EINPUT
    n = size(x)
    if (n < 4 .or. size(v) /= n .or. size(xs) /= n) return
    if (.not. (dt > 0) .or. .not. (rolloff >= 0 .and. rolloff < 2)) return
    if (.not. (abs(cutoff) <= huge(1.0_wp))) return
    allocate (r(n), trend(n), dtrend(n))
    big_t = (n - 1)*dt
    select case (edge)
    case (EDGE_PERIODIC)
      trend = 0
      dtrend = 0
      nn = n
    case (EDGE_ODD)
      do k = 1, n
        trend(k) = x(1) + (x(n) - x(1))*real(k - 1, wp)/(n - 1)
      end do
      dtrend = (x(n) - x(1))/big_t
      nn = 2*(n - 1)
    case (EDGE_MIRROR)
      q = 3
      if (present(end_order)) q = end_order
      if (cutoff > 0) then
        me = max(q + 4, nint(min(2/(cutoff*dt), real(n, wp))))
      else
        me = q + 4
      end if
      if (present(end_window)) me = end_window
      me = min(me, n)
      if (q < 1 .or. me < q + 1) return
      allocate (w0(me), w1(me))
      call savgol_weights(me, q, 1, w0, w1, stat)
      if (stat /= TUBES_OK) return
      d0 = dot_product(w1, x(1:me))/dt
      call savgol_weights(me, q, me, w0, w1, stat)
      if (stat /= TUBES_OK) return
      d1 = dot_product(w1, x(n - me + 1:n))/dt
      stat = TUBES_EINPUT
      do k = 1, n   ! quadratic with slope d0 at t = 0 and d1 at t = big_t
        s = (k - 1)*dt
        trend(k) = d0*s + (d1 - d0)*s*s/(2*big_t)
        dtrend(k) = d0 + (d1 - d0)*s/big_t
      end do
      nn = 2*(n - 1)
    case default
      return
    end select
    r = x - trend
    allocate (ext(nn), spec(nn/2 + 1), dspec(nn/2 + 1))
    ext(1:n) = r
    select case (edge)
    case (EDGE_ODD)        ! r(1) = r(n) = 0 up to rounding: make them exact, extend oddly
      ext(1) = 0
      ext(n) = 0
      do k = 1, n - 2
        ext(n + k) = -r(n - k)
      end do
    case (EDGE_MIRROR)     ! extend evenly about both end samples
      do k = 1, n - 2
        ext(n + k) = r(n - k)
      end do
    end select
    call fft_real(ext, spec, .true., plans)
    do k = 0, nn/2
      f = k/(nn*dt)
      gain = lowpass_gain(f, cutoff, rolloff)
      spec(k + 1) = spec(k + 1)*gain
      dspec(k + 1) = spec(k + 1)*cmplx(0.0_wp, 2*PI*f, wp)
    end do
    if (mod(nn, 2) == 0) dspec(nn/2 + 1) = 0   ! the Nyquist mode has no odd-symmetric derivative
    call fft_real(ext, spec, .false., plans)
    xs = trend + ext(1:n)/nn
    call fft_real(ext, dspec, .false., plans)
    v = dtrend + ext(1:n)/nn
    stat = TUBES_OK
  end subroutine diff_spectral

  !> Unnormalised FFTs of real data: forward, x into its half spectrum y (real-to-complex);
  !> backward, the half spectrum y into x (complex-to-real, size(x) points). FFTW_ESTIMATE on
  !> arrays from fftw_alloc_* (always SIMD-aligned): the same plan, and so the same bits, on every
  !> call; kept in plans if present (else destroyed after), executed on this call's arrays.
  !> FFTW's planner is not thread-safe and a kept plan may be replaced by another thread's: the
  !> whole transform is one critical section (a column's transforms are short; the callers serial).
  subroutine fft_real(x, y, forward, plans)
    real(wp), intent(inout) :: x(:)
    complex(wp), intent(inout) :: y(:)
    logical, intent(in) :: forward
    type(fft_plans_t), intent(inout), optional :: plans
    real(c_double), pointer :: a(:)
    complex(c_double_complex), pointer :: b(:)
    type(c_ptr) :: pa, pb, plan
    integer :: n, k
    n = size(x)
    !$omp critical (tubes_fftw_planner)
    pa = fftw_alloc_real(int(n, c_size_t))
    pb = fftw_alloc_complex(int(size(y), c_size_t))
    call c_f_pointer(pa, a, [n])
    call c_f_pointer(pb, b, [size(y)])
    plan = c_null_ptr
    if (present(plans)) then
      do k = 1, PLANS_MAX
        if (plans%n(k) == n .and. (plans%forward(k) .eqv. forward)) then
          plan = plans%plan(k)
          exit
        end if
      end do
    end if
    if (.not. c_associated(plan)) then
      if (forward) then
        plan = fftw_plan_dft_r2c_1d(int(n, c_int), a, b, FFTW_ESTIMATE)
      else
        plan = fftw_plan_dft_c2r_1d(int(n, c_int), b, a, FFTW_ESTIMATE)
      end if
      if (present(plans)) then
        k = plans%next
        if (c_associated(plans%plan(k))) call fftw_destroy_plan(plans%plan(k))
        plans%n(k) = n
        plans%forward(k) = forward
        plans%plan(k) = plan
        plans%next = mod(k, PLANS_MAX) + 1
      end if
    end if
    if (forward) then
      a = x
      call fftw_execute_dft_r2c(plan, a, b)
      y = b
    else
      b = y                                ! c2r overwrites its input: b is a copy
      call fftw_execute_dft_c2r(plan, b, a)
      x = a
    end if
    if (.not. present(plans)) call fftw_destroy_plan(plan)
    call fftw_free(pa)
    call fftw_free(pb)
    !$omp end critical (tubes_fftw_planner)
  end subroutine fft_real

  !> Savitzky-Golay weights: the least-squares polynomial of degree `order` through m equally
  !> spaced samples (unit spacing), evaluated at sample j (1..m): value = sum w0 x, derivative
  !> per sample spacing = sum w1 x. Computed from a QR factorisation (modified Gram-Schmidt,
  !> twice) of the Vandermonde matrix in the scaled abscissa (i - centre)/half-width.
  !> stat: TUBES_EINPUT unless 0 <= order < m and 1 <= j <= m.
  pure subroutine savgol_weights(m, order, j, w0, w1, stat)
    integer, intent(in) :: m              !! window length (samples)
    integer, intent(in) :: order          !! polynomial degree
    integer, intent(in) :: j              !! evaluation sample in the window
    real(wp), intent(out) :: w0(m)        !! weights of the fitted value
    real(wp), intent(out) :: w1(m)        !! weights of the fitted derivative [1/spacing]
    integer, intent(out) :: stat
    real(wp) :: q(m, order + 1), rr(order + 1, order + 1), s(m), c, hw, psi0(order + 1), &
                psi1(order + 1), z0(order + 1), z1(order + 1), sj, proj
    integer :: i, k, l, pass
    w0 = 0
    w1 = 0
    stat = TUBES_EINPUT
    if (order < 0 .or. order >= m .or. j < 1 .or. j > m) return
    c = 0.5_wp*(m + 1)
    hw = max(0.5_wp*(m - 1), 1.0_wp)
    do i = 1, m
      s(i) = (i - c)/hw
    end do
    do k = 1, order + 1
      q(:, k) = s**(k - 1)
    end do
    rr = 0
    do k = 1, order + 1
      do pass = 1, 2
        do l = 1, k - 1
          proj = dot_product(q(:, l), q(:, k))
          rr(l, k) = rr(l, k) + proj
          q(:, k) = q(:, k) - proj*q(:, l)
        end do
      end do
      rr(k, k) = norm2(q(:, k))
      q(:, k) = q(:, k)/rr(k, k)
    end do
    sj = s(j)
    do k = 1, order + 1
      psi0(k) = sj**(k - 1)
      if (k == 1) then
        psi1(k) = 0
      else
        psi1(k) = (k - 1)*sj**(k - 2)/hw
      end if
    end do
    ! z = R^-T psi (forward substitution), w = Q z
    do k = 1, order + 1
      z0(k) = (psi0(k) - dot_product(rr(1:k - 1, k), z0(1:k - 1)))/rr(k, k)
      z1(k) = (psi1(k) - dot_product(rr(1:k - 1, k), z1(1:k - 1)))/rr(k, k)
    end do
    w0 = matmul(q, z0)
    w1 = matmul(q, z1)
    stat = TUBES_OK
  end subroutine savgol_weights

  !> Savitzky-Golay derivative v and smoothed signal xs of x sampled every dt: the
  !> least-squares polynomial of degree `order` over `window` samples (odd) centred on each
  !> sample; the first and last window/2 samples use the first/last `window` samples
  !> (shifted window). Polynomials of degree <= order are reproduced exactly.
  !> stat: TUBES_OK, or TUBES_EINPUT (window even or > n, order < 1 or >= window, dt <= 0).
  subroutine diff_savgol(x, dt, order, window, v, xs, stat)
    real(wp), intent(in) :: x(:)      !! samples [any unit]
    real(wp), intent(in) :: dt        !! sample spacing [s]
    integer, intent(in) :: order      !! polynomial degree (1 <= order < window)
    integer, intent(in) :: window     !! window length in samples (odd, <= n)
    real(wp), intent(out) :: v(:)     !! derivative [unit/s]
    real(wp), intent(out) :: xs(:)    !! smoothed signal [unit]
    integer, intent(out) :: stat
    real(wp), allocatable :: w0(:), w1(:)
    integer :: n, h, i
    v = 0
    xs = 0
    stat = TUBES_EINPUT
    n = size(x)
    if (size(v) /= n .or. size(xs) /= n .or. .not. (dt > 0)) return
    if (mod(window, 2) /= 1 .or. window > n .or. order < 1 .or. order >= window) return
    h = window/2
    allocate (w0(window), w1(window))
    call savgol_weights(window, order, h + 1, w0, w1, stat)
    if (stat /= TUBES_OK) return
    do i = h + 1, n - h
      xs(i) = dot_product(w0, x(i - h:i + h))
      v(i) = dot_product(w1, x(i - h:i + h))/dt
    end do
    do i = 1, h
      call savgol_weights(window, order, i, w0, w1, stat)
      if (stat /= TUBES_OK) return
      xs(i) = dot_product(w0, x(1:window))
      v(i) = dot_product(w1, x(1:window))/dt
      call savgol_weights(window, order, window - h + i, w0, w1, stat)
      if (stat /= TUBES_OK) return
      xs(n - h + i) = dot_product(w0, x(n - window + 1:n))
      v(n - h + i) = dot_product(w1, x(n - window + 1:n))/dt
    end do
    stat = TUBES_OK
  end subroutine diff_savgol
end module tubes_differentiate
