! The f2py facade of tubes (python/tubes/_core): plain subroutines, iso_c_binding kinds,
! explicit shapes, stat first among the outputs. The tubes package (python/tubes/__init__.py)
! copies inputs and raises TubesError on stat < 0. Model vector: include/tubes.h.

subroutine energy(params, x, stat, e)
  use, intrinsic :: iso_c_binding, only: c_double, c_int
  use tubes_ball, only: ball_t
  use tubes_models, only: conservative_ball
  implicit none
  real(c_double), intent(in) :: params(7), x(4)
  integer(c_int), intent(out) :: stat
  real(c_double), intent(out) :: e
  type(ball_t) :: ball
  e = 0
  call conservative_ball(params, ball, stat)
  if (stat == 0) e = ball%energy(x)
end subroutine energy

subroutine vector_field(params, x, stat, dxdt)
  use, intrinsic :: iso_c_binding, only: c_double, c_int
  use tubes_ball, only: ball_t
  use tubes_models, only: model_ball
  implicit none
  real(c_double), intent(in) :: params(7), x(4)
  integer(c_int), intent(out) :: stat
  real(c_double), intent(out) :: dxdt(4)
  class(ball_t), allocatable :: ball
  real(c_double) :: c
  dxdt = 0
  call model_ball(params, ball, c, stat)
  if (stat /= 0) return
  call ball%eval(0.0_c_double, x, dxdt, stat)
  if (stat /= 0) stat = -4
end subroutine vector_field

subroutine momentum(params, q, v, stat, p)
  use, intrinsic :: iso_c_binding, only: c_double, c_int
  use tubes_ball, only: ball_t
  use tubes_models, only: conservative_ball
  implicit none
  real(c_double), intent(in) :: params(7), q(2), v(2)
  integer(c_int), intent(out) :: stat
  real(c_double), intent(out) :: p(2)
  type(ball_t) :: ball
  p = 0
  call conservative_ball(params, ball, stat)
  if (stat == 0) p = ball%momentum(q, v)
end subroutine momentum

subroutine velocity(params, x, stat, v)
  use, intrinsic :: iso_c_binding, only: c_double, c_int
  use tubes_ball, only: ball_t
  use tubes_models, only: conservative_ball
  implicit none
  real(c_double), intent(in) :: params(7), x(4)
  integer(c_int), intent(out) :: stat
  real(c_double), intent(out) :: v(2)
  type(ball_t) :: ball
  v = 0
  call conservative_ball(params, ball, stat)
  if (stat == 0) v = ball%velocity(x)
end subroutine velocity

subroutine equilibria(params, box, n_grid, stat, n, x, y, height, en, morse, names, lam, om, evec)
  use, intrinsic :: iso_c_binding, only: c_double, c_int
  use tubes_ball, only: ball_t
  use tubes_models, only: conservative_ball
  use tubes_equilibria, only: equilibrium_t, find_equilibria
  implicit none
  real(c_double), intent(in) :: params(7), box
  integer(c_int), intent(in) :: n_grid
  integer(c_int), intent(out) :: stat, n
  real(c_double), intent(out) :: x(64), y(64), height(64), en(64), lam(64), om(64), evec(4, 4, 64)
  integer(c_int), intent(out) :: morse(64)
  character(len=640), intent(out) :: names
  type(ball_t) :: ball
  type(equilibrium_t), allocatable :: eqs(:)
  integer :: k
  n = 0; x = 0; y = 0; height = 0; en = 0; lam = 0; om = 0; evec = 0; morse = -1; names = ''
  call conservative_ball(params, ball, stat)
  if (stat /= 0) return
  call find_equilibria(ball, box, n_grid, eqs, stat)
  if (stat /= 0) return
  n = min(size(eqs), 64)
  do k = 1, n
    x(k) = eqs(k)%q(1); y(k) = eqs(k)%q(2)
    height(k) = eqs(k)%height; en(k) = eqs(k)%energy; morse(k) = eqs(k)%morse
    lam(k) = eqs(k)%lambda; om(k) = eqs(k)%omega; evec(:, :, k) = eqs(k)%evec
    names = trim(names)//' '//trim(eqs(k)%name)
  end do
end subroutine equilibria

