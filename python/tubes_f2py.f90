! The f2py facade of tubes (python/tubes/_core): plain subroutines, iso_c_binding kinds,
! explicit shapes, stat first among the outputs. The tubes package (python/tubes/__init__.py)
! copies inputs and raises TubesError on stat < 0. A model is (system, params(16)) in the order
! of the library's table (src/models/tubes_models.f90, model_info). What the C API does too is
! one routine of src/workflow (tubes_run, tubes_study) that both call.

subroutine model_system(k, stat, name)
  ! the name of built-in system k = 1, 2, ... (stat TUBES_EINPUT past the last)
  use, intrinsic :: iso_c_binding, only: c_int
  use tubes_models, only: system_name, NSYSTEMS
  use tubes_status, only: TUBES_EINPUT
  implicit none
  integer(c_int), intent(in) :: k
  integer(c_int), intent(out) :: stat
  character(len=32), intent(out) :: name
  name = ''
  stat = TUBES_EINPUT
  if (k < 1 .or. k > NSYSTEMS) return
  name = system_name(k)
  stat = 0
end subroutine model_system

subroutine model_info(system, stat, ndof, np, names, units, docs, defaults, summary, saddle, near, &
                      sec_kind, sec_index, sec_value, sec_dir, sec_angle, gate, box, box_center, &
                      length_units)
  ! the table entry of a system (src/models/tubes_models.f90): names np blocks of 24 characters
  ! (LEN_PARAM), units of 16, docs of 96
  use, intrinsic :: iso_c_binding, only: c_double, c_int
  use tubes_models, only: system_info_t, system_info
  use tubes_capi, only: scene_defaults
  implicit none
  character(len=*), intent(in) :: system
  integer(c_int), intent(out) :: stat, ndof, np, sec_index, sec_dir
  character(len=384), intent(out) :: names
  character(len=256), intent(out) :: units
  character(len=1536), intent(out) :: docs
  character(len=8), intent(out) :: length_units
  real(c_double), intent(out) :: defaults(16), near(3), sec_value, sec_angle, gate, box(3), box_center(3)
  character(len=160), intent(out) :: summary
  character(len=8), intent(out) :: saddle, sec_kind
  type(system_info_t) :: info
  integer :: k
  names = ''; units = ''; docs = ''; length_units = ''; defaults = 0; summary = ''; saddle = ''
  near = 0; sec_kind = ''; sec_index = 0
  sec_value = 0; sec_dir = 0; sec_angle = 0; gate = 0; box = 0; box_center = 0; ndof = 0; np = 0
  call system_info(trim(system), info, stat)
  if (stat /= 0) return
  ndof = info%ndof
  np = info%np
  do k = 1, info%np
    names(24*(k - 1) + 1:24*k) = info%params(k)%name
    units(16*(k - 1) + 1:16*k) = info%params(k)%units
    docs(96*(k - 1) + 1:96*k) = info%params(k)%doc
    defaults(k) = info%params(k)%default
  end do
  summary = info%summary
  saddle = info%saddle
  sec_kind = info%section_kind
  length_units = info%length_units
  call scene_defaults(info, box, box_center, near, sec_index, sec_value, sec_dir, sec_angle, gate)
end subroutine model_info

subroutine energies(system, params, n, m, x, stat, e)
  ! H of m states (columns of x, n = 2N components each) of the conservative model
  use, intrinsic :: iso_c_binding, only: c_double, c_int
  use tubes_hamiltonian, only: hamiltonian_t
  use tubes_run, only: sized_model
  implicit none
  character(len=*), intent(in) :: system
  integer(c_int), intent(in) :: n, m
  real(c_double), intent(in) :: params(16), x(n, m)
  integer(c_int), intent(out) :: stat
  real(c_double), intent(out) :: e(m)
  class(hamiltonian_t), allocatable :: model
  integer :: k
  e = 0
  call sized_model(system, params, n, .false., model, stat)
  if (stat /= 0) return
  do k = 1, m
    e(k) = model%energy(x(:, k))
  end do
end subroutine energies

subroutine vector_field(system, params, n, m, x, stat, dxdt)
  ! Hamilton's equations (damped for the rolling ball with damping_ratio > 0) at m states
  ! (columns of x), the model made once
  use, intrinsic :: iso_c_binding, only: c_double, c_int
  use tubes_run, only: field_rates
  implicit none
  character(len=*), intent(in) :: system
  integer(c_int), intent(in) :: n, m
  real(c_double), intent(in) :: params(16), x(n, m)
  integer(c_int), intent(out) :: stat
  real(c_double), intent(out) :: dxdt(n, m)
  call field_rates(system, params, x, dxdt, stat)
end subroutine vector_field

subroutine momentum(system, params, n, m, q, v, stat, p)
  ! natural systems: the momenta of velocity v at q, p = A(q)^-1 v (the ball: (7/5) M v), at m
  ! configurations (columns of q and v), the model made once
  use, intrinsic :: iso_c_binding, only: c_double, c_int
  use tubes_hamiltonian, only: hamiltonian_t
  use tubes_models, only: momentum_of
  use tubes_run, only: sized_model
  implicit none
  character(len=*), intent(in) :: system
  integer(c_int), intent(in) :: n, m
  real(c_double), intent(in) :: params(16), q(n, m), v(n, m)
  integer(c_int), intent(out) :: stat
  real(c_double), intent(out) :: p(n, m)
  class(hamiltonian_t), allocatable :: model
  integer :: k
  p = 0
  call sized_model(system, params, n, .true., model, stat)
  if (stat /= 0) return
  do k = 1, m
    call momentum_of(model, q(:, k), v(:, k), p(:, k), stat)
    if (stat /= 0) return
  end do
end subroutine momentum

subroutine potentials(system, params, n, m, q, stat, v)
  ! natural systems: V at m configurations (columns of q)
  use, intrinsic :: iso_c_binding, only: c_double, c_int
  use tubes_hamiltonian, only: hamiltonian_t
  use tubes_models, only: potential_of
  use tubes_run, only: sized_model
  use tubes_status, only: TUBES_EINPUT
  implicit none
  character(len=*), intent(in) :: system
  integer(c_int), intent(in) :: n, m
  real(c_double), intent(in) :: params(16), q(n, m)
  integer(c_int), intent(out) :: stat
  real(c_double), intent(out) :: v(m)
  class(hamiltonian_t), allocatable :: model
  integer :: k
  v = 0
  call sized_model(system, params, n, .true., model, stat)
  if (stat /= 0) return
  if (m < 1) stat = TUBES_EINPUT   ! no configurations (m = 0): invalid input, tubes.potentials raises
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
  use tubes_models, only: shape_derivs_of
  use tubes_run, only: sized_model
  use tubes_status, only: TUBES_EINPUT
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
  call sized_model(system, params, n, .true., model, stat)
  if (stat /= 0) return
  if (m < 1) stat = TUBES_EINPUT   ! no configurations (m = 0): invalid input, tubes.potentials raises
  do k = 1, m
    call shape_derivs_of(model, q(:, k), grad(:, k), hess(:, :, k), stat)
    if (stat /= 0) return
  end do
end subroutine shape_derivs

