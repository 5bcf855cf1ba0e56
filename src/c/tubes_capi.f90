!> The bind(C) API (include/tubes.h): scalars by value, explicit-shape arrays, int status.
module tubes_capi
  use, intrinsic :: iso_c_binding, only: c_int, c_double, c_char, c_int64_t, c_ptr, c_funptr, &
                                         c_null_char, c_associated, c_funloc, c_f_procpointer
  use tubes_kinds, only: wp
  use tubes_status, only: TUBES_OK, TUBES_EINPUT, TUBES_EVENT, status_message
  use tubes_ball, only: ball_t
  use tubes_models, only: NMODEL, conservative_ball, damping_rate, model_ball
  use tubes_equilibria, only: equilibrium_t, find_equilibria
  use tubes_integrator, only: integrator_t, propagate
  use tubes_methods, only: new_integrator, method_opts_t
  use tubes_run, only: run_integration, section_spec_t
  use tubes_integrator, only: crossing_log_t
  use tubes_sampler, only: sampler_t
  use tubes_orbits, only: orbit_t, orbit_opts_t, orbit_family
  implicit none
  private

  !> Sampler that also calls a C progress callback every PROGRESS_EVERY steps.
  type, extends(sampler_t) :: c_sampler_t
    type(c_funptr) :: cb
    type(c_ptr) :: user
  contains
    procedure :: on_step => c_sampler_on_step
  end type c_sampler_t
  integer, parameter :: PROGRESS_EVERY = 2000

  abstract interface
    integer(c_int) function progress_i(t, user) bind(C)
      import :: c_int, c_double, c_ptr
      real(c_double), value :: t
      type(c_ptr), value :: user
    end function progress_i
  end interface

