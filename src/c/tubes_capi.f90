!> The bind(C) API (include/tubes.h): scalars by value, explicit-shape arrays, int status.
module tubes_capi
  use, intrinsic :: iso_c_binding, only: c_int, c_double, c_char, c_int64_t, c_ptr, c_funptr, &
                                         c_null_char, c_associated, c_funloc, c_f_procpointer
  use tubes_kinds, only: wp
  use tubes_status, only: TUBES_OK, TUBES_EINPUT, TUBES_EVENT, TUBES_ENOCONV, status_message
  use tubes_ball, only: ball_t
  use tubes_models, only: NMODEL, conservative_ball, damping_rate, model_ball
  use tubes_equilibria, only: equilibrium_t, find_equilibria
  use tubes_integrator, only: integrator_t, propagate
  use tubes_methods, only: new_integrator, method_opts_t
  use tubes_run, only: run_integration, section_spec_t
  use tubes_integrator, only: crossing_log_t
  use tubes_sampler, only: sampler_t
  use tubes_orbits, only: orbit_t, orbit_opts_t, orbit_family
  use tubes_manifold, only: tube_opts_t, tube_cut_t, tube_cut
  use tubes_section, only: ray_t, section_region, section_area, section_darea
  use tubes_transport, only: monte_carlo, poincare_map, state_on_section
  use tubes_experiment, only: experiment_opts_t, experiment_samples, synthetic_experiment
  use, intrinsic :: iso_c_binding, only: c_long
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

  !> The model, its equilibria, the saddle named by the C string and the well of the section's
  !> quadrant (the one whose direction from the origin is closest to the ray's angle).
  subroutine setup_saddle(model, saddle, angle, ball, eqs, isad, iwell, stat)
    real(c_double), intent(in) :: model(NMODEL), angle
    character(kind=c_char), intent(in) :: saddle(8)
    type(ball_t), intent(out) :: ball
    type(equilibrium_t), allocatable, intent(out) :: eqs(:)
    integer, intent(out) :: isad, iwell, stat
    character(8) :: name
    integer :: k
    real(wp) :: best, d
    name = ''
    do k = 1, 8
      if (saddle(k) == c_null_char) exit
      name(k:k) = saddle(k)
    end do
    call conservative_ball(model, ball, stat)
    if (stat /= TUBES_OK) return
    call find_equilibria(ball, 20.0_wp, 41, eqs, stat)
    if (stat /= TUBES_OK) return
    isad = 0
    iwell = 0
    best = huge(1.0_wp)
    do k = 1, size(eqs)
      if (eqs(k)%name == name .and. eqs(k)%morse == 1) isad = k
      if (eqs(k)%morse == 0) then
        d = abs(atan2(eqs(k)%q(2), eqs(k)%q(1)) - angle)
        if (d < best) then
          best = d
          iwell = k
        end if
      end if
    end do
    if (isad == 0 .or. iwell == 0) stat = TUBES_EINPUT
  end subroutine setup_saddle

  !> The Lyapunov orbit at excess energy de by continuation (options as &orbits).
  subroutine orbit_at(ball, eqs, isad, de, n_segments, tol, rtol, atol, orb, stat, local)
    type(ball_t), intent(in) :: ball
    logical, intent(in), optional :: local    !! on this MPI rank alone (default: all ranks)
    type(equilibrium_t), intent(in) :: eqs(:)
    integer, intent(in) :: isad, n_segments
    real(wp), intent(in) :: de, tol, rtol, atol
    type(orbit_t), intent(out) :: orb
    integer, intent(out) :: stat
    type(orbit_opts_t) :: opts
    type(orbit_t) :: orbs(1)
    real(wp) :: end_de
    integer :: reason
    opts%n_segments = n_segments
    opts%tol = tol
    opts%rtol = rtol
    opts%atol = atol
    if (present(local)) opts%local = local
    call orbit_family(ball, eqs, isad, [de], opts, orbs, end_de, reason, stat)
    if (stat /= TUBES_OK) return
    orb = orbs(1)
    if (.not. orb%converged) stat = TUBES_ENOCONV
  end subroutine orbit_at

  !> The energy surface on the section theta = angle [rad] at E = E_e + de: its interval
  !> [rmin, rmax] on the ray, its area [cm^2/s] and dA/dE [s].
  integer(c_int) function c_section_info(model, saddle, angle, de, rmin, rmax, area, darea) &
      result(stat) bind(C, name='tubes_section_info')
    real(c_double), intent(in) :: model(NMODEL)
    character(kind=c_char), intent(in) :: saddle(8)
    real(c_double), value :: angle, de
    real(c_double), intent(out) :: rmin, rmax, area, darea
    type(ball_t) :: ball
    type(equilibrium_t), allocatable :: eqs(:)
    type(ray_t), target :: ray
    integer :: isad, iw
    real(wp) :: err
    rmin = 0; rmax = 0; area = 0; darea = 0
    call setup_saddle(model, saddle, angle, ball, eqs, isad, iw, stat)
    if (stat /= TUBES_OK) return
    ray%ball = ball
    ray%theta0 = angle
    ray%energy = eqs(isad)%energy + de
    call section_region(ray, 2*sqrt(sum(eqs(iw)%q**2)) + 10, stat)
    if (stat /= TUBES_OK) return
    rmin = ray%rmin
    rmax = ray%rmax
    call section_area(ray, area, err, stat)
    if (stat /= TUBES_OK) return
    call section_darea(ray, darea, err, stat)
  end function c_section_info

  !> The cut of the Lyapunov orbit's tube at excess energy de with the section (include/tubes.h).
  integer(c_int) function c_tube_cut(model, saddle, de, kind, angle, pth_sign, eps, area_tol, &
      t_max, n_init, n_max, n_segments, orb_tol, orb_rtol, orb_atol, nout, n, tau, r, pr, time, &
      xs, area, area_polygon, action, period, nhist, hist_n, hist_area, n_failed, fail_tau, local) &
      result(stat) bind(C, name='tubes_tube_cut')
    real(c_double), intent(in) :: model(NMODEL)
    character(kind=c_char), intent(in) :: saddle(8)
    real(c_double), value :: de, angle, eps, area_tol, t_max, orb_tol, orb_rtol, orb_atol
    integer(c_int), value :: kind, pth_sign, n_init, n_max, n_segments, nout, local
    integer(c_int), intent(out) :: n, nhist, hist_n(64), n_failed
    real(c_double), intent(out) :: tau(nout), r(nout), pr(nout), time(nout), xs(4, nout), area, &
                                   area_polygon, action, period, hist_area(64), fail_tau
    type(ball_t) :: ball
    type(equilibrium_t), allocatable :: eqs(:)
    type(orbit_t) :: orb
    type(tube_opts_t) :: opts
    type(tube_cut_t) :: cut
    integer :: isad, iw
    n = 0; nhist = 0; hist_n = 0; hist_area = 0; area = 0; area_polygon = 0; action = 0; period = 0
    n_failed = 0; fail_tau = 0
    call setup_saddle(model, saddle, angle, ball, eqs, isad, iw, stat)
    if (stat /= TUBES_OK) return
    call orbit_at(ball, eqs, isad, de, n_segments, orb_tol, orb_rtol, orb_atol, orb, stat, local /= 0)
    if (stat /= TUBES_OK) return
    action = orb%action
    period = orb%period
    opts%local = local /= 0
    opts%kind = kind
    opts%theta0 = angle
    opts%branch = pth_sign
    opts%eps = eps
    opts%area_tol = area_tol
    opts%t_max = t_max
    opts%n_init = n_init
    opts%n_max = min(n_max, nout)
    call tube_cut(ball, orb, eqs(iw)%q - eqs(isad)%q, opts, cut, stat)
    n_failed = cut%n_failed
    fail_tau = cut%fail_tau
    n = min(cut%n, nout)
    if (n > 0) then
      tau(1:n) = cut%tau(1:n)
      r(1:n) = cut%r(1:n)
      pr(1:n) = cut%pr(1:n)
      time(1:n) = cut%time(1:n)
      xs(:, 1:n) = cut%x(:, 1:n)
    end if
    area = cut%area
    area_polygon = cut%area_polygon
    if (allocated(cut%hist_n)) then
      nhist = min(size(cut%hist_n), 64)
      hist_n(1:nhist) = cut%hist_n(1:nhist)
      hist_area(1:nhist) = cut%hist_area(1:nhist)
    end if
  end function c_tube_cut

  !> Monte Carlo transition check at excess energy de (include/tubes.h).
  integer(c_int) function c_monte_carlo(model, saddle, de, angle, pth_sign, nsamp, seed, t_max, &
      gate, ncut, cut_r, cut_pr, r, pr, outcome, inside) result(stat) &
      bind(C, name='tubes_monte_carlo')
    real(c_double), intent(in) :: model(NMODEL)
    character(kind=c_char), intent(in) :: saddle(8)
    real(c_double), value :: de, angle, t_max, gate
    integer(c_int), value :: pth_sign, nsamp, seed, ncut
    real(c_double), intent(in) :: cut_r(ncut), cut_pr(ncut)
    real(c_double), intent(out) :: r(nsamp), pr(nsamp)
    integer(c_int), intent(out) :: outcome(nsamp), inside(nsamp)
    type(ball_t) :: ball
    type(equilibrium_t), allocatable :: eqs(:)
    type(ray_t), target :: ray
    logical :: ins(nsamp)
    integer :: isad, iw
    r = 0; pr = 0; outcome = -1; inside = 0
    call setup_saddle(model, saddle, angle, ball, eqs, isad, iw, stat)
    if (stat /= TUBES_OK) return
    ray%ball = ball
    ray%theta0 = angle
    ray%energy = eqs(isad)%energy + de
    call section_region(ray, 2*sqrt(sum(eqs(iw)%q**2)) + 10, stat)
    if (stat /= TUBES_OK) return
    call monte_carlo(ray, nsamp, int(seed, c_long), pth_sign, eqs(isad)%q(1) - gate, t_max, &
                     1.0e-10_wp, cut_r, cut_pr, r, pr, outcome, ins, stat)
    inside = merge(1, 0, ins)
  end function c_monte_carlo

  !> Poincare map of the section at excess energy de: n_seeds starts on the section (half on
  !> p_r = 0 across the region, half across p_r at the region's middle r), n_iter returns each:
  !> pts(1:2, k, j) = (r, p_r) of the k-th return of seed j (NaN after it stops returning).
  integer(c_int) function c_poincare(model, saddle, de, angle, pth_sign, n_seeds, n_iter, t_max, &
      pts) result(stat) bind(C, name='tubes_poincare')
    real(c_double), intent(in) :: model(NMODEL)
    character(kind=c_char), intent(in) :: saddle(8)
    real(c_double), value :: de, angle, t_max
    integer(c_int), value :: pth_sign, n_seeds, n_iter
    real(c_double), intent(out) :: pts(2, n_iter, n_seeds)
    type(ball_t) :: ball
    type(equilibrium_t), allocatable :: eqs(:)
    type(ray_t), target :: ray
    real(wp) :: x0(4, n_seeds), rr, pp, rmid, pm
    integer :: isad, iw, j, h, st
    pts = 0
    call setup_saddle(model, saddle, angle, ball, eqs, isad, iw, stat)
    if (stat /= TUBES_OK) return
    ray%ball = ball
    ray%theta0 = angle
    ray%energy = eqs(isad)%energy + de
    call section_region(ray, 2*sqrt(sum(eqs(iw)%q**2)) + 10, stat)
    if (stat /= TUBES_OK) return
    h = (n_seeds + 1)/2
    rmid = 0.5_wp*(ray%rmin + ray%rmax)
    pm = sqrt(max(0.0_wp, 2*(ray%energy - ball%potential(rmid*cos(angle), rmid*sin(angle)))/(5.0_wp/7)))
    do j = 1, n_seeds
      if (j <= h) then
        rr = ray%rmin + (ray%rmax - ray%rmin)*(j - 0.5_wp)/h
        pp = 0
      else
        rr = rmid
        pp = pm*(2*(j - h - 0.5_wp)/max(1, n_seeds - h) - 1)*0.98_wp
      end if
      call state_on_section(ray, rr, pp, pth_sign, x0(:, j), st)
      if (st /= TUBES_OK) x0(:, j) = [rmid*cos(angle), rmid*sin(angle), 0.0_wp, 0.0_wp]
    end do
    call poincare_map(ball, angle, pth_sign, x0, n_iter, t_max, 1.0e-10_wp, pts, stat)
  end function c_poincare

  !> Frames per track of the synthetic experiment (include/tubes.h).
  integer(c_int) function c_experiment_samples(duration, camera_rate) result(ns) &
      bind(C, name='tubes_experiment_samples')
    real(c_double), value :: duration, camera_rate
    ns = experiment_samples(duration, camera_rate)
  end function c_experiment_samples

  !> Synthetic tracking data (include/tubes.h, src/tubes_experiment.f90).
  integer(c_int) function c_synthetic_experiment(model, e_e, n_tracks, duration, camera_rate, &
      pixel, noise, de_min, de_max, box, seed, rtol, ns, t, state, energy, noisy, measured, &
      release, c_damp, n_draws) result(stat) bind(C, name='tubes_synthetic_experiment')
    real(c_double), intent(in) :: model(NMODEL)
    real(c_double), value :: e_e, duration, camera_rate, pixel, noise, de_min, de_max, box, rtol
    integer(c_int), value :: n_tracks, seed, ns
    real(c_double), intent(out) :: t(max(ns, 0)), state(4, max(ns, 0), max(n_tracks, 0)), &
      energy(max(ns, 0), max(n_tracks, 0)), noisy(2, max(ns, 0), max(n_tracks, 0)), &
      measured(2, max(ns, 0), max(n_tracks, 0)), release(3, max(n_tracks, 0)), c_damp
    integer(c_int), intent(out) :: n_draws
    type(experiment_opts_t) :: opts
    c_damp = 0
    n_draws = 0
    stat = TUBES_EINPUT
    if (n_tracks < 1 .or. ns < 1 .or. seed < 0) return
    if (ns /= experiment_samples(duration, camera_rate)) return
    opts%n_tracks = n_tracks
    opts%duration = duration
    opts%camera_rate = camera_rate
    opts%pixel = pixel
    opts%noise = noise
    opts%de_min = de_min
    opts%de_max = de_max
    opts%e_e = e_e
    opts%box = box
    opts%seed = int(seed, c_long)
    opts%rtol = rtol
    opts%atol = rtol
    call synthetic_experiment(model, opts, t, state, energy, noisy, measured, release, c_damp, &
                              n_draws, stat)
  end function c_synthetic_experiment

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
