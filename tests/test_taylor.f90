!> The Taylor method (src/integrators/tubes_taylor.f90, docs/integrators-taylor.md): root
!> isolation on polynomials with known roots; the order of accuracy at a fixed order and step on
!> the oscillator (exact flow) and on the ball (against the real128 reference); events on the
!> oscillator against the exact crossing times, two crossings in one step; the adaptive method
!> against the real128 reference and its energy error; every built-in system (its formula in the
!> table of src/models/tubes_models.f90) against DOP853 on the system's closed form; the damped
!> ball; the variational equations against DOP853's with the analytic Jacobian.
program test_taylor
  use tubes_kinds, only: wp, i8
  use tubes_check, only: check_close, check_rel, check_true, check_eq, finish
  use tubes_status, only: TUBES_OK, TUBES_EVENT, TUBES_EMODEL
  use tubes_test_models, only: X0_BALL, PI, oscillator_t
  use tubes_taylor, only: taylor_t, isolate_roots, taylor_order, step_sizes, taylor_rule
  use tubes_dop853, only: dop853_t
  use tubes_integrator, only: integrator_t, propagate, plane_t, crossing_log_t
  use tubes_field, only: vector_field_t
  use tubes_hamiltonian, only: hamiltonian_t
  use tubes_models, only: make_model, make_field, MAX_PARAMS
  use tubes_reference, only: reference_solution
  use tubes_variational, only: variational_t, make_variational, stm_start
  implicit none
  real(wp), parameter :: PAPER(10) = [0.07_wp, 1.017_wp, 15.103_wp, 0.00656_wp, 12.065_wp, 981.0_wp, 0.0_wp, &
                                      0.0_wp, 0.0_wp, 0.0_wp]

  call roots()
  call step_size_rule()
  call oscillator_order()
  call oscillator_events()
  call two_crossings_in_one_step()
  call ball_against_reference()
  call builtin_systems()
  call variational()
  call escape()
  call finish('test_taylor')

