! The f2py facade of tubes (python/tubes/_core): plain subroutines, iso_c_binding kinds,
! explicit shapes, stat first among the outputs. The tubes package (python/tubes/__init__.py)
! copies inputs and raises TubesError on stat < 0. A model is (system, params(16)) in the order
! of the library's table (src/tubes_models.f90, model_info).

subroutine model_system(k, stat, name)
  ! the name of built-in system k = 1, 2, ... (stat -1 past the last)
  use, intrinsic :: iso_c_binding, only: c_int
  use tubes_models, only: system_name, NSYSTEMS
  implicit none
  integer(c_int), intent(in) :: k
  integer(c_int), intent(out) :: stat
  character(len=32), intent(out) :: name
  name = ''
  stat = -1
  if (k < 1 .or. k > NSYSTEMS) return
  name = system_name(k)
  stat = 0
end subroutine model_system

subroutine model_info(system, stat, ndof, np, names, defaults, summary, saddle, near, sec_kind, &
                      sec_index, sec_value, sec_dir, sec_angle, gate, box, box_center)
  ! the table entry of a system (src/tubes_models.f90): names is np blocks of 16 characters
  use, intrinsic :: iso_c_binding, only: c_double, c_int
  use tubes_models, only: system_info_t, system_info, MAX_PARAMS, MAX_DOF
  implicit none
  character(len=*), intent(in) :: system
  integer(c_int), intent(out) :: stat, ndof, np, sec_index, sec_dir
  character(len=256), intent(out) :: names
  real(c_double), intent(out) :: defaults(16), near(3), sec_value, sec_angle, gate, box(3), box_center(3)
  character(len=160), intent(out) :: summary
  character(len=8), intent(out) :: saddle, sec_kind
  type(system_info_t) :: info
  integer :: k
  names = ''; defaults = 0; summary = ''; saddle = ''; near = 0; sec_kind = ''; sec_index = 0
  sec_value = 0; sec_dir = 0; sec_angle = 0; gate = 0; box = 0; box_center = 0; ndof = 0; np = 0
  call system_info(trim(system), info, stat)
  if (stat /= 0) return
  ndof = info%ndof
  np = info%np
  do k = 1, info%np
    names(16*(k - 1) + 1:16*k) = info%params(k)%name
    defaults(k) = info%params(k)%default
  end do
  summary = info%summary
  saddle = info%saddle
  near = info%saddle_near
  sec_kind = info%section_kind
  sec_index = info%section_index
  sec_value = info%section_value
  sec_dir = info%section_direction
  sec_angle = info%section_angle
  gate = info%gate
  box = info%box
  box_center = info%box_center
end subroutine model_info

subroutine energies(system, params, n, m, x, stat, e)
  ! H of m states (columns of x, n = 2N components each) of the conservative model
  use, intrinsic :: iso_c_binding, only: c_double, c_int
  use tubes_hamiltonian, only: hamiltonian_t
  use tubes_models, only: make_model
  implicit none
  character(len=*), intent(in) :: system
  integer(c_int), intent(in) :: n, m
  real(c_double), intent(in) :: params(16), x(n, m)
  integer(c_int), intent(out) :: stat
  real(c_double), intent(out) :: e(m)
  class(hamiltonian_t), allocatable :: model
  integer :: k
  e = 0
  call make_model(trim(system), params, model, stat)
  if (stat /= 0) return
  if (n /= model%dim()) then
    stat = -1
    return
  end if
  do k = 1, m
    e(k) = model%energy(x(:, k))
  end do
end subroutine energies

subroutine vector_field(system, params, n, x, stat, dxdt)
  ! Hamilton's equations (damped for the rolling ball with damping_ratio > 0)
  use, intrinsic :: iso_c_binding, only: c_double, c_int
  use tubes_field, only: vector_field_t
  use tubes_models, only: make_field
  use tubes_status, only: TUBES_EMODEL
  implicit none
  character(len=*), intent(in) :: system
  integer(c_int), intent(in) :: n
  real(c_double), intent(in) :: params(16), x(n)
  integer(c_int), intent(out) :: stat
  real(c_double), intent(out) :: dxdt(n)
  class(vector_field_t), allocatable :: field
  real(c_double) :: c
  dxdt = 0
  call make_field(trim(system), params, field, c, stat)
  if (stat /= 0) return
  if (n /= field%dim()) then
    stat = -1
    return
  end if
  call field%eval(0.0_c_double, x, dxdt, stat)
  if (stat /= 0) stat = TUBES_EMODEL
end subroutine vector_field