subroutine equilibria(system, params, lo, hi, n_grid, stores, stat, n, ndof, q, p, height, en, grad, &
                      morse, rank1, names, lam, om, evec)
  ! equilibria in the box [lo, hi] (first ndof entries), as the C API's tubes_find_equilibria
  ! (tubes_study equilibria_table; evec by columns, 4 ndof^2 each); at most 256 (more:
  ! stat -1, TUBES_EINPUT, as the C API's nmax; find_equilibria refuses more than 256 itself). stores:
  ! stores_open's handle (a search kept there is not repeated), or 0
  use, intrinsic :: iso_c_binding, only: c_double, c_int, c_int64_t
  use tubes_hamiltonian, only: hamiltonian_t
  use tubes_models, only: make_model
  use tubes_equilibria, only: equilibrium_t
  use tubes_study, only: equilibria_of, equilibria_table, seed_stores_t, stores_at
  implicit none
  character(len=*), intent(in) :: system
  real(c_double), intent(in) :: params(16), lo(3), hi(3)
  integer(c_int), intent(in) :: n_grid
  integer(c_int64_t), intent(in) :: stores
  integer(c_int), intent(out) :: stat, n, ndof
  real(c_double), intent(out) :: q(3, 256), p(3, 256), height(256), en(256), grad(256), lam(256), &
                                 om(2, 256), evec(36, 256)
  integer(c_int), intent(out) :: morse(256), rank1(256)
  character(len=2304), intent(out) :: names
  class(hamiltonian_t), allocatable :: model
  type(equilibrium_t), allocatable :: eqs(:)
  type(seed_stores_t), pointer :: kept
  integer :: k, nd
  n = 0; ndof = 0; q = 0; p = 0; height = 0; en = 0; grad = 0; lam = 0; om = 0; evec = 0; morse = -1
  rank1 = 0; names = ''
  call make_model(trim(system), params, model, stat)
  if (stat /= 0) return
  nd = model%ndof()
  ndof = nd
  kept => stores_at(stores)
  call equilibria_of(trim(system), params, lo, hi, n_grid, model, eqs, stat, kept)
  if (stat /= 0) return
  if (size(eqs) > 256) then      ! refuse, as the C API does past nmax: never truncate
    stat = -1
    return
  end if
  n = size(eqs)
  call equilibria_table(eqs, nd, q, p, height, en, grad, morse, rank1, lam, om, evec)
  do k = 1, n
    names(9*(k - 1) + 1:9*k) = eqs(k)%name
  end do
end subroutine equilibria

subroutine trajectory(system, params, n2, x0, t_end, dt_out, method, rtol, atol, h, max_steps, &
                      omega_bind, solver, max_iter, sec_kind, sec_level, sec_dir, stop_first, &
                      max_cross, nmax, stat, n, t, state, en, n_cross, cross_t, cross_x, cross_dir, &
                      counters)
  use, intrinsic :: iso_c_binding, only: c_double, c_int, c_int64_t
  use tubes_kinds, only: wp
  use tubes_methods, only: method_opts_t
  use tubes_run, only: run_trajectory, section_spec_t
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
  type(sampler_t) :: obs
  real(c_double) :: c
  call run_trajectory(trim(system), params, x0, t_end, dt_out, method, rtol, atol, h, max_steps, &
                      method_opts_t(omega_bind=omega_bind, solver=solver, max_iter=max_iter), &
                      section_spec_t(kind=sec_kind, level=sec_level, dir=sec_dir, &
                                     stop_at_first=stop_first /= 0, max_crossings=max_cross), &
                      obs, n, t, state, en, n_cross, cross_t, cross_x, cross_dir, counters, c, stat)
end subroutine trajectory

subroutine integrator_trajectory(handle, n2, x0, t_end, dt_out, sec_kind, sec_level, sec_dir, stop_first, &
                                 max_cross, nmax, stat, n, t, state, en, n_cross, cross_t, cross_x, cross_dir, &
                                 counters)
  ! trajectory's integration with kept integrator handle (tubes.integrate's cache): the same outputs
  use, intrinsic :: iso_c_binding, only: c_double, c_int, c_int64_t
  use tubes_run, only: trajectory_kept, section_spec_t
  use tubes_sampler, only: sampler_t
  implicit none
  integer(c_int64_t), intent(in) :: handle
  integer(c_int), intent(in) :: n2
  real(c_double), intent(in) :: x0(n2), t_end, dt_out, sec_level
  integer(c_int), intent(in) :: nmax, sec_kind, sec_dir, stop_first, max_cross
  integer(c_int), intent(out) :: stat, n, n_cross
  real(c_double), intent(out) :: t(nmax), state(n2, nmax), en(nmax)
  real(c_double), intent(out) :: cross_t(max_cross), cross_x(n2, max_cross)
  integer(c_int), intent(out) :: cross_dir(max_cross)
  integer(c_int64_t), intent(out) :: counters(4)
  type(sampler_t) :: obs
  call trajectory_kept(handle, x0, t_end, dt_out, section_spec_t(kind=sec_kind, level=sec_level, dir=sec_dir, &
                       stop_at_first=stop_first /= 0, max_crossings=max_cross), obs, n, t, state, en, n_cross, &
                       cross_t, cross_x, cross_dir, counters, stat)
end subroutine integrator_trajectory

subroutine integrator_open(system, params, method, rtol, atol, h, max_steps, omega_bind, solver, &
                           max_iter, handle, stat)
  ! a kept integrator (src/workflow/tubes_run.f90 open_integrator): Python's tubes.Integrator
  use, intrinsic :: iso_c_binding, only: c_double, c_int, c_int64_t
  use tubes_methods, only: method_opts_t
  use tubes_run, only: open_integrator
  implicit none
  character(len=*), intent(in) :: system
  real(c_double), intent(in) :: params(16), rtol, atol, h, omega_bind
  integer(c_int), intent(in) :: method, solver, max_iter
  integer(c_int64_t), intent(in) :: max_steps
  integer(c_int64_t), intent(out) :: handle        ! the integrator's address, owned by the caller
  integer(c_int), intent(out) :: stat
  call open_integrator(trim(system), params, method, rtol, atol, h, max_steps, &
                       method_opts_t(omega_bind=omega_bind, solver=solver, max_iter=max_iter), handle, stat)
end subroutine integrator_open

subroutine integrator_propagate(handle, n2, x0, t_end, x, counters, stat)
  ! x0 from t = 0 to t_end with kept integrator handle: the state x reached, the call's counters
  use, intrinsic :: iso_c_binding, only: c_double, c_int, c_int64_t
  use tubes_run, only: propagate_kept
  implicit none
  integer(c_int64_t), intent(in) :: handle
  integer(c_int), intent(in) :: n2
  real(c_double), intent(in) :: x0(n2), t_end
  real(c_double), intent(out) :: x(n2)
  integer(c_int64_t), intent(out) :: counters(4)
  integer(c_int), intent(out) :: stat
  x = x0
  call propagate_kept(handle, x, t_end, counters, stat)
end subroutine integrator_propagate

subroutine integrator_close(handle)
  use, intrinsic :: iso_c_binding, only: c_int64_t
  use tubes_run, only: close_integrator
  implicit none
  integer(c_int64_t), intent(in) :: handle
  call close_integrator(handle)
end subroutine integrator_close

subroutine stores_open(handle)
  ! a new, empty set of stores (src/workflow/tubes_study.f90): Python's tubes.Model keeps one, so
  ! that its calls take the equilibria, orbit families and tube seeds its earlier calls computed
  use, intrinsic :: iso_c_binding, only: c_int64_t
  use tubes_study, only: open_stores
  implicit none
  integer(c_int64_t), intent(out) :: handle        ! the stores' address, owned by the caller
  call open_stores(handle)