contains

  subroutine c_status_message(code, buf, len) bind(C, name='tubes_status_message')
    integer(c_int), value :: code, len
    character(kind=c_char), intent(out) :: buf(len)
    character(:), allocatable :: m
    integer :: i
    if (len < 1) return
    m = status_message(code)
    do i = 1, min(len - 1, len_trim(m))
      buf(i) = m(i:i)
    end do
    buf(min(len - 1, len_trim(m)) + 1) = c_null_char
  end subroutine c_status_message

  integer(c_int) function c_energy(model, x, energy) result(stat) bind(C, name='tubes_energy')
    real(c_double), intent(in) :: model(NMODEL), x(4)
    real(c_double), intent(out) :: energy
    type(ball_t) :: ball
    energy = 0
    call conservative_ball(model, ball, stat)
    if (stat /= TUBES_OK) return
    energy = ball%energy(x)
  end function c_energy

  integer(c_int) function c_vector_field(model, x, dxdt) result(stat) &
      bind(C, name='tubes_vector_field')
    real(c_double), intent(in) :: model(NMODEL), x(4)
    real(c_double), intent(out) :: dxdt(4)
    class(ball_t), allocatable :: ball
    real(wp) :: c
    dxdt = 0
    call model_ball(model, ball, c, stat)
    if (stat /= TUBES_OK) return
    call ball%eval(0.0_wp, x, dxdt, stat)
    if (stat /= 0) stat = -4
  end function c_vector_field

  integer(c_int) function c_momentum(model, q, v, p) result(stat) bind(C, name='tubes_momentum')
    real(c_double), intent(in) :: model(NMODEL), q(2), v(2)
    real(c_double), intent(out) :: p(2)
    type(ball_t) :: ball
    p = 0
    call conservative_ball(model, ball, stat)
    if (stat /= TUBES_OK) return
    p = ball%momentum(q, v)
  end function c_momentum

  integer(c_int) function c_damping_rate(model, c) result(stat) bind(C, name='tubes_damping_rate')
    real(c_double), intent(in) :: model(NMODEL)
    real(c_double), intent(out) :: c
    type(ball_t) :: ball
    c = 0
    call conservative_ball(model, ball, stat)
    if (stat /= TUBES_OK) return
    if (model(7) > 0) call damping_rate(ball, model(7), c, stat)
  end function c_damping_rate

  integer(c_int) function c_equilibria(model, box, n_grid, nmax, n, x, y, height, energy, &
      grad_norm, morse, names, lambda, omega, evec) result(stat) bind(C, name='tubes_find_equilibria')
    real(c_double), intent(in) :: model(NMODEL)
    real(c_double), value :: box
    integer(c_int), value :: n_grid, nmax
    integer(c_int), intent(out) :: n
    real(c_double), intent(out) :: x(nmax), y(nmax), height(nmax), energy(nmax), &
                                   grad_norm(nmax), lambda(nmax), omega(nmax), evec(16, nmax)
    integer(c_int), intent(out) :: morse(nmax)
    character(kind=c_char), intent(out) :: names(8, nmax)
    type(ball_t) :: ball
    type(equilibrium_t), allocatable :: eqs(:)
    integer :: k, i
    n = 0
    call conservative_ball(model, ball, stat)
    if (stat /= TUBES_OK) return
    call find_equilibria(ball, box, n_grid, eqs, stat)
    if (stat /= TUBES_OK) return
    n = min(size(eqs), nmax)
    names = c_null_char
    do k = 1, n
      x(k) = eqs(k)%q(1)
      y(k) = eqs(k)%q(2)
      height(k) = eqs(k)%height
      energy(k) = eqs(k)%energy
      grad_norm(k) = eqs(k)%grad_norm
      morse(k) = eqs(k)%morse
      lambda(k) = eqs(k)%lambda
      omega(k) = eqs(k)%omega
      evec(:, k) = reshape(eqs(k)%evec, [16])
      do i = 1, min(7, len_trim(eqs(k)%name))
        names(i, k) = eqs(k)%name(i:i)
      end do
    end do
  end function c_equilibria

  integer(c_int) function c_trajectory(model, x0, t_end, dt_out, method, rtol, atol, h, &
      max_steps, omega_bind, solver, max_iter, sec_kind, sec_level, sec_dir, stop_first, &
      max_cross, nmax, n, t, state, energy, n_cross, cross_t, cross_x, cross_dir, counters, &
      c_damp, progress, user) result(stat) bind(C, name='tubes_run_trajectory')
    real(c_double), intent(in) :: model(NMODEL), x0(4)
    real(c_double), value :: t_end, dt_out, rtol, atol, h, omega_bind, sec_level
    integer(c_int), value :: method, nmax, solver, max_iter, sec_kind, sec_dir, stop_first, max_cross
    integer(c_int64_t), value :: max_steps
    integer(c_int), intent(out) :: n, n_cross
    real(c_double), intent(out) :: t(nmax), state(4, nmax), energy(nmax), c_damp
    real(c_double), intent(out) :: cross_t(max(max_cross, 1)), cross_x(4, max(max_cross, 1))
    integer(c_int), intent(out) :: cross_dir(max(max_cross, 1))
    integer(c_int64_t), intent(out) :: counters(4)
    type(c_funptr), value :: progress
    type(c_ptr), value :: user
    type(ball_t) :: cons
    type(c_sampler_t) :: obs
    type(crossing_log_t) :: log
    integer :: k
    n = 0
    n_cross = 0
    counters = 0
    c_damp = 0
    if (dt_out <= 0 .or. t_end < 0 .or. nmax < 2 .or. max_cross < 0) then
      stat = TUBES_EINPUT
      return
    end if
    call conservative_ball(model, cons, stat)
    if (stat /= TUBES_OK) return
    obs%cb = progress
    obs%user = user
    call obs%start(0.0_wp, dt_out, x0, nmax)
    call run_integration(model, x0, t_end, method, rtol, atol, h, max_steps, &
                         method_opts_t(omega_bind=omega_bind, solver=solver, max_iter=max_iter), &
                         section_spec_t(kind=sec_kind, level=sec_level, dir=sec_dir, &
                                        stop_at_first=stop_first /= 0, max_crossings=max(max_cross, 1)), &
                         obs, log, counters, c_damp, stat)
    n = obs%n
    t(1:n) = obs%t(1:n)
    state(:, 1:n) = obs%x(:, 1:n)
    do k = 1, n
      energy(k) = cons%energy(state(:, k))
    end do
    if (sec_kind /= 0) then
      n_cross = min(log%n, max_cross)
      do k = 1, n_cross
        cross_t(k) = log%t(k)
        cross_x(:, k) = log%x(:, k)
        cross_dir(k) = log%direction(k)
      end do
    end if
  end function c_trajectory

  !> The Lyapunov family of the saddle named `saddle` (C string) at the ascending excess
  !> energies des(nde); outputs per orbit as in include/tubes.h (tubes_orbit_family).
  integer(c_int) function c_orbit_family(model, saddle, nde, des, n_segments, tol, rtol, atol, &
      max_iter, nsamp, energy, period, action, state0, mu_u, mu_s, mu_triv, stab, residual, &
      closure, iterations, converged, mindist, monodromy, ts, xs, history, end_de, end_reason) &
      result(stat) bind(C, name='tubes_orbit_family')
    real(c_double), intent(in) :: model(NMODEL)
    character(kind=c_char), intent(in) :: saddle(8)
    integer(c_int), value :: nde, n_segments, max_iter, nsamp
    real(c_double), intent(in) :: des(nde)
    real(c_double), value :: tol, rtol, atol
    real(c_double), intent(out) :: energy(nde), period(nde), action(nde), state0(4, nde), &
      mu_u(nde), mu_s(nde), mu_triv(4, nde), stab(nde), residual(nde), closure(nde), &
      mindist(nde), monodromy(4, 4, nde), ts(nsamp, nde), xs(4, nsamp, nde), &
      history(max_iter, nde), end_de
    integer(c_int), intent(out) :: iterations(nde), converged(nde), end_reason
    type(ball_t) :: ball
    type(equilibrium_t), allocatable :: eqs(:)
    type(orbit_opts_t) :: opts
    type(orbit_t), allocatable :: orbs(:)
    character(8) :: name
    integer :: k, isad, nh, reason
    real(wp) :: ede
    energy = 0; period = 0; action = 0; state0 = 0; mu_u = 0; mu_s = 0; mu_triv = 0; stab = 0
    residual = 0; closure = 0; mindist = 0; monodromy = 0; ts = 0; xs = 0; history = 0
    iterations = 0; converged = 0; end_de = -1; end_reason = 0
    name = ''
    do k = 1, 8
      if (saddle(k) == c_null_char) exit
      name(k:k) = saddle(k)
    end do
    if (nde < 1 .or. nsamp < 2 .or. max_iter < 1 .or. n_segments < 1 .or. tol <= 0) then
      stat = TUBES_EINPUT
      return
    end if
    call conservative_ball(model, ball, stat)
    if (stat /= TUBES_OK) return
    call find_equilibria(ball, 20.0_wp, 41, eqs, stat)
    if (stat /= TUBES_OK) return
    isad = 0
    do k = 1, size(eqs)
      if (eqs(k)%name == name .and. eqs(k)%morse == 1) isad = k
    end do
    if (isad == 0) then
      stat = TUBES_EINPUT
      return
    end if
    opts%n_segments = n_segments
    opts%tol = tol
    opts%rtol = rtol
    opts%atol = atol
    opts%max_iter = max_iter
    opts%n_samples = nsamp
    allocate (orbs(nde))
    call orbit_family(ball, eqs, isad, des, opts, orbs, ede, reason, stat)
    if (stat < 0) return
    end_de = ede
    end_reason = reason
    do k = 1, nde
      energy(k) = eqs(isad)%energy + des(k)
      if (allocated(orbs(k)%history)) then
        nh = min(size(orbs(k)%history), max_iter)
        history(1:nh, k) = orbs(k)%history(1:nh)
      end if
      iterations(k) = orbs(k)%iterations
      converged(k) = merge(1, 0, orbs(k)%converged)
      if (.not. orbs(k)%converged) cycle
      period(k) = orbs(k)%period
      action(k) = orbs(k)%action
      state0(:, k) = orbs(k)%x0
      mu_u(k) = orbs(k)%mu_unstable
      mu_s(k) = orbs(k)%mu_stable
      mu_triv(:, k) = [orbs(k)%mu_trivial(1), orbs(k)%mu_trivial_imag(1), &
                       orbs(k)%mu_trivial(2), orbs(k)%mu_trivial_imag(2)]
      stab(k) = orbs(k)%stability_index
      residual(k) = orbs(k)%residual
      closure(k) = orbs(k)%closure
      mindist(k) = orbs(k)%min_eq_distance
      monodromy(:, :, k) = orbs(k)%monodromy
      ts(:, k) = orbs(k)%t
      xs(:, :, k) = orbs(k)%x
    end do
    stat = TUBES_OK
  end function c_orbit_family

  subroutine c_sampler_on_step(self, ig, t_hi, stop_now)
    class(c_sampler_t), intent(inout) :: self
    class(integrator_t), intent(inout) :: ig
    real(wp), intent(in) :: t_hi
    logical, intent(out) :: stop_now
    procedure(progress_i), pointer :: f
    call self%sampler_t%on_step(ig, t_hi, stop_now)
    if (mod(self%count, PROGRESS_EVERY) == 0 .and. c_associated(self%cb)) then
      call c_f_procpointer(self%cb, f)
      stop_now = f(ig%t, self%user) /= 0
    end if
  end subroutine c_sampler_on_step
end module tubes_capi