subroutine momentum(system, params, n, q, v, stat, p)
  ! natural systems: the momenta of velocity v at q, p = A(q)^-1 v (the ball: (7/5) M v)
  use, intrinsic :: iso_c_binding, only: c_double, c_int
  use tubes_hamiltonian, only: hamiltonian_t
  use tubes_models, only: make_model, momentum_of
  implicit none
  character(len=*), intent(in) :: system
  integer(c_int), intent(in) :: n
  real(c_double), intent(in) :: params(16), q(n), v(n)
  integer(c_int), intent(out) :: stat
  real(c_double), intent(out) :: p(n)
  class(hamiltonian_t), allocatable :: model
  p = 0
  call make_model(trim(system), params, model, stat)
  if (stat /= 0) return
  stat = -1
  if (n /= model%ndof()) return
  call momentum_of(model, q, v, p, stat)
end subroutine momentum

subroutine potentials(system, params, n, m, q, stat, v)
  ! natural systems: V at m configurations (columns of q)
  use, intrinsic :: iso_c_binding, only: c_double, c_int
  use tubes_hamiltonian, only: hamiltonian_t
  use tubes_models, only: make_model, potential_of
  implicit none
  character(len=*), intent(in) :: system
  integer(c_int), intent(in) :: n, m
  real(c_double), intent(in) :: params(16), q(n, m)
  integer(c_int), intent(out) :: stat
  real(c_double), intent(out) :: v(m)
  class(hamiltonian_t), allocatable :: model
  integer :: k
  v = 0
  call make_model(trim(system), params, model, stat)
  if (stat /= 0) return
  stat = -1
  if (n /= model%ndof()) return
  do k = 1, m
    call potential_of(model, q(:, k), v(k), stat)
    if (stat /= 0) return
  end do
end subroutine potentials

subroutine shape_derivs(system, params, n, m, q, stat, grad, hess)
  ! natural systems: gradient and Hessian of the potential's shape (the ball: of the surface's
  ! height H(x, y), V = g H) at m configurations
  use, intrinsic :: iso_c_binding, only: c_double, c_int
  use tubes_hamiltonian, only: hamiltonian_t
  use tubes_models, only: make_model, shape_derivs_of
  implicit none
  character(len=*), intent(in) :: system
  integer(c_int), intent(in) :: n, m
  real(c_double), intent(in) :: params(16), q(n, m)
  integer(c_int), intent(out) :: stat
  real(c_double), intent(out) :: grad(n, m), hess(n, n, m)
  class(hamiltonian_t), allocatable :: model
  integer :: k
  grad = 0
  hess = 0
  call make_model(trim(system), params, model, stat)
  if (stat /= 0) return
  stat = -1
  if (n /= model%ndof()) return
  do k = 1, m
    call shape_derivs_of(model, q(:, k), grad(:, k), hess(:, :, k), stat)
    if (stat /= 0) return
  end do
end subroutine shape_derivs

subroutine equilibria(system, params, lo, hi, n_grid, stat, n, ndof, q, p, height, en, morse, rank1, &
                      names, lam, om, evec)
  ! equilibria in the box [lo, hi] (first ndof entries); at most 256
  use, intrinsic :: iso_c_binding, only: c_double, c_int
  use tubes_hamiltonian, only: hamiltonian_t
  use tubes_models, only: make_model
  use tubes_equilibria, only: equilibrium_t, find_equilibria
  implicit none
  character(len=*), intent(in) :: system
  real(c_double), intent(in) :: params(16), lo(3), hi(3)
  integer(c_int), intent(in) :: n_grid
  integer(c_int), intent(out) :: stat, n, ndof
  real(c_double), intent(out) :: q(3, 256), p(3, 256), height(256), en(256), lam(256), om(2, 256), &
                                 evec(6, 6, 256)
  integer(c_int), intent(out) :: morse(256), rank1(256)
  character(len=2304), intent(out) :: names
  class(hamiltonian_t), allocatable :: model
  type(equilibrium_t), allocatable :: eqs(:)
  integer :: k, nd
  n = 0; ndof = 0; q = 0; p = 0; height = 0; en = 0; lam = 0; om = 0; evec = 0; morse = -1
  rank1 = 0; names = ''
  call make_model(trim(system), params, model, stat)
  if (stat /= 0) return
  nd = model%ndof()
  ndof = nd
  call find_equilibria(model, lo(1:nd), hi(1:nd), n_grid, eqs, stat)
  if (stat /= 0) return
  n = min(size(eqs), 256)
  do k = 1, n
    q(1:nd, k) = eqs(k)%q
    p(1:nd, k) = eqs(k)%x(nd + 1:2*nd)
    height(k) = eqs(k)%height
    en(k) = eqs(k)%energy
    morse(k) = eqs(k)%morse
    rank1(k) = merge(1, 0, eqs(k)%rank1)
    lam(k) = eqs(k)%lambda
    om(1:nd - 1, k) = eqs(k)%omegas(1:nd - 1)
    evec(1:2*nd, 1:2*nd, k) = eqs(k)%evec
    names(9*(k - 1) + 1:9*k) = eqs(k)%name
  end do