end subroutine stores_open

subroutine stores_close(handle)
  use, intrinsic :: iso_c_binding, only: c_int64_t
  use tubes_study, only: close_stores
  implicit none
  integer(c_int64_t), intent(in) :: handle
  call close_stores(handle)
end subroutine stores_close

subroutine stores_counts(handle, n_eqs, n_families, n_seeds)
  ! what the stores keep: equilibria searches, orbit families, tube-seed set-ups
  use, intrinsic :: iso_c_binding, only: c_int, c_int64_t
  use tubes_study, only: counts => stores_counts
  implicit none
  integer(c_int64_t), intent(in) :: handle
  integer(c_int), intent(out) :: n_eqs, n_families, n_seeds
  call counts(handle, n_eqs, n_families, n_seeds)
end subroutine stores_counts

subroutine ensemble(system, params, n2, m, x0, t_end, method, rtol, atol, h, max_steps, omega_bind, &
                    solver, max_iter, threads, stat, xs, st, nsteps)
  ! many integrations of one model from t = 0 to t_end (src/workflow/tubes_run.f90 run_ensemble)
  use, intrinsic :: iso_c_binding, only: c_double, c_int, c_int64_t
  use tubes_methods, only: method_opts_t
  use tubes_run, only: run_ensemble
  implicit none
  character(len=*), intent(in) :: system
  integer(c_int), intent(in) :: n2, m, method, solver, max_iter, threads
  real(c_double), intent(in) :: params(16), x0(n2, m), t_end, rtol, atol, h, omega_bind
  integer(c_int64_t), intent(in) :: max_steps
  integer(c_int), intent(out) :: stat, st(m)
  real(c_double), intent(out) :: xs(n2, m)
  integer(c_int64_t), intent(out) :: nsteps(m)
  call run_ensemble(trim(system), params, x0, t_end, method, rtol, atol, h, max_steps, &
                    method_opts_t(omega_bind=omega_bind, solver=solver, max_iter=max_iter), threads, &
                    xs, st, nsteps, stat)
end subroutine ensemble

subroutine section_boundary(system, params, lo, hi, n_grid, saddle, sec_kind, sec_index, level, &
                            dir, de, m, stat, smin, smax, s, pmin, pmax)
  ! the energy surface's boundary on a section (src/transport/tubes_section_kinds.f90) at E_e(saddle) + de:
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
  real(c_double), intent(in) :: params(10), x0(4), t_end, tol
  integer(c_int), intent(out) :: stat
  real(c_double), intent(out) :: x_end(4)
  integer(c_int64_t), intent(out) :: nsteps, nfev
  call ref(params, x0, t_end, tol, x_end, stat, nsteps, nfev)
end subroutine reference_solution