contains

  !> The step size (step_sizes) against Jorba and Zou's rule computed with libm,
  !> h_JZ = exp(min(-log(n1)/(p - 1), -log(n2)/p) - 2 - 0.7/(p - 1)): never above it and at most
  !> the factor 2^(-1/128 - log2(1 + 1/128)/(p - 1)) below it (the docs' bound), on random normal
  !> n1, n2 over 600 binades and orders 2 to 30, also where both terms nearly tie, one call of 8
  !> and eight calls of 1 the same bits; a zero norm sets no limit (h > 1e300 with both zero, the
  !> other's limit with one); an infinite or NaN norm gives h = 0.
  subroutine step_size_rule()
    use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_positive_inf, ieee_quiet_nan
    real(wp) :: u(4), n1(8), n2(8), r1(8), r2(8), c(8), h(8), h1(1), r(3), want, lo, worst_lo, worst_hi
    integer :: k, l, p(8), above, below, differ
    above = 0
    below = 0
    differ = 0
    worst_lo = 1
    worst_hi = 0
    call random_seed(put=[(36 + k, k = 1, 64)])
    do k = 1, 50000
      do l = 1, 8
        call random_number(u)
        p(l) = 2 + int(29*u(1))
        r = taylor_rule(p(l))
        r1(l) = r(1)
        r2(l) = r(2)
        c(l) = r(3)
        n1(l) = (0.5_wp + u(2))*2.0_wp**int(600*u(3) - 300)
        if (mod(l, 2) == 0) then               ! a near-tie: n2 from n1, moved by 1e-16 .. 1e-3
          n2(l) = exp(log(n1(l))*r1(l)/r2(l))*(1 + (u(4) - 0.5_wp)*10.0_wp**(-16 + 13*u(2)))
        else
          n2(l) = (0.5_wp + u(4))*2.0_wp**int(600*u(2) - 300)
        end if
      end do
      call step_sizes(8, n1, n2, r1, r2, c, h)
      do l = 1, 8
        want = exp(min(-log(n1(l))*r1(l), -log(n2(l))*r2(l)) - 2 - 0.7_wp/(p(l) - 1))
        if (.not. (want > 1.0e-290_wp .and. want < 1.0e290_wp)) cycle
        lo = 2.0_wp**(-1.0_wp/128 - log(1 + 1.0_wp/128)/log(2.0_wp)*r1(l))
        if (h(l) > want*(1 + 1.0e-13_wp)) above = above + 1
        if (h(l) < want*lo*(1 - 1.0e-13_wp)) below = below + 1
        worst_lo = min(worst_lo, h(l)/want)
        worst_hi = max(worst_hi, h(l)/want)
        call step_sizes(1, n1(l:l), n2(l:l), r1(l:l), r2(l:l), c(l:l), h1)
        if (h1(1) /= h(l)) differ = differ + 1
      end do
    end do
    print '(a, f8.5, a, f8.5, a)', '  step_sizes / Jorba-Zou in [', worst_lo, ', ', worst_hi, ']'
    call check_eq('step_sizes: never above Jorba and Zou''s h (400000 pairs, orders 2..30)', above, 0)
    call check_eq('step_sizes: never below it by more than 2^(-1/128 - log2(1 + 1/128)/(p - 1))', below, 0)
    call check_eq('step_sizes: nl = 8 and nl = 1 the same bits', differ, 0)
    r = taylor_rule(11)
    call step_sizes(1, [0.0_wp], [0.0_wp], r(1:1), r(2:2), r(3:3), h1)
    call check_true('step_sizes: zero norms set no limit', h1(1) > 1.0e300_wp .and. h1(1) <= huge(1.0_wp))
    call step_sizes(1, [0.0_wp], [1.0e-20_wp], r(1:1), r(2:2), r(3:3), h1)
    want = exp(-log(1.0e-20_wp)*r(2) - 2 - 0.7_wp/10)
    call check_true('step_sizes: one zero norm, the other''s limit', h1(1) <= want .and. h1(1) > 0.99_wp*want)
    call step_sizes(1, [1.0_wp], [ieee_value(1.0_wp, ieee_positive_inf)], r(1:1), r(2:2), r(3:3), h1)
    call check_true('step_sizes: an infinite norm gives h = 0', h1(1) == 0)
    call step_sizes(1, [ieee_value(1.0_wp, ieee_quiet_nan)], [1.0_wp], r(1:1), r(2:2), r(3:3), h1)
    call check_true('step_sizes: a NaN norm gives h = 0', h1(1) == 0)
  end subroutine step_size_rule

  !> P(s) = (s - 0.1)(s - 0.15)(s - 0.7)(s + 0.3)(s - 2): three roots in (0, 1), each alone in an
  !> interval of the samples (P changes sign across it, and nowhere else); backwards, the roots
  !> -0.3 in (-1, 0) only.
  subroutine roots()
    real(wp) :: a(0:5)
    real(wp), allocatable :: ts(:)
    integer :: m
    a = poly([0.1_wp, 0.15_wp, 0.7_wp, -0.3_wp, 2.0_wp])
    call isolate_roots(a, 1.0_wp, ts, m)
    call check_eq('roots: sign changes on [0, 1]', sign_changes(a, [0.0_wp, ts(1:m), 1.0_wp]), 3)
    call check_true('roots: samples inside (0, 1), increasing', all(ts(1:m) > 0 .and. ts(1:m) < 1) .and. &
                    all(ts(2:m) > ts(1:m - 1)))
    call isolate_roots(a, -1.0_wp, ts, m)
    call check_eq('roots backwards: sign changes on [-1, 0]', sign_changes(a, [0.0_wp, ts(1:m), -1.0_wp]), 1)
    ! roots 1e-6 apart: still separated (bisection depth; not on a dyadic point, where a root
    ! would sit on a sample and change no sign in this count)
    a = poly([0.3_wp, 0.300001_wp, 0.9_wp, 3.0_wp, 4.0_wp])
    call isolate_roots(a, 1.0_wp, ts, m)
    call check_eq('roots 1e-6 apart: sign changes', sign_changes(a, [0.0_wp, ts(1:m), 1.0_wp]), 3)
  end subroutine roots

  !> Coefficients (increasing degree) of prod (s - r).
  pure function poly(r) result(a)
    real(wp), intent(in) :: r(:)
    real(wp) :: a(0:size(r))
    integer :: i
    a = 0
    a(0) = 1
    do i = 1, size(r)
      a(1:i) = a(0:i - 1) - r(i)*a(1:i)
      a(0) = -r(i)*a(0)
    end do
  end function poly

  !> Sign changes of P between consecutive points, each counted once; -1 if some interval
  !> holds more than one root (a sign change of P at a finer sampling that the points miss).
  integer function sign_changes(a, s) result(n)
    real(wp), intent(in) :: a(0:), s(:)
    real(wp) :: u, v
    integer :: i, j, fine
    n = 0
    do i = 1, size(s) - 1
      fine = 0
      do j = 0, 999
        u = horner(a, s(i) + (s(i + 1) - s(i))*j/1000.0_wp)
        v = horner(a, s(i) + (s(i + 1) - s(i))*(j + 1)/1000.0_wp)
        if (u*v < 0) fine = fine + 1
      end do
      if (fine > 1) then
        n = -1
        return
      end if
      if (horner(a, s(i))*horner(a, s(i + 1)) < 0) n = n + 1
    end do
  end function sign_changes

  pure real(wp) function horner(a, s)
    real(wp), intent(in) :: a(0:), s
    integer :: k
    horner = a(size(a) - 1)
    do k = size(a) - 2, 0, -1
      horner = horner*s + a(k)
    end do
  end function horner

  !> Order 4 at fixed steps h = 0.1, 0.05 to t = 10 on x'' = -x: the error falls by 2^4 (the
  !> truncated series' local error h^5/5!, global h^4); the observed order within 0.1 of 4.
  subroutine oscillator_order()
    type(taylor_t) :: ig
    real(wp) :: x(2), err(2)
    integer :: k, stat
    do k = 1, 2
      call ig%init(oscillator_t(), 0.0_wp)
      ig%order = 4
      ig%h = 0.1_wp/2**(k - 1)
      ig%rtol = 1.0e-300_wp
      ig%atol = 1.0e-300_wp
      x = [1.0_wp, 0.0_wp]
      call propagate(ig, x, 10.0_wp, stat)
      call check_eq('oscillator order 4: status', stat, TUBES_OK)
      err(k) = maxval(abs(x - [cos(10.0_wp), -sin(10.0_wp)]))
    end do
    call check_close('oscillator: observed order at p = 4', log(err(1)/err(2))/log(2.0_wp), 4.0_wp, 0.1_wp)
  end subroutine oscillator_order

  !> Crossings of x = 0 going down (x = cos t: t = pi/2 + 2 pi k) at tol 1e-15: times and states
  !> exact to 1e-14 (the series is exact to rounding; the root is refined on the polynomial).
  subroutine oscillator_events()
    type(taylor_t) :: ig
    type(crossing_log_t) :: log
    real(wp) :: x(2)
    integer :: stat, k
    call ig%init(oscillator_t(), 0.0_wp)
    ig%rtol = 1.0e-15_wp
    ig%atol = 1.0e-15_wp
    x = [1.0_wp, 0.0_wp]
    call propagate(ig, x, 26.0_wp, stat, event=plane_t(k=1, c=0.0_wp, direction=-1, terminal=.false.), &
                   crossings=log)
    call check_eq('oscillator events: status', stat, TUBES_OK)
    call check_eq('oscillator events: 4 crossings going down in 26 s', log%n, 4)
    do k = 1, min(log%n, 4)
      call check_close('oscillator event time', log%t(k), PI/2 + 2*PI*(k - 1), 1.0e-14_wp*(1 + log%t(k)))
      call check_close('oscillator event state x', log%x(1, k), 0.0_wp, 1.0e-14_wp)
      call check_close('oscillator event state v', log%x(2, k), -1.0_wp, 1.0e-14_wp)
    end do
  end subroutine oscillator_events

  !> x = cos t crosses x = 0.999 at 2 pi -+ acos(0.999), 0.089 s apart: one Taylor step (about
  !> 0.9 s at tol 1e-14) holds both, and both are found (sampling g at 4 points of each step of
  !> another method would miss them).
  subroutine two_crossings_in_one_step()
    type(taylor_t) :: ig
    type(crossing_log_t) :: log
    real(wp) :: x(2), t0, a
    integer :: stat
    t0 = 2*PI - 0.3_wp
    a = acos(0.999_wp)
    call ig%init(oscillator_t(), t0)
    ig%rtol = 1.0e-14_wp
    ig%atol = 1.0e-14_wp
    x = [cos(t0), -sin(t0)]
    call propagate(ig, x, 2*PI + 0.3_wp, stat, event=plane_t(k=1, c=0.999_wp, terminal=.false.), crossings=log)
    call check_eq('two crossings: status', stat, TUBES_OK)
    call check_eq('two crossings: steps', int(ig%nsteps), 1)
    call check_eq('two crossings: found', log%n, 2)
    if (log%n == 2) then
      call check_close('two crossings: first (going up)', log%t(1), 2*PI - a, 1.0e-13_wp)
      call check_close('two crossings: second (going down)', log%t(2), 2*PI + a, 1.0e-13_wp)
      call check_eq('two crossings: directions', log%direction(1)*10 + log%direction(2), 10 - 1)
    end if
  end subroutine two_crossings_in_one_step

  !> The ball from the benchmark's release (dE = 1500) over 1 s against the real128 reference
  !> (tol 1e-24, error ~1e-22): at order 8 and fixed steps 1/100, 1/200 the error falls by 2^8
  !> (observed order within 0.5 of 8: the ball is not in the asymptotic regime as cleanly as the
  !> oscillator); adaptive at tol 1e-15, the final state within 1e-13 relative and the energy
  !> within 1e-14 relative along 10 s.
  subroutine ball_against_reference()
    class(hamiltonian_t), allocatable :: ball
    type(taylor_t) :: ig
    real(wp) :: params(MAX_PARAMS), ref(4), x(4), err(2), e0
    integer :: stat, k
    integer(i8) :: ns
    params = 0
    params(1:10) = PAPER
    call make_model('rolling_ball', params, ball, stat)
    call check_eq('ball: model', stat, TUBES_OK)
    call reference_solution(PAPER, X0_BALL, 1.0_wp, 1.0e-24_wp, ref, stat, nsteps=ns)
    call check_eq('ball: reference', stat, TUBES_OK)
    do k = 1, 2
      call ig%init(ball, 0.0_wp)
      ig%order = 8
      ig%h = 1.0_wp/(100*2**(k - 1))
      ig%rtol = 1.0e-300_wp
      ig%atol = 1.0e-300_wp
      x = X0_BALL
      call propagate(ig, x, 1.0_wp, stat)
      call check_eq('ball order 8: status', stat, TUBES_OK)
      err(k) = maxval(abs(x - ref))/maxval(abs(ref))
      call check_eq('ball order 8: fixed steps', int(ig%nsteps), 100*2**(k - 1))
    end do
    ! the adaptive run below reaches 8e-16: the errors here are well above rounding
    call check_true('ball order 8: errors above rounding', err(2) > 2.0e-14_wp)
    write (*, '(a, 2es10.2)') 'ball order 8: errors at h = 1/100, 1/200:', err
    call check_close('ball: observed order at p = 8', log(err(1)/err(2))/log(2.0_wp), 8.0_wp, 0.5_wp)
    call ig%init(ball, 0.0_wp)
    ig%order = 0
    ig%h = 0
    ig%rtol = 1.0e-15_wp
    ig%atol = 1.0e-15_wp
    x = X0_BALL
    call propagate(ig, x, 1.0_wp, stat)
    call check_eq('ball adaptive: status', stat, TUBES_OK)
    call check_eq('ball adaptive: order at tol 1e-15', ig%p, taylor_order(1.0e-15_wp))
    call check_close('ball adaptive vs real128 at t = 1', maxval(abs(x - ref))/maxval(abs(ref)), 0.0_wp, 1.0e-13_wp)
    e0 = ball%energy(X0_BALL)
    do k = 1, 10
      call propagate(ig, x, real(k + 1, wp), stat)
      call check_close('ball adaptive: energy error', ball%energy(x)/e0 - 1, 0.0_wp, 1.0e-14_wp)
    end do
  end subroutine ball_against_reference

  !> Each built-in system through its formula (Taylor) and its closed form (DOP853), both at tol
  !> 1e-13 over 2 time units from a state of moderate energy: the same state to 1e-10 relative
  !> (the two integrations' errors; a formula that differs from the closed form by a term shows
  !> at O(1)); and the damped ball (damping_ratio 0.05: -c p on the momenta).
  subroutine builtin_systems()
    character(16), parameter :: NAMES(7) = [character(16) :: 'rolling_ball', 'henon_heiles', 'de_leon_berne', &
                                            'coupled_quartic', 'cr3bp', 'cr3bp_spatial', 'rolling_ball']
    real(wp) :: params(MAX_PARAMS), x0(6), xt(6), xd(6), c
    class(vector_field_t), allocatable :: field
    type(taylor_t) :: tay
    type(dop853_t) :: dop
    integer :: k, n, stat
    real(wp) :: span
    do k = 1, size(NAMES)
      params = 0
      select case (k)
      case (1, 7)
        params(1:10) = PAPER
        if (k == 7) params(7) = 0.05_wp
        x0(1:4) = [4.0_wp, 11.0_wp, 5.0_wp, -3.0_wp]
      case (2)
        x0(1:4) = [0.1_wp, -0.2_wp, 0.3_wp, 0.15_wp]
      case (3)
        params(1:6) = [8.0_wp, 8.0_wp, 10.0_wp, 1.5_wp, 1.0_wp, 1.0_wp]
        x0(1:4) = [0.05_wp, 0.6_wp, 0.5_wp, -0.4_wp]
      case (4)
        params(1:6) = [1.0_wp, 1.0_wp, 1.0_wp, 1.0_wp, 1.0_wp, 0.1_wp]
        x0(1:4) = [0.5_wp, 0.1_wp, 0.2_wp, -0.3_wp]
      case (5)
        params(1) = 0.01215058560962404_wp
        x0(1:4) = [0.5_wp, 0.1_wp, -0.1_wp, 0.5_wp]
      case (6)
        params(1) = 0.01215058560962404_wp
        x0 = [0.5_wp, 0.1_wp, 0.05_wp, -0.1_wp, 0.5_wp, 0.02_wp]
      end select
      call make_field(NAMES(k), params, field, c, stat)
      call check_eq('built-in '//trim(NAMES(k))//': model', stat, TUBES_OK)
      if (stat /= TUBES_OK) cycle
      if (k == 7) call check_true('damped ball: a damping rate', c > 0)
      n = field%dim()
      span = merge(0.5_wp, 2.0_wp, k == 1 .or. k == 7)
      xt(1:n) = x0(1:n)
      call run_13(tay, field, xt(1:n), span, 'built-in '//trim(NAMES(k))//': taylor status')
      xd(1:n) = x0(1:n)
      call run_13(dop, field, xd(1:n), span, 'built-in '//trim(NAMES(k))//': dop853 status')
      call check_close('built-in '//trim(NAMES(k))//': taylor vs dop853', &
                       maxval(abs(xt(1:n) - xd(1:n)))/maxval(abs(xd(1:n))), 0.0_wp, 1.0e-10_wp)
    end do
  end subroutine builtin_systems

  !> The ball's state transition matrix over 0.37 s (a brake orbit's half period at dE ~ 100):
  !> Taylor (the variational kernel from the formula) against DOP853 (the closed-form Jacobian),
  !> tol 1e-13: within 1e-10 of the matrix's largest entry.
  subroutine variational()
    class(hamiltonian_t), allocatable :: ball
    type(variational_t) :: var
    type(taylor_t) :: tay
    type(dop853_t) :: dop
    real(wp) :: params(MAX_PARAMS), zt(20), zd(20)
    integer :: stat
    params = 0
    params(1:10) = PAPER
    call make_model('rolling_ball', params, ball, stat)
    call make_variational(var, ball)
    zt = stm_start([-0.3_wp, 6.1_wp, 3.0_wp, 1.0_wp])
    zd = zt
    call run_13(tay, var, zt, 0.37_wp, 'variational: taylor status')
    call run_13(dop, var, zd, 0.37_wp, 'variational: dop853 status')
    call check_close('variational: state', maxval(abs(zt(1:4) - zd(1:4)))/maxval(abs(zd(1:4))), 0.0_wp, 1.0e-10_wp)
    call check_close('variational: matrix', maxval(abs(zt(5:) - zd(5:)))/maxval(abs(zd(5:))), 0.0_wp, 1.0e-10_wp)
  end subroutine variational

  !> An escaping Henon-Heiles trajectory (E = 0.22 > 1/6: it reaches infinity in finite time):
  !> the model refuses |x| + |y| > 1e6 (its eval, under DOP853), and the Taylor method, which
  !> does not call eval, refuses the same state: both TUBES_EMODEL, the state the last accepted
  !> one (finite, within the bound, at ig%t).
  subroutine escape()
    class(hamiltonian_t), allocatable :: hh
    type(taylor_t) :: tay
    type(dop853_t) :: dop
    real(wp) :: params(MAX_PARAMS), xt(4), xd(4)
    integer :: stat
    params = 0
    call make_model('henon_heiles', params, hh, stat)
    xt = [0.0_wp, 0.9_wp, 0.0_wp, 0.35_wp]
    xd = xt
    call tay%init(hh, 0.0_wp)
    tay%rtol = 1.0e-10_wp
    tay%atol = 1.0e-10_wp
    call propagate(tay, xt, 100.0_wp, stat)
    call check_eq('escape: taylor refuses the blown-up state', stat, TUBES_EMODEL)
    call check_true('escape: taylor keeps the last accepted state', &
                    abs(xt(1)) + abs(xt(2)) <= 1.0e6_wp .and. all(abs(xt) <= huge(1.0_wp)) .and. tay%t < 100)
    call dop%init(hh, 0.0_wp)
    dop%rtol = 1.0e-10_wp
    dop%atol = 1.0e-10_wp
    call propagate(dop, xd, 100.0_wp, stat)
    call check_eq('escape: dop853 (the eval of the model) refuses it too', stat, TUBES_EMODEL)
    ! along the escape y'' ~ y^2, so y ~ 6/(t_b - t)^2 passes 1e6 at t_b - 2.4e-3; each method stops
    ! at its last step before that, its steps there shorter than the distance to t_b
    call check_close('escape: both stop just before |q| = 1e6 (2.4e-3 before the blow-up)', tay%t, dop%t, &
                     2.5e-3_wp)
  end subroutine escape

  !> x from t = 0 to t_end with ig on field at rtol = atol = 1e-13, the status checked (label).
  subroutine run_13(ig, field, x, t_end, label)
    class(integrator_t), intent(inout) :: ig
    class(vector_field_t), intent(in) :: field
    real(wp), intent(inout) :: x(:)
    real(wp), intent(in) :: t_end
    character(*), intent(in) :: label
    integer :: stat
    call ig%init(field, 0.0_wp)
    ig%rtol = 1.0e-13_wp
    ig%atol = 1.0e-13_wp
    call propagate(ig, x, t_end, stat)
    call check_eq(label, stat, TUBES_OK)
  end subroutine run_13
end program test_taylor