end subroutine equilibria

subroutine trajectory(system, params, n2, x0, t_end, dt_out, method, rtol, atol, h, max_steps, &
                      omega_bind, solver, max_iter, sec_kind, sec_level, sec_dir, stop_first, &
                      max_cross, nmax, stat, n, t, state, en, n_cross, cross_t, cross_x, cross_dir, &
                      counters)
  use, intrinsic :: iso_c_binding, only: c_double, c_int, c_int64_t
  use tubes_kinds, only: wp
  use tubes_hamiltonian, only: hamiltonian_t
  use tubes_models, only: make_model
  use tubes_integrator, only: crossing_log_t
  use tubes_methods, only: method_opts_t
  use tubes_run, only: run_integration, section_spec_t
  use tubes_sampler, only: sampler_t
  implicit none
  character(len=*), intent(in) :: system
  integer(c_int), intent(in) :: n2
  real(c_double), intent(in) :: params(16), x0(n2), t_end, dt_out, rtol, atol, h, omega_bind, sec_level
  integer(c_int), intent(in) :: method, nmax, solver, max_iter, sec_kind, sec_dir, stop_first, max_cross
  integer(c_int64_t), intent(in) :: max_steps
  integer(c_int), intent(out) :: stat, n, n_cross
  real(c_double), intent(out) :: t(nmax), state(n2, nmax), en(nmax)
  real(c_double), intent(out) :: cross_t(max_cross), cross_x(n2, max_cross)
  integer(c_int), intent(out) :: cross_dir(max_cross)
  integer(c_int64_t), intent(out) :: counters(4)
  class(hamiltonian_t), allocatable :: cons
  type(sampler_t) :: obs
  type(crossing_log_t) :: log
  real(c_double) :: c
  integer :: k
  n = 0; n_cross = 0; t = 0; state = 0; en = 0; counters = 0; cross_t = 0; cross_x = 0; cross_dir = 0
  stat = -1
  if (dt_out <= 0 .or. t_end < 0 .or. nmax < 2 .or. max_cross < 1) return
  call make_model(trim(system), params, cons, stat)
  if (stat /= 0) return
  if (n2 /= cons%dim()) then
    stat = -1
    return
  end if
  call obs%start(0.0_wp, dt_out, x0, nmax)
  call run_integration(trim(system), params, x0, t_end, method, rtol, atol, h, max_steps, &
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

subroutine section_boundary(system, params, lo, hi, n_grid, saddle, sec_kind, sec_index, level, &
                            dir, de, m, stat, smin, smax, s, pmin, pmax)
  ! the energy surface's boundary on a section (src/tubes_section_kinds.f90) at E_e(saddle) + de:
  ! its interval [smin, smax] and the p_s range [pmin, pmax] at m points s across it
  use, intrinsic :: iso_c_binding, only: c_double, c_int
  use tubes_hamiltonian, only: hamiltonian_t
  use tubes_equilibria, only: equilibrium_t
  use tubes_section_kinds, only: poincare_t
  use tubes_study, only: setup_section
  implicit none
  character(len=*), intent(in) :: system, saddle
  real(c_double), intent(in) :: params(16), lo(3), hi(3), level, de
  integer(c_int), intent(in) :: n_grid, sec_kind, sec_index, dir, m
  integer(c_int), intent(out) :: stat
  real(c_double), intent(out) :: smin, smax, s(m), pmin(m), pmax(m)
  class(hamiltonian_t), allocatable :: model
  type(equilibrium_t), allocatable :: eqs(:)
  type(poincare_t) :: psec
  real(c_double), allocatable :: q_ref(:)
  integer :: isad, k
  smin = 0; smax = 0; s = 0; pmin = 0; pmax = 0
  call setup_section(trim(system), params, lo, hi, n_grid, trim(saddle), sec_kind, sec_index, level, &
                     dir, de, model, eqs, isad, psec, q_ref, stat)
  if (stat /= 0) return
  smin = psec%smin
  smax = psec%smax
  do k = 1, m
    s(k) = smin + (smax - smin)*(k - 1)/max(1, m - 1)
    call psec%bounds(s(k), pmin(k), pmax(k))
  end do
end subroutine section_boundary

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