subroutine differentiate_spectral(x, n, dt, cutoff, rolloff, edge, end_order, end_window, stat, v, xs)
  ! tubes_differentiate: diff_spectral. edge 0 periodic, 1 odd, 2 mirror; end_window <= 0: default
  use, intrinsic :: iso_c_binding, only: c_double, c_int
  ! (the FFTW plans kept for the Python session: tubes_differentiate's fft_plans_t)
  use tubes_differentiate, only: diff_spectral, fft_plans_t
  implicit none
  integer(c_int), intent(in) :: n
  real(c_double), intent(in) :: x(n), dt, cutoff, rolloff
  integer(c_int), intent(in) :: edge, end_order, end_window
  integer(c_int), intent(out) :: stat
  real(c_double), intent(out) :: v(n), xs(n)
  type(fft_plans_t), save :: plans
  if (end_window > 0) then
    call diff_spectral(x, dt, cutoff, rolloff, edge, v, xs, stat, end_order=end_order, &
                       end_window=end_window, plans=plans)
  else
    call diff_spectral(x, dt, cutoff, rolloff, edge, v, xs, stat, end_order=end_order, plans=plans)
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

subroutine read_input(path, stat, msg, system, lo, hi, n_grid, saddle, use_near, near, n_segments, &
                      sec_kind, sec_index, sec_level, sec_dir, tra_area_tol, mc_t_max, mc_gate, &
                      pm_n_seeds, pm_n_iter, pm_t_max, method, h, omega_bind, solver, int_max_iter, &
                      orb_family, expr_lib, exp_rolling_resistance, mc_n_samples, mc_seed, mc_de, &
                      des, ndes, nconfig, config)
  ! an input file read and validated as the program reads it (nml_load: the lexer, the namelist
  ! reader src/io/tubes_nml.f90, the validator), with the system's defaults filled in: Python's
  ! scene calls take their defaults and their checks from here; msg holds the messages; config the
  ! settings themselves (nconfig = settings_size() bytes), as the scenes take them
  use, intrinsic :: iso_c_binding, only: c_double, c_int, c_char
  use tubes_cstrings, only: c_to_f, f_to_c
  use tubes_config, only: tubes_config_t
  use tubes_kinds, only: PI
  implicit none
  character(len=*), intent(in) :: path
  integer(c_int), intent(out) :: stat, n_grid, use_near, n_segments, sec_kind, sec_index, sec_dir, &
                                 pm_n_seeds, pm_n_iter, method, solver, int_max_iter, orb_family
  character(len=1024), intent(out) :: expr_lib
  real(c_double), intent(out) :: exp_rolling_resistance
  ! &montecarlo's n_samples, seed and de; the lists of excess energies of &orbits, &tubes,
  ! &transition, &sections and &flux (columns 1..5, each with its length in ndes)
  integer(c_int), intent(out) :: mc_n_samples, mc_seed, ndes(5)
  real(c_double), intent(out) :: mc_de, des(256, 5)
  integer(c_int), intent(in) :: nconfig
  integer(1), intent(out) :: config(nconfig)
  character(len=2048), intent(out) :: msg
  character(len=32), intent(out) :: system
  character(len=8), intent(out) :: saddle
  real(c_double), intent(out) :: lo(3), hi(3), near(3), sec_level, tra_area_tol, mc_t_max, mc_gate, pm_t_max, h, &
                                 omega_bind
  interface
    integer(c_int) function method_code(name) bind(C, name='tubes_method_code')
      import :: c_int, c_char
      character(kind=c_char), intent(in) :: name(*)
    end function method_code
    integer(c_int) function input_check(p, cfg, m, mlen) bind(C, name='tubes_input_check')
      import :: c_int, c_char, tubes_config_t
      character(kind=c_char), intent(in) :: p(*)
      type(tubes_config_t), intent(out) :: cfg
      integer(c_int), value :: mlen
      character(kind=c_char), intent(out) :: m(mlen)
    end function input_check
  end interface
  type(tubes_config_t) :: cfg
  character(kind=c_char) :: cpath(len_trim(path) + 1), cmsg(2048)
  call f_to_c(path, cpath)
  stat = input_check(cpath, cfg, cmsg, 2048)
  msg = c_to_f(cmsg)
  system = c_to_f(cfg%model)   ! the library's name of the model (expr_<hash> for a formula)
  lo = cfg%box_lo
  hi = cfg%box_hi
  n_grid = cfg%n_grid
  saddle = c_to_f(cfg%orb_saddle)
  use_near = cfg%orb_use_near
  near = cfg%orb_saddle_near
  n_segments = merge(cfg%orb_n_segments, 1, c_to_f(cfg%orb_method) == 'multiple')
  if (c_to_f(cfg%sec_kind) == 'ray') then
    sec_kind = 1
    sec_index = 0
    sec_level = cfg%sec_angle*PI/180
    sec_dir = cfg%sec_pth_sign
  else if (c_to_f(cfg%sec_kind) == 'plane') then
    sec_kind = 2
    sec_index = cfg%sec_index
    sec_level = cfg%sec_value
    sec_dir = cfg%sec_direction
  else
    sec_kind = 0
    sec_index = 0
    sec_level = 0
    sec_dir = 0
  end if
  tra_area_tol = cfg%tra_area_tol
  mc_t_max = cfg%mc_t_max
  mc_gate = cfg%mc_gate
  pm_n_seeds = cfg%pm_n_seeds
  pm_n_iter = cfg%pm_n_iter
  pm_t_max = cfg%pm_t_max
  method = method_code(cfg%method)
  h = cfg%h
  omega_bind = cfg%omega_bind
  solver = merge(2, 1, c_to_f(cfg%solver) == 'fixed_point')
  int_max_iter = cfg%max_iter
  orb_family = cfg%orb_family
  expr_lib = c_to_f(cfg%expr_lib)   ! a formula model's library file ('' for a built-in)
  exp_rolling_resistance = cfg%exp_rolling_resistance
  mc_n_samples = cfg%mc_n_samples
  mc_seed = cfg%mc_seed
  mc_de = cfg%mc_de
  des = 0
  des(:, 1) = cfg%orb_de
  des(:, 2) = cfg%tub_de
  des(:, 3) = cfg%tra_de
  des(:, 4) = cfg%pm_de
  des(:, 5) = cfg%flux_de
  ndes = [cfg%orb_nde, cfg%tub_nde, cfg%tra_nde, cfg%pm_nde, cfg%flux_nde]
  config = 0
  if (nconfig == size(transfer(cfg, config))) config = transfer(cfg, config)
end subroutine read_input

subroutine settings_size(n)
  ! the size of the settings (read_input's config) in bytes
  use tubes_settings, only: settings_bytes
  implicit none
  integer, intent(out) :: n
  n = settings_bytes()
end subroutine settings_size

subroutine orbit_family(system, params, lo, hi, n_grid, saddle, nde, des, n_segments, family, tol, rtol, &
                        atol, max_iter, nsamp, method, h, omega_bind, solver, int_max_iter, stores, &
                        nguess, guess, guess_period, stat, energy, period, action, mu_u, mu_s, mu_triv, stab, &
                        residual, closure, &
                        iterations, converged, mindist, monodromy, history, state0, ts, xs, end_de, &
                        end_reason)
  ! the Lyapunov family of a saddle (as the orbits scene and the C API's tubes_orbit_family: the
  ! same tables, tubes_study family_table), on the family's path in stores
  use, intrinsic :: iso_c_binding, only: c_double, c_int, c_int64_t
  use tubes_hamiltonian, only: hamiltonian_t
  use tubes_equilibria, only: equilibrium_t
  use tubes_orbits, only: orbit_t, orbit_opts_t
  use tubes_study, only: study_t, study_family, family_table, seed_stores_t, stores_at
  use tubes_capi, only: integ_of, guess_opts
  implicit none
  character(len=*), intent(in) :: system, saddle
  integer(c_int), intent(in) :: n_grid, nde, n_segments, family, max_iter, nsamp, method, solver, int_max_iter
  real(c_double), intent(in) :: h, omega_bind
  real(c_double), intent(in) :: params(16), lo(3), hi(3), des(nde), tol, rtol, atol
  integer(c_int64_t), intent(in) :: stores
  integer(c_int), intent(in) :: nguess          ! &orbits guess: its values (0: none), and period
  real(c_double), intent(in) :: guess(6), guess_period
  integer(c_int), intent(out) :: stat, iterations(nde), converged(nde), end_reason
  real(c_double), intent(out) :: energy(nde), period(nde), action(nde), mu_u(nde), mu_s(nde), &
                                 mu_triv(4, nde), stab(nde), residual(nde), closure(nde), mindist(nde), &
                                 monodromy(36, nde), history(max_iter, nde), state0(6, nde), &
                                 ts(nsamp, nde), xs(6, nsamp, nde), end_de
  class(hamiltonian_t), allocatable :: model
  type(equilibrium_t), allocatable :: eqs(:)
  type(orbit_opts_t) :: opts
  type(orbit_t) :: orbs(nde)
  type(seed_stores_t), pointer :: kept
  integer :: isad, reason
  energy = 0; period = 0; action = 0; mu_u = 0; mu_s = 0; mu_triv = 0; stab = 0; residual = 0
  closure = 0; mindist = 0; monodromy = 0; history = 0; iterations = 0; converged = 0; state0 = 0
  ts = 0; xs = 0; end_de = -1; end_reason = 0
  opts = orbit_opts_t(n_segments=n_segments, tol=tol, rtol=rtol, atol=atol, max_iter=max_iter, n_samples=nsamp, &
                      family=family, integ=integ_of(method, h, omega_bind, solver, int_max_iter))
  call guess_opts(nguess, guess, guess_period, opts)   ! (and family 'branch:K', as the C API's)
  kept => stores_at(stores)
  call study_family(study_t(system=system, params=params, lo=lo, hi=hi, n_grid=n_grid, saddle=saddle, &
                            integ=opts%integ), des, opts, model, eqs, isad, orbs, end_de, reason, stat, kept)
  end_reason = reason
  if (stat < 0) return
  call family_table(orbs, eqs(isad)%energy, des, model%dim(), energy, period, action, state0, mu_u, mu_s, &
                    mu_triv, stab, residual, closure, iterations, converged, mindist, monodromy, ts, xs, &
                    history)
end subroutine orbit_family

subroutine tube_cut(system, params, lo, hi, n_grid, saddle, n_segments, family, orb_tol, orb_rtol, orb_atol, &
                    sec_kind, sec_index, level, dir, de, kind, eps, area_tol, t_max, n_init, n_max, &
                    method, h, omega_bind, solver, int_max_iter, stores, stat, n, tau, r, pr, time, &
                    xs, area, area_polygon, action, period, n_failed, nhist, hist_n, hist_area, floquet, sigma)
  ! the cut of the tube of the saddle's orbit of family `family` (as &orbits family) at de with the
  ! section (as the tubes scene; 3 DOF: a plane); its refinement history: the points and area after
  ! each of nhist rounds; xs(1:2N, :) the states, floquet(1:2N) and sigma the step-off's eigenvector
  ! and branch
  use, intrinsic :: iso_c_binding, only: c_double, c_int, c_int64_t
  use tubes_orbits, only: orbit_t
  use tubes_manifold, only: tube_cut_t
  use tubes_study, only: study_t, section_choice_t, cut_at, cut_outputs, seed_stores_t, stores_at
  use tubes_capi, only: integ_of, tube_opts_of
  implicit none
  character(len=*), intent(in) :: system, saddle
  integer(c_int), intent(in) :: n_grid, n_segments, family, sec_kind, sec_index, dir, kind, n_init, n_max, &
                                method, solver, int_max_iter
  real(c_double), intent(in) :: h, omega_bind
  real(c_double), intent(in) :: params(16), lo(3), hi(3), orb_tol, orb_rtol, orb_atol, level, de, &
                                eps, area_tol, t_max
  integer(c_int64_t), intent(in) :: stores
  integer(c_int), intent(out) :: stat, n, n_failed, nhist, hist_n(64)
  real(c_double), intent(out) :: tau(n_max), r(n_max), pr(n_max), time(n_max), xs(6, n_max), area, &
                                 area_polygon, action, period, hist_area(64), floquet(6), sigma
  real(c_double), allocatable :: xl(:, :)
  type(study_t) :: st
  type(tube_cut_t) :: cut
  type(orbit_t) :: orb
  type(seed_stores_t), pointer :: kept
  n = 0; tau = 0; r = 0; pr = 0; time = 0; xs = 0; area = 0; area_polygon = 0; action = 0; period = 0
  n_failed = 0; hist_n = 0; hist_area = 0; floquet = 0; sigma = 0
  st = study_t(system=system, params=params, lo=lo, hi=hi, n_grid=n_grid, saddle=saddle, &
               n_segments=n_segments, family=family, orb_tol=orb_tol, orb_rtol=orb_rtol, orb_atol=orb_atol, &
               integ=integ_of(method, h, omega_bind, solver, int_max_iter))
  kept => stores_at(stores)
  call cut_at(st, section_choice_t(kind=sec_kind, index=sec_index, level=level, dir=dir), de, &
              tube_opts_of(kind, eps, area_tol, t_max, n_init, n_max, .false.), cut, orb, stat, kept)
  if (allocated(cut%x)) then
    allocate (xl(size(cut%x, 1), n_max))
  else
    allocate (xl(4, n_max))
  end if
  xl = 0
  call cut_outputs(cut, orb, n, tau, r, pr, time, xl, area, area_polygon, action, period, n_failed, &
                   nhist, hist_n, hist_area)
  xs(1:size(xl, 1), :) = xl
  if (allocated(cut%floquet)) floquet(1:size(cut%floquet)) = cut%floquet
  sigma = cut%sigma
end subroutine tube_cut

subroutine dissipation_rates(system, params, stat, c, f)
  ! the model's dissipation: its viscous rate c [1/s] and rolling drag f [cm/s^2] (as the
  ! program's /model damping_rate and rolling_drag; include/tubes.h tubes_dissipation)
  use, intrinsic :: iso_c_binding, only: c_double, c_int
  use tubes_field, only: vector_field_t
  use tubes_models, only: make_field
  implicit none
  character(len=*), intent(in) :: system
  real(c_double), intent(in) :: params(16)
  integer(c_int), intent(out) :: stat
  real(c_double), intent(out) :: c, f
  class(vector_field_t), allocatable :: field
  integer :: ist
  call make_field(system, params, field, c, ist, f)
  stat = ist
end subroutine dissipation_rates

subroutine monte_carlo(system, params, lo, hi, n_grid, saddle, sec_kind, sec_index, level, dir, de, &
                       nsamp, seed, t_max, gate, method, h, omega_bind, solver, int_max_iter, ncut, &
                       cut_r, cut_pr, stores, stat, r, pr, outcome, inside)
  ! the Monte Carlo check at de against the cut (cut_r, cut_pr) (as the montecarlo scene)
  use, intrinsic :: iso_c_binding, only: c_double, c_int, c_long, c_int64_t
  use tubes_study, only: study_t, section_choice_t, check_at, seed_stores_t, stores_at
  use tubes_capi, only: integ_of
  implicit none
  character(len=*), intent(in) :: system, saddle
  integer(c_int), intent(in) :: n_grid, sec_kind, sec_index, dir, nsamp, seed, ncut, method, solver, &
                                int_max_iter
  real(c_double), intent(in) :: h, omega_bind
  real(c_double), intent(in) :: params(16), lo(3), hi(3), level, de, t_max, gate, cut_r(ncut), cut_pr(ncut)
  integer(c_int64_t), intent(in) :: stores
  integer(c_int), intent(out) :: stat, outcome(nsamp), inside(nsamp)
  real(c_double), intent(out) :: r(nsamp), pr(nsamp)
  logical :: ins(nsamp)
  type(seed_stores_t), pointer :: kept
  kept => stores_at(stores)
  call check_at(study_t(system=system, params=params, lo=lo, hi=hi, n_grid=n_grid, saddle=saddle, &
                        integ=integ_of(method, h, omega_bind, solver, int_max_iter)), &
                section_choice_t(kind=sec_kind, index=sec_index, level=level, dir=dir), de, nsamp, &
                int(seed, c_long), t_max, gate, cut_r, cut_pr, r, pr, outcome, ins, stat, kept)
  inside = merge(1, 0, ins)
end subroutine monte_carlo

subroutine status_code(name, code)
  ! the number of the status code TUBES_<name> (src/base/tubes_status.f90), 1000 for no such code
  use tubes_status, only: status_code_of => status_code
  implicit none
  character(len=*), intent(in) :: name
  integer, intent(out) :: code
  code = status_code_of(name)
end subroutine status_code

subroutine cancel_begin()
  ! SIGINT (Ctrl-C) stops the core's ensembles until cancel_end (src/base/tubes_cancel_shim.c)
  implicit none
  interface
    subroutine c_cancel_begin() bind(C, name='tubes_cancel_begin')
    end subroutine c_cancel_begin
  end interface
  call c_cancel_begin()
end subroutine cancel_begin

subroutine progress_enable(on)
  ! progress lines of the core's ensembles on stderr (src/base/tubes_progress_shim.c): 1 on, 0 off
  use, intrinsic :: iso_c_binding, only: c_int
  implicit none
  integer, intent(in) :: on
  interface
    subroutine c_progress_enable(o) bind(C, name='tubes_progress_enable')
      import :: c_int
      integer(c_int), value :: o
    end subroutine c_progress_enable
  end interface
  call c_progress_enable(int(on, c_int))
end subroutine progress_enable

subroutine cancel_end(requested)
  ! the caller's SIGINT handler back; requested = 1 if SIGINT came since cancel_begin
  use, intrinsic :: iso_c_binding, only: c_int
  implicit none
  integer, intent(out) :: requested
  interface
    integer(c_int) function c_cancel_end() bind(C, name='tubes_cancel_end')
      import :: c_int
    end function c_cancel_end
  end interface
  requested = c_cancel_end()
end subroutine cancel_end

subroutine mc_agreement(n, n_transit, n_undecided, misclassified, p, sigmas, sigma_limit, mis_lim, und_lim, &
                        agrees)
  ! the Monte Carlo check's verdict (src/transport/tubes_transport.f90 mc_agreement, the rule's one
  ! definition, as the montecarlo scene decides it), through the C API's tubes_mc_agreement
  use, intrinsic :: iso_c_binding, only: c_double, c_int
  use tubes_capi, only: c_mc_agreement
  implicit none
  integer(c_int), intent(in) :: n, n_transit, n_undecided, misclassified
  real(c_double), intent(in) :: p
  real(c_double), intent(out) :: sigmas, sigma_limit
  integer(c_int), intent(out) :: mis_lim, und_lim, agrees
  call c_mc_agreement(n, n_transit, n_undecided, misclassified, p, sigmas, sigma_limit, mis_lim, und_lim, agrees)
end subroutine mc_agreement

subroutine status_text(code, msg)
  ! the meaning of a TUBES_* status code (src/base/tubes_status.f90: the one table of them)
  use tubes_status, only: status_message
  implicit none
  integer, intent(in) :: code
  character(len=256), intent(out) :: msg
  msg = status_message(code)
end subroutine status_text

subroutine method_choice(code, system, params, eps, m, why)
  ! the method a run integrates with (src/workflow/tubes_setup.f90 method_resolved, as ./tubes)
  use tubes_setup, only: method_resolved
  implicit none
  integer, intent(in) :: code
  character(len=*), intent(in) :: system
  real(8), intent(in) :: params(16), eps
  integer, intent(out) :: m
  character(len=1024), intent(out) :: why
  m = method_resolved(code, trim(system), params, eps, why)
end subroutine method_choice

subroutine dissipation_of(system, params, law, text, v, stat)
  ! the model's dissipation (src/workflow/tubes_setup.f90 model_dissipation, as ./tubes): its law,
  ! its sentence, v = (damping_ratio, rolling_resistance, noise, temperature, c, f)
  use tubes_setup, only: dissipation_t, model_dissipation
  implicit none
  character(len=*), intent(in) :: system
  real(8), intent(in) :: params(16)
  character(len=128), intent(out) :: law
  character(len=256), intent(out) :: text
  real(8), intent(out) :: v(6)
  integer, intent(out) :: stat
  type(dissipation_t) :: d
  call model_dissipation(trim(system), params, .true., d, stat)
  law = d%law
  text = d%text
  v = [d%zeta, d%crr, d%noise, d%temperature, d%c, d%f]
end subroutine dissipation_of

subroutine saddle_of_run(system, params, lo, hi, n_grid, stores, name, use_near, near, degenerate_ok, label, dflt, &
                         code, chosen, e_saddle, msg)
  ! the run's saddle among the equilibria in the box (src/workflow/tubes_setup.f90 run_saddle, as
  ! ./tubes): code 0 (chosen, e_saddle), a refusal's code > 0, or the search's status < 0; msg why
  use, intrinsic :: iso_c_binding, only: c_int64_t
  use tubes_setup, only: run_saddle
  use tubes_study, only: seed_stores_t, stores_at
  implicit none
  character(len=*), intent(in) :: system, name, label
  real(8), intent(in) :: params(16), lo(3), hi(3), near(3)
  integer, intent(in) :: n_grid, use_near, degenerate_ok, dflt
  integer(c_int64_t), intent(in) :: stores
  integer, intent(out) :: code
  character(len=8), intent(out) :: chosen
  real(8), intent(out) :: e_saddle
  character(len=2048), intent(out) :: msg
  type(seed_stores_t), pointer :: kept
  kept => stores_at(stores)
  code = run_saddle(trim(system), params, lo, hi, n_grid, kept, name, use_near /= 0, near, degenerate_ok /= 0, &
                    label, dflt /= 0, chosen, e_saddle, msg)
end subroutine saddle_of_run

subroutine scene_check(scene, ndof, plane, label, code, msg)
  ! whether a scene applies to a model of ndof degrees of freedom (src/workflow/tubes_setup.f90
  ! scene_refused, as ./tubes): 0, else the refusal's code and message
  use tubes_setup, only: scene_refused
  implicit none
  character(len=*), intent(in) :: scene, label
  integer, intent(in) :: ndof, plane
  integer, intent(out) :: code
  character(len=1024), intent(out) :: msg
  code = scene_refused(scene, ndof, plane /= 0, label, msg)
end subroutine scene_check

subroutine dataset_units(group, name, dimensionless, stat, units)
  ! the units of dataset (or attribute) name of group in the output file (src/io/tubes_units.c: the
  ! writer's one table), as a model with or without physical units writes them; stat -1: no row
  use, intrinsic :: iso_c_binding, only: c_int, c_char, c_null_char
  implicit none
  character(len=*), intent(in) :: group, name
  integer, intent(in) :: dimensionless
  integer, intent(out) :: stat
  character(len=64), intent(out) :: units
  interface
    function tubes_units_c(g, n, dl, out, ln) result(r) bind(C, name='tubes_units_c')
      import :: c_int, c_char
      character(kind=c_char), intent(in) :: g(*), n(*)
      integer(c_int), value :: dl, ln
      character(kind=c_char), intent(out) :: out(*)
      integer(c_int) :: r
    end function tubes_units_c
  end interface
  character(kind=c_char) :: buf(64)
  integer :: k
  buf = c_null_char
  stat = tubes_units_c(trim(group) // c_null_char, trim(name) // c_null_char, int(dimensionless, c_int), buf, 64_c_int)
  units = ''
  do k = 1, 64
    if (buf(k) == c_null_char) exit
    units(k:k) = buf(k)
  end do
end subroutine dataset_units

subroutine nf_map(nd, order, nt, expo, coef, to_model, npts, pts, stat, out, round_trip, msg)
  ! points through the Birkhoff normal form's coordinate change and back (tubes.normal_form_map)
  use, intrinsic :: iso_c_binding, only: c_double, c_int
  use tubes_normal_form, only: nf_result_t, nf_change_t, normal_form, nf_map_points
  implicit none
  integer(c_int), intent(in) :: nd, order, nt, to_model, npts
  integer(c_int), intent(in) :: expo(2*nd, nt)
  real(c_double), intent(in) :: coef(nt), pts(2*nd, npts)
  integer(c_int), intent(out) :: stat
  real(c_double), intent(out) :: out(2*nd, npts), round_trip(npts)
  character(len=256), intent(out) :: msg
  type(nf_result_t) :: res
  type(nf_change_t) :: ch
  out = 0
  round_trip = 0
  call normal_form(nd, order, expo, coef, res, stat, change=ch)
  msg = res%message
  if (stat /= 0) return
  call nf_map_points(ch, to_model /= 0, pts, out, round_trip)
end subroutine nf_map

subroutine transition_region(system, params, lo, hi, n_grid, saddle, sec_kind, sec_index, level, dir, de, &
                             gate, t_max, area_tol, n_init, n_scan, xtol, method, h, omega_bind, solver, &
                             int_max_iter, nout, mcurve, noiseless, stores, stat, n, phi, rho, s, p, t_in, m, cs, cp, &
                             res, counts)
  ! the transition region at de of the model with its dissipation (as the transition scene of a
  ! dissipative model): the section points that pass the saddle's gate before they return. n_init
  ! (rays), n_scan (scan grid) and xtol (bisection): 0 for the program's (tubes_region's) defaults
  use, intrinsic :: iso_c_binding, only: c_double, c_int, c_int64_t
  use tubes_region, only: region_opts_t, region_t
  use tubes_study, only: study_t, section_choice_t, region_at, region_outputs, region_numbers, region_info_t, &
                         seed_stores_t, stores_at
  use tubes_capi, only: integ_of
  implicit none
  character(len=*), intent(in) :: system, saddle
  integer(c_int), intent(in) :: n_grid, sec_kind, sec_index, dir, n_init, n_scan, method, solver, &
                                int_max_iter, nout, mcurve, noiseless
  real(c_double), intent(in) :: params(16), lo(3), hi(3), level, de, gate, t_max, area_tol, xtol, h, omega_bind
  integer(c_int64_t), intent(in) :: stores
  integer(c_int), intent(out) :: stat, n, m, counts(8)
  real(c_double), intent(out) :: phi(nout), rho(nout), s(nout), p(nout), t_in(nout), cs(mcurve), cp(mcurve), &
                                 res(12)
  type(region_t) :: reg
  type(region_info_t) :: info
  type(region_opts_t) :: o
  type(seed_stores_t), pointer :: kept
  phi = 0; rho = 0; s = 0; p = 0; t_in = 0; cs = 0; cp = 0
  kept => stores_at(stores)
  o = region_opts_t(area_tol=area_tol, t_max=t_max)
  o%n_max = min(o%n_max, nout)
  if (n_init > 0) o%n_init = n_init
  if (n_scan > 0) o%n_scan = n_scan
  if (xtol > 0) o%xtol = xtol
  call region_at(study_t(system=system, params=params, lo=lo, hi=hi, n_grid=n_grid, saddle=saddle, &
                         integ=integ_of(method, h, omega_bind, solver, int_max_iter)), &
                 section_choice_t(kind=sec_kind, index=sec_index, level=level, dir=dir), de, gate, o, reg, info, &
                 stat, kept, noiseless /= 0)
  call region_outputs(reg, n, phi, rho, s, p, t_in, m, cs, cp)
  call region_numbers(reg, info, res, counts)
end subroutine transition_region

subroutine scan_parameter_index(system, name, ipar, allowed)
  ! the index (1-based, table order) of the parameter `name` of system, 0 if none; allowed: the
  ! system's parameters, blank-separated (tubes_scan scan_parameter)
  use, intrinsic :: iso_c_binding, only: c_int
  use tubes_scan, only: scan_parameter
  implicit none
  character(len=*), intent(in) :: system, name
  integer(c_int), intent(out) :: ipar
  character(len=512), intent(out) :: allowed
  integer :: k
  call scan_parameter(trim(system), trim(name), k, allowed)
  ipar = k
end subroutine scan_parameter_index

subroutine scan_start_value(system, params, ipar, stat, start)
  ! the start value of the scan's parameter ipar (scan_parameter_index's): params(ipar), or a
  ! formula's constant's value (tubes_scan scan_start)
  use, intrinsic :: iso_c_binding, only: c_double, c_int
  use tubes_study, only: study_t
  use tubes_scan, only: scan_start
  implicit none
  character(len=*), intent(in) :: system
  real(c_double), intent(in) :: params(16)
  integer(c_int), intent(in) :: ipar
  integer(c_int), intent(out) :: stat
  real(c_double), intent(out) :: start
  integer :: s
  call scan_start(study_t(system=system, params=params), ipar, start, s)
  stat = s
end subroutine scan_start_value

subroutine formula_with_constant(system, name, value, stat, key, msg)
  ! the library of the formula model system with its constant `name` set to value (built or loaded:
  ! include/tubes.h tubes_expr_with_constant); its name in key, on failure the reason in msg
  use, intrinsic :: iso_c_binding, only: c_double, c_int
  use tubes_scan, only: with_constant => formula_with_constant
  implicit none
  character(len=*), intent(in) :: system, name
  real(c_double), intent(in) :: value
  integer(c_int), intent(out) :: stat
  character(len=32), intent(out) :: key
  character(len=2048), intent(out) :: msg
  call with_constant(trim(system), trim(name), value, key, msg, stat)
end subroutine formula_with_constant

subroutine registry_range(group, name, found, lo, hi, lo_open, hi_open, is_int, allowed)
  ! a registered number's range (src/workflow/tubes_config.f90's annotations, the reader's check):
  ! found 1 with its bounds (+-huge or +-inf where open-ended), whether they are open, whether it
  ! is an integer and the allowed text of the reader's messages; found 2: a registered string, its
  ! values in allowed; found 0: not registered
  use, intrinsic :: iso_c_binding, only: c_double, c_int, c_char, c_null_char
  use tubes_cstrings, only: c_to_f
  implicit none
  character(len=*), intent(in) :: group, name
  integer(c_int), intent(out) :: found, lo_open, hi_open, is_int
  real(c_double), intent(out) :: lo, hi
  character(len=256), intent(out) :: allowed
  interface
    integer(c_int) function c_range(group, name, lo, hi, lo_open, hi_open, is_int, allowed, len) &
        bind(C, name='tubes_registry_range')
      import :: c_int, c_double, c_char
      character(kind=c_char), intent(in) :: group(*), name(*)
      real(c_double), intent(out) :: lo, hi
      integer(c_int), intent(out) :: lo_open, hi_open, is_int
      character(kind=c_char), intent(out) :: allowed(*)
      integer(c_int), value :: len
    end function c_range
  end interface
  character(kind=c_char) :: buf(256)
  found = c_range(trim(group) // c_null_char, trim(name) // c_null_char, lo, hi, lo_open, hi_open, is_int, buf, &
                  256_c_int)
  allowed = ''
  if (found /= 0) allowed = c_to_f(buf)
end subroutine registry_range

subroutine de_unresolved(des, n, group, saddle, ee, k, msg)
  ! the first of a group's excess energies below what the energy resolves at the saddle of energy ee
  ! (src/workflow/tubes_setup.f90 de_unresolved, the program's check): its index (1-based) and the
  ! message, or 0
  use, intrinsic :: iso_c_binding, only: c_double, c_int
  use tubes_setup, only: rule => de_unresolved
  implicit none
  integer(c_int), intent(in) :: n
  real(c_double), intent(in) :: des(n), ee
  character(len=*), intent(in) :: group, saddle
  integer(c_int), intent(out) :: k
  character(len=1024), intent(out) :: msg
  k = rule(des, trim(group), trim(saddle), ee, msg)
end subroutine de_unresolved

subroutine default_refused(model, group, label, k, msg)
  ! whether the model lacks the paper's defaults of group (its excess energies; 'trajectory': the
  ! start): 0, or 1 with the message (src/workflow/tubes_setup.f90 default_refused, the program's)
  use, intrinsic :: iso_c_binding, only: c_int
  use tubes_setup, only: rule => default_refused
  implicit none
  character(len=*), intent(in) :: model, group, label
  integer(c_int), intent(out) :: k
  character(len=1024), intent(out) :: msg
  k = rule(trim(model), trim(group), trim(label), msg)
end subroutine default_refused

subroutine scene(name, config, n, saddle, method, flags, text1, text2, stores, h)
  ! the program's scene `name` (src/workflow/tubes_scene_<name>.f90) on the settings read_input
  ! returned (config), the saddle and the method the run chose: the handle of its result record (read
  ! with record_sizes, record_item, record_reals, record_ints, record_string, record_line, record_code;
  ! forget it with record_free). The run's facts each scene takes besides:
  !   equilibria: flags(1) asked (saddle the one asked for), text1 the model's label, text2 dissip
  !   orbits: flags(1) dimensioned, flags(2) dissipative
  !   flux: text1 who (the messages' head)
  !   transition: flags(1) units, text1 dissip
  !   montecarlo: flags(1) units, flags(2) noisy, text1 dissip, text2 gate_at
  !   tubes: flags(1) check_eps, text1 dissip
  !   sections: flags(1) k (the map), flags(2) dissipative
  !   synthetic_experiment: none
  ! h = -1: no such scene, or config not the settings' size
  use, intrinsic :: iso_c_binding, only: c_int, c_int64_t
  use tubes_study, only: seed_stores_t, stores_at
  use tubes_record, only: record_t, record_keep
  use tubes_config, only: tubes_config_t
  use tubes_settings, only: settings_of_bytes
  use tubes_scene_equilibria, only: scene_equilibria
  use tubes_scene_orbits, only: scene_orbits
  use tubes_scene_flux, only: scene_flux
  use tubes_scene_transition, only: scene_transition
  use tubes_scene_montecarlo, only: scene_montecarlo
  use tubes_scene_tubes, only: scene_tubes
  use tubes_scene_sections, only: scene_sections
  use tubes_scene_synthetic_experiment, only: scene_synthetic_experiment
  implicit none
  character(len=*), intent(in) :: name, saddle, text1, text2
  integer(c_int), intent(in) :: n, method, flags(4)
  integer(1), intent(in) :: config(n)
  integer(c_int64_t), intent(in) :: stores
  integer(c_int), intent(out) :: h
  type(record_t), allocatable :: rec
  type(tubes_config_t) :: cfg
  type(seed_stores_t), pointer :: kept
  integer :: st, m
  h = -1
  call settings_of_bytes(config, cfg, st)
  if (st /= 0) return
  allocate (rec)
  kept => stores_at(stores)
  m = int(method)
  select case (name)
  case ('equilibria')
    call scene_equilibria(cfg, trim(saddle), flags(1) /= 0, trim(text1), trim(text2), kept, rec)
  case ('orbits')
    call scene_orbits(cfg, trim(saddle), m, flags(1) /= 0, flags(2) /= 0, kept, rec)
  case ('flux')
    call scene_flux(cfg, trim(saddle), m, trim(text1), kept, rec)
  case ('transition')
    call scene_transition(cfg, trim(saddle), m, flags(1) /= 0, trim(text1), .false., kept, rec)
  case ('montecarlo')
    call scene_montecarlo(cfg, trim(saddle), m, flags(1) /= 0, trim(text1), flags(2) /= 0, text2, .false., kept, rec)
  case ('tubes')
    call scene_tubes(cfg, trim(saddle), m, .false., '', trim(text1), flags(1) /= 0, .false., kept, rec)
  case ('sections')
    call scene_sections(cfg, trim(saddle), m, int(flags(1)), flags(2) /= 0, kept, rec)
  case ('synthetic_experiment')
    call scene_synthetic_experiment(cfg, trim(saddle), m, kept, rec)
  case default
    return
  end select
  h = record_keep(rec)
end subroutine scene

subroutine scene_scan(config, n, saddle, method, ipar, parameter, to, nsteps, nde, des, p_on, dissip, h)
  ! the scan scene (src/workflow/tubes_scene_scan.f90), as the program's, on the settings read_input
  ! returned, the saddle and the method the run chose: parameter ipar (its name parameter) to `to` in
  ! nsteps steps, the orbits at des, p_on: p_trans too. The handle of its result record
  use, intrinsic :: iso_c_binding, only: c_int, c_double
  use tubes_record, only: record_t, record_keep
  use tubes_config, only: tubes_config_t
  use tubes_settings, only: settings_of_bytes
  use tubes_scene_scan, only: scene_run => scene_scan
  implicit none
  integer(c_int), intent(in) :: n, method, ipar, nsteps, nde, p_on
  integer(1), intent(in) :: config(n)
  character(len=*), intent(in) :: saddle, parameter, dissip
  real(c_double), intent(in) :: to, des(nde)
  integer(c_int), intent(out) :: h
  type(record_t), allocatable :: rec
  type(tubes_config_t) :: cfg
  integer :: st
  h = -1
  call settings_of_bytes(config, cfg, st)
  if (st /= 0) return
  allocate (rec)
  call scene_run(cfg, trim(saddle), int(method), int(ipar), trim(parameter), to, int(nsteps), des, p_on /= 0, &
                 trim(dissip), 'tubes', rec)
  h = record_keep(rec)
end subroutine scene_scan

subroutine trajectory_section(name, angle, level, direction, kind, lvl, dir, known)
  ! the section of a trajectory by name (the trajectory scene's rule, tubes_scene_trajectory):
  ! kind (0 none, 1 ray, 2 x, 3 y), level, orientation; known 0: no such name
  use, intrinsic :: iso_c_binding, only: c_double, c_int
  use tubes_scene_trajectory, only: section_of => trajectory_section
  implicit none
  character(len=*), intent(in) :: name
  real(c_double), intent(in) :: angle, level
  integer(c_int), intent(in) :: direction
  integer(c_int), intent(out) :: kind, dir, known
  real(c_double), intent(out) :: lvl
  logical :: ok
  call section_of(trim(name), angle, level, direction, kind, lvl, dir, ok)
  known = merge(1, 0, ok)
end subroutine trajectory_section

subroutine record_sizes(h, code, n_items, n_lines)
  ! a result record's exit code (-1: no record), numbers of items and of console lines
  use, intrinsic :: iso_c_binding, only: c_int
  use tubes_record, only: sizes => record_sizes
  implicit none
  integer(c_int), intent(in) :: h
  integer(c_int), intent(out) :: code, n_items, n_lines
  call sizes(h, code, n_items, n_lines)
end subroutine record_sizes

subroutine record_item(h, k, kind, group, name, units, rank, dims, n)
  ! item k (1-based) of a record: its kind (tubes_record REC_*), group, name, units, rank, dims
  ! (C order) and number of values (strings: their count)
  use, intrinsic :: iso_c_binding, only: c_int, c_int64_t
  use tubes_record, only: record_item_info
  implicit none
  integer(c_int), intent(in) :: h, k
  integer(c_int), intent(out) :: kind, rank, n
  character(len=256), intent(out) :: group
  character(len=64), intent(out) :: name
  character(len=32), intent(out) :: units
  integer(c_int64_t), intent(out) :: dims(5)
  character(:), allocatable :: g, nm, u
  integer :: slen
  call record_item_info(h, k, kind, g, nm, u, rank, dims, n, slen)
  group = g
  name = nm
  units = u
end subroutine record_item

subroutine record_reals(h, k, n, v)
  ! item k's n real values (C order)
  use, intrinsic :: iso_c_binding, only: c_int, c_double
  use tubes_record, only: reals => record_reals
  implicit none
  integer(c_int), intent(in) :: h, k, n
  real(c_double), intent(out) :: v(n)
  call reals(h, k, v)
end subroutine record_reals

subroutine record_ints(h, k, n, v)
  ! item k's n integer values (C order)
  use, intrinsic :: iso_c_binding, only: c_int
  use tubes_record, only: ints => record_ints
  implicit none
  integer(c_int), intent(in) :: h, k, n
  integer(c_int), intent(out) :: v(n)
  call ints(h, k, v)
end subroutine record_ints

subroutine record_long(h, k, v)
  ! item k's integer attribute (64 bits)
  use, intrinsic :: iso_c_binding, only: c_int, c_int64_t
  use tubes_record, only: long => record_long
  implicit none
  integer(c_int), intent(in) :: h, k
  integer(c_int64_t), intent(out) :: v
  v = long(h, k)
end subroutine record_long

subroutine record_string(h, k, j, s)
  ! string j (1-based) of item k
  use, intrinsic :: iso_c_binding, only: c_int
  use tubes_record, only: string => record_string
  implicit none
  integer(c_int), intent(in) :: h, k, j
  character(len=1024), intent(out) :: s
  s = string(h, k, j)
end subroutine record_string

subroutine record_line(h, j, stream, s)
  ! console line j (1-based) of a record: stream 1 stdout, 2 stderr
  use, intrinsic :: iso_c_binding, only: c_int
  use tubes_record, only: line => record_line
  implicit none
  integer(c_int), intent(in) :: h, j
  integer(c_int), intent(out) :: stream
  character(len=4096), intent(out) :: s
  character(:), allocatable :: text
  call line(h, j, stream, text)
  s = text
end subroutine record_line

subroutine record_free(h)
  ! forget a record
  use, intrinsic :: iso_c_binding, only: c_int
  use tubes_record, only: record_drop
  implicit none
  integer(c_int), intent(in) :: h
  call record_drop(h)
end subroutine record_free
