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
                      solver, max_iter, nmax, stat, n, t, state, en, counters)
  use, intrinsic :: iso_c_binding, only: c_double, c_int, c_int64_t
  use tubes_kinds, only: wp
  use tubes_ball, only: ball_t
  use tubes_models, only: model_ball, conservative_ball
  use tubes_integrator, only: integrator_t, propagate
  use tubes_methods, only: new_integrator, method_opts_t
  use tubes_sampler, only: sampler_t
  implicit none
  real(c_double), intent(in) :: params(7), x0(4), t_end, dt_out, rtol, atol, h, omega_bind
  integer(c_int), intent(in) :: method, nmax, solver, max_iter
  integer(c_int64_t), intent(in) :: max_steps
  integer(c_int), intent(out) :: stat, n
  real(c_double), intent(out) :: t(nmax), state(4, nmax), en(nmax)
  integer(c_int64_t), intent(out) :: counters(4)
  class(ball_t), allocatable :: ball
  type(ball_t) :: cons
  class(integrator_t), allocatable :: ig
  type(sampler_t) :: obs
  real(c_double) :: x(4), c
  integer :: k
  n = 0; t = 0; state = 0; en = 0; counters = 0
  stat = -1
  if (dt_out <= 0 .or. t_end < 0 .or. nmax < 2) return
  call model_ball(params, ball, c, stat)
  if (stat /= 0) return
  call conservative_ball(params, cons, stat)
  call new_integrator(method, ig, stat, method_opts_t(omega_bind=omega_bind, solver=solver, &
                                                      max_iter=max_iter))
  if (stat /= 0) return
  call ig%init(ball, 0.0_wp)
  ig%rtol = rtol; ig%atol = atol; ig%h = h; ig%max_steps = max_steps
  x = x0
  call obs%start(0.0_wp, dt_out, x, nmax)
  if (t_end > 0) call propagate(ig, x, t_end, stat, observer=obs)
  if (stat == 1) stat = 0
  n = obs%n
  t(1:n) = obs%t(1:n)
  state(:, 1:n) = obs%x(:, 1:n)
  do k = 1, n
    en(k) = cons%energy(state(:, k))
  end do
  counters = [ig%nfev, ig%nsteps, ig%nrejected, ig%niter]
end subroutine trajectory