subroutine trajectory(params, x0, t_end, dt_out, method, rtol, atol, h, max_steps, omega_bind, &
                      solver, max_iter, sec_kind, sec_level, sec_dir, stop_first, max_cross, nmax, &
                      stat, n, t, state, en, n_cross, cross_t, cross_x, cross_dir, counters)
  use, intrinsic :: iso_c_binding, only: c_double, c_int, c_int64_t
  use tubes_kinds, only: wp
  use tubes_ball, only: ball_t
  use tubes_models, only: conservative_ball
  use tubes_integrator, only: crossing_log_t
  use tubes_methods, only: method_opts_t
  use tubes_run, only: run_integration, section_spec_t
  use tubes_sampler, only: sampler_t
  implicit none
  real(c_double), intent(in) :: params(7), x0(4), t_end, dt_out, rtol, atol, h, omega_bind, sec_level
  integer(c_int), intent(in) :: method, nmax, solver, max_iter, sec_kind, sec_dir, stop_first, max_cross
  integer(c_int64_t), intent(in) :: max_steps
  integer(c_int), intent(out) :: stat, n, n_cross
  real(c_double), intent(out) :: t(nmax), state(4, nmax), en(nmax)
  real(c_double), intent(out) :: cross_t(max_cross), cross_x(4, max_cross)
  integer(c_int), intent(out) :: cross_dir(max_cross)
  integer(c_int64_t), intent(out) :: counters(4)
  type(ball_t) :: cons
  type(sampler_t) :: obs
  type(crossing_log_t) :: log
  real(c_double) :: c
  integer :: k
  n = 0; n_cross = 0; t = 0; state = 0; en = 0; counters = 0; cross_t = 0; cross_x = 0; cross_dir = 0
  stat = -1
  if (dt_out <= 0 .or. t_end < 0 .or. nmax < 2 .or. max_cross < 1) return
  call conservative_ball(params, cons, stat)
  if (stat /= 0) return
  call obs%start(0.0_wp, dt_out, x0, nmax)
  call run_integration(params, x0, t_end, method, rtol, atol, h, max_steps, &
                       method_opts_t(omega_bind=omega_bind, solver=solver, max_iter=max_iter), &
                       section_spec_t(kind=sec_kind, level=sec_level, dir=sec_dir, &
                                      stop_at_first=stop_first /= 0, max_crossings=max_cross), &
                       obs, log, counters, c, stat)
  n = obs%n
  t(1:n) = obs%t(1:n)
  state(:, 1:n) = obs%x(:, 1:n)
  do k = 1, n
    en(k) = cons%energy(state(:, k))
  end do
  if (sec_kind /= 0) then
    n_cross = min(log%n, max_cross)
    do k = 1, n_cross
      cross_t(k) = log%t(k)
      cross_x(:, k) = log%x(:, k)
      cross_dir(k) = log%direction(k)
    end do
  end if
end subroutine trajectory

subroutine reference_solution(params, x0, t_end, tol, stat, x_end, nsteps, nfev)
  use, intrinsic :: iso_c_binding, only: c_double, c_int, c_int64_t
  use tubes_reference, only: ref => reference_solution
  implicit none
  real(c_double), intent(in) :: params(7), x0(4), t_end, tol
  integer(c_int), intent(out) :: stat
  real(c_double), intent(out) :: x_end(4)
  integer(c_int64_t), intent(out) :: nsteps, nfev
  call ref(params, x0, t_end, tol, x_end, stat, nsteps, nfev)
end subroutine reference_solution

subroutine differentiate_spectral(x, n, dt, cutoff, rolloff, edge, end_order, end_window, stat, v, xs)
  ! tubes_differentiate: diff_spectral. edge 0 periodic, 1 odd, 2 mirror; end_window <= 0: default
  use, intrinsic :: iso_c_binding, only: c_double, c_int
  use tubes_differentiate, only: diff_spectral
  implicit none
  integer(c_int), intent(in) :: n
  real(c_double), intent(in) :: x(n), dt, cutoff, rolloff
  integer(c_int), intent(in) :: edge, end_order, end_window
  integer(c_int), intent(out) :: stat
  real(c_double), intent(out) :: v(n), xs(n)
  if (end_window > 0) then
    call diff_spectral(x, dt, cutoff, rolloff, edge, v, xs, stat, end_order=end_order, &
                       end_window=end_window)
  else
    call diff_spectral(x, dt, cutoff, rolloff, edge, v, xs, stat, end_order=end_order)
  end if
end subroutine differentiate_spectral

subroutine differentiate_savgol(x, n, dt, order, window, stat, v, xs)
  ! tubes_differentiate: diff_savgol (window odd, 1 <= order < window <= n)
  use, intrinsic :: iso_c_binding, only: c_double, c_int
  use tubes_differentiate, only: diff_savgol
  implicit none
  integer(c_int), intent(in) :: n
  real(c_double), intent(in) :: x(n), dt
  integer(c_int), intent(in) :: order, window
  integer(c_int), intent(out) :: stat
  real(c_double), intent(out) :: v(n), xs(n)
  call diff_savgol(x, dt, order, window, v, xs, stat)
end subroutine differentiate_savgol
