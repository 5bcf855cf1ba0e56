!> The bind(C) API (include/tubes.h): scalars by value, explicit-shape arrays, int status.
module tubes_capi
  use, intrinsic :: iso_c_binding, only: c_int, c_double, c_char, c_int64_t, c_ptr, c_funptr, &
                                         c_null_char, c_associated, c_funloc, c_f_procpointer, &
                                         c_loc, c_f_pointer
  use tubes_kinds, only: wp, PI
  use tubes_cstrings, only: c_to_f, f_to_c
  use tubes_status, only: TUBES_OK, TUBES_EINPUT, TUBES_EVENT, TUBES_ENOCONV, TUBES_EMODEL, &
                          TUBES_EOUTSIDE, status_message
  use tubes_field, only: vector_field_t
  use tubes_taylor, only: taylor_check
  use tubes_hamiltonian, only: hamiltonian_t
  use tubes_ball, only: ball_t
  use tubes_models, only: NMODEL, MAX_PARAMS, MAX_DOF, LEN_SYSTEM, LEN_PARAM, NSYSTEMS, &
                          system_info_t, system_info, system_name, make_model, make_field, &
                          conservative_ball
  use tubes_equilibria, only: equilibrium_t
  use tubes_integrator, only: integrator_t, propagate
  use tubes_methods, only: new_integrator, method_opts_t, integ_choice_t
  use tubes_run, only: run_trajectory, section_spec_t, sized_model, field_rates
  use tubes_sampler, only: sampler_t
  use tubes_orbits, only: orbit_t, orbit_opts_t
  use tubes_settings, only: orbit_guess_branch
  use tubes_manifold, only: tube_opts_t, tube_cut_t, tube_cut
  use tubes_section_kinds, only: poincare_t, make_ray_section, make_plane_section, SEC_RAY, SEC_PLANE, &
                                 plane_search_range, plane_quadratic_in_p
  use tubes_transport, only: monte_carlo, poincare_map, gate_spec_t, mc_agreement, MC_SIGMA
  use tubes_flux, only: flux_result_t, flux_leading_order, flux_sampled
  use tubes_normal_form, only: nf_result_t, normal_form_flux, NF_NPTS
  use tubes_cut3, only: cut3_t, CUT3_NDIAG
  use tubes_flux3, only: cut3_study
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
  use tubes_study, only: bifurcation_table, BIF_TOL
  use tubes_scan, only: scan_table, scan_index, scan_start, SCAN_MAXEQ, SCAN_FOLD_TOL
  use tubes_study, only: setup_model, setup_section, study_t, section_choice_t, section_info, cut_at, &
                         check_at, gate_reach, maps_at, cut_outputs, seed_stores_t, family_at, &
                         equilibria_of, equilibria_table, study_family, family_table, open_stores, stores_at, &
                         close_stores, de_floor, region_at, region_outputs, region_numbers, region_info_t, &
                         damped_spectrum, box_note_of, centres_of
  use tubes_region, only: region_opts_t, region_t
  use tubes_experiment, only: experiment_opts_t, experiment_samples, synthetic_experiment
  use, intrinsic :: iso_c_binding, only: c_long, c_intptr_t
  implicit none
  private
  ! the synthetic experiment's entry, the Monte Carlo verdict, the tube cut's options, the
  ! scenes' defaults of a system and the integrator choice of a call, called by the f2py facade too (python/tubes_f2py.f90)
  public :: c_synthetic_experiment, c_experiment_defaults, c_experiment_samples, c_mc_agreement, tube_opts_of, &
            scene_defaults, integ_of
  ! a C call's study, stores and guess options, for the C API's other modules (tubes_capi_parameter)
  public :: study_of, stores_of, guess_opts


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

  !> A new, empty set of seed stores for tubes_tube_cut (include/tubes.h); free it with
  !> tubes_seed_stores_free.
  type(c_ptr) function c_seed_stores_new() result(p) bind(C, name='tubes_seed_stores_new')
    integer(c_intptr_t) :: handle
    call open_stores(handle)
    p = transfer(handle, p)
  end function c_seed_stores_new

  !> The stores behind a C pointer, or a disassociated pointer for NULL (stores_at).
  function stores_of(p) result(s)
    type(c_ptr), intent(in) :: p
    type(seed_stores_t), pointer :: s
    s => stores_at(transfer(p, 0_c_intptr_t))
  end function stores_of

  subroutine c_seed_stores_free(p) bind(C, name='tubes_seed_stores_free')
    type(c_ptr), value :: p
    call close_stores(transfer(p, 0_c_intptr_t))
  end subroutine c_seed_stores_free

  subroutine c_status_message(code, buf, len) bind(C, name='tubes_status_message')
    integer(c_int), value :: code, len
    character(kind=c_char), intent(out) :: buf(len)
    if (len < 1) return
    call f_to_c(status_message(code), buf)
  end subroutine c_status_message

  integer(c_int) function c_model_system(k, name) result(stat) bind(C, name='tubes_model_system')
    integer(c_int), value :: k
    character(kind=c_char), intent(out) :: name(LEN_SYSTEM)
    name = c_null_char
    stat = TUBES_EINPUT
    if (k < 0 .or. k >= NSYSTEMS) return
    call f_to_c(system_name(k + 1), name)
    stat = TUBES_OK
  end function c_model_system

  integer(c_int) function c_model_info(system, ndof, np, names, defaults, units, docs, summary, &
      length_units, box, box_center, saddle, saddle_near, section_kind, section_index, &
      section_value, section_direction, section_angle, gate, surface) result(stat) &
      bind(C, name='tubes_model_info')
    character(kind=c_char), intent(in) :: system(LEN_SYSTEM)
    integer(c_int), intent(out) :: ndof, np, section_index, section_direction
    character(kind=c_char), intent(out) :: names(LEN_PARAM, MAX_PARAMS), units(16, MAX_PARAMS), &
      docs(96, MAX_PARAMS), summary(160), length_units(8), saddle(8), section_kind(8), surface(160)
    real(c_double), intent(out) :: defaults(MAX_PARAMS), box(MAX_DOF), box_center(MAX_DOF), &
      saddle_near(MAX_DOF), section_value, section_angle, gate
    type(system_info_t) :: info
    integer :: k, ist
    call system_info(trim(c_to_f(system)), info, ist)
    stat = ist
    ndof = info%ndof
    np = info%np
    defaults = 0
    names = c_null_char; units = c_null_char; docs = c_null_char
    do k = 1, info%np
      call f_to_c(info%params(k)%name, names(:, k))
      call f_to_c(info%params(k)%units, units(:, k))
      call f_to_c(info%params(k)%doc, docs(:, k))
      defaults(k) = info%params(k)%default
    end do
    call f_to_c(info%summary, summary)
    call f_to_c(info%surface, surface)
    call f_to_c(info%length_units, length_units)
    call f_to_c(info%saddle, saddle)
    call f_to_c(info%section_kind, section_kind)
    call scene_defaults(info, box, box_center, saddle_near, section_index, section_value, section_direction, &
                        section_angle, gate)
  end function c_model_info

  !> The numbers of a system's table entry that are the scenes' defaults (tubes_model_info and the
  !> f2py facade's model_info): the box, the saddle's position, the section, the gate.
  pure subroutine scene_defaults(info, box, box_center, saddle_near, section_index, section_value, &
                                 section_direction, section_angle, gate)
    type(system_info_t), intent(in) :: info
    real(c_double), intent(out) :: box(MAX_DOF), box_center(MAX_DOF), saddle_near(MAX_DOF), section_value, &
                                   section_angle, gate
    integer(c_int), intent(out) :: section_index, section_direction
    box = info%box
    box_center = info%box_center
    saddle_near = info%saddle_near
    section_index = info%section_index
    section_value = info%section_value
    section_direction = info%section_direction
    section_angle = info%section_angle
    gate = info%gate
  end subroutine scene_defaults

  !> 1 if the system is natural (H = T + V: rest points, brake orbits, zero-velocity curves).
  integer(c_int) function c_model_natural(system, params, natural) result(stat) &
      bind(C, name='tubes_model_natural')
    character(kind=c_char), intent(in) :: system(LEN_SYSTEM)
    real(c_double), intent(in) :: params(MAX_PARAMS)
    integer(c_int), intent(out) :: natural
    class(hamiltonian_t), allocatable :: model
    natural = 0
    call model_of(system, params, model, stat)
    if (stat /= TUBES_OK) return
    natural = merge(1, 0, model%is_natural())
  end function c_model_natural

  !> The Monte Carlo check's verdict (tubes_transport mc_agreement): sigmas, the limits and
  !> agrees (1 or 0); sigma_limit is MC_SIGMA.
  subroutine c_mc_agreement(n, n_transit, n_undecided, misclassified, p, sigmas, sigma_limit, mis_lim, &
                            und_lim, agrees) bind(C, name='tubes_mc_agreement')
    integer(c_int), value :: n, n_transit, n_undecided, misclassified
    real(c_double), value :: p
    real(c_double), intent(out) :: sigmas, sigma_limit
    integer(c_int), intent(out) :: mis_lim, und_lim, agrees
    integer :: ml, ul
    logical :: ok
    call mc_agreement(int(n), int(n_transit), int(n_undecided), int(misclassified), p, sigmas, ml, ul, ok)
    mis_lim = ml
    und_lim = ul
    agrees = merge(1, 0, ok)
    sigma_limit = MC_SIGMA
  end subroutine c_mc_agreement

  !> 1 if H is quadratic in the momenta on the plane q_index = value of a 2-DOF model, over the
  !> s range a plane section searches (the box lo, hi widened): the plane section's premise.
  integer(c_int) function c_plane_quadratic(system, params, lo, hi, sec_index, value, quadratic) &
      result(stat) bind(C, name='tubes_plane_quadratic')
    character(kind=c_char), intent(in) :: system(LEN_SYSTEM)
    real(c_double), intent(in) :: params(MAX_PARAMS), lo(MAX_DOF), hi(MAX_DOF)
    integer(c_int), value :: sec_index
    real(c_double), value :: value
    integer(c_int), intent(out) :: quadratic
    class(hamiltonian_t), allocatable :: model
    real(wp) :: s_lo, s_hi
    quadratic = 0
    call model_of(system, params, model, stat)
    if (stat /= TUBES_OK) return
    if (model%ndof() /= 2 .or. sec_index < 1 .or. sec_index > 2) then
      stat = TUBES_EINPUT
      return
    end if
    call plane_search_range(lo(1:2), hi(1:2), int(sec_index), s_lo, s_hi)
    quadratic = merge(1, 0, plane_quadratic_in_p(model, int(sec_index), value, s_lo, s_hi))
  end function c_plane_quadratic

  !> The smallest |dE| the energy resolves at a saddle of energy e_saddle (de_floor); the calls
  !> that take a smaller one return TUBES_EUNRESOLVED.
  real(c_double) function c_de_floor(e_saddle) bind(C, name='tubes_de_floor')
    real(c_double), value :: e_saddle
    c_de_floor = de_floor(e_saddle)
  end function c_de_floor

  !> Can method = 'taylor' integrate (system, params) at relative tolerance eps? Its kernel is
  !> built or loaded now (src/integrators/tubes_taylor.f90 taylor_check); on failure TUBES_ENOJET
  !> and the reason in msg (NUL-terminated).
  integer(c_int) function c_taylor_check(system, params, eps, msg, lmsg) result(stat) &
      bind(C, name='tubes_taylor_check')
    character(kind=c_char), intent(in) :: system(LEN_SYSTEM)
    real(c_double), intent(in) :: params(MAX_PARAMS)
    real(c_double), value :: eps
    integer(c_int), value :: lmsg
    character(kind=c_char), intent(out) :: msg(lmsg)
    class(vector_field_t), allocatable :: field
    character(512) :: m
    real(wp) :: c
    msg(1) = c_null_char
    call make_field(trim(c_to_f(system)), params, field, c, stat)
    if (stat /= TUBES_OK) return
    call taylor_check(field, eps, m, stat)
    call f_to_c(m, msg)
  end function c_taylor_check

  !> The conservative model of (system, params).
  subroutine model_of(system, params, model, stat)
    character(kind=c_char), intent(in) :: system(LEN_SYSTEM)
    real(c_double), intent(in) :: params(MAX_PARAMS)
    class(hamiltonian_t), allocatable, intent(out) :: model
    integer, intent(out) :: stat
    call make_model(trim(c_to_f(system)), params, model, stat)
  end subroutine model_of

  integer(c_int) function c_energy(system, params, n, x, energy) result(stat) bind(C, name='tubes_energy')
    character(kind=c_char), intent(in) :: system(LEN_SYSTEM)
    real(c_double), intent(in) :: params(MAX_PARAMS)
    integer(c_int), value :: n
    real(c_double), intent(in) :: x(n)
    real(c_double), intent(out) :: energy
    class(hamiltonian_t), allocatable :: model
    energy = 0
    call sized_model(c_to_f(system), params, n, .false., model, stat)
    if (stat == TUBES_OK) energy = model%energy(x)
  end function c_energy

  integer(c_int) function c_vector_field(system, params, n, x, dxdt) result(stat) &
      bind(C, name='tubes_vector_field')
    character(kind=c_char), intent(in) :: system(LEN_SYSTEM)
    real(c_double), intent(in) :: params(MAX_PARAMS)
    integer(c_int), value :: n
    real(c_double), intent(in) :: x(n)
    real(c_double), intent(out) :: dxdt(n)
    call field_rates(c_to_f(system), params, x, dxdt, stat)
  end function c_vector_field

  integer(c_int) function c_momentum(system, params, q, v, p) result(stat) bind(C, name='tubes_momentum')
    character(kind=c_char), intent(in) :: system(LEN_SYSTEM)
    real(c_double), intent(in) :: params(MAX_PARAMS), q(2), v(2)
    real(c_double), intent(out) :: p(2)
    type(ball_t) :: ball
    p = 0
    stat = TUBES_EINPUT
    if (trim(c_to_f(system)) /= 'rolling_ball') return
    call conservative_ball(params(1:NMODEL), ball, stat)
    if (stat /= TUBES_OK) return
    p = ball%momentum(q, v)
  end function c_momentum

  integer(c_int) function c_damping_rate(system, params, c) result(stat) bind(C, name='tubes_damping_rate')
    character(kind=c_char), intent(in) :: system(LEN_SYSTEM)
    real(c_double), intent(in) :: params(MAX_PARAMS)
    real(c_double), intent(out) :: c
    class(vector_field_t), allocatable :: field
    call make_field(trim(c_to_f(system)), params, field, c, stat)
  end function c_damping_rate

  !> The model's dissipation: its viscous rate c [1/s] and rolling drag f [cm/s^2] (include/tubes.h).
  integer(c_int) function c_dissipation(system, params, c, f) result(stat) bind(C, name='tubes_dissipation')
    character(kind=c_char), intent(in) :: system(LEN_SYSTEM)
    real(c_double), intent(in) :: params(MAX_PARAMS)
    real(c_double), intent(out) :: c, f
    class(vector_field_t), allocatable :: field
    call make_field(trim(c_to_f(system)), params, field, c, stat, f)
  end function c_dissipation

  !> Equilibria of the model in the box [lo, hi] (per coordinate, ndof of them).
  integer(c_int) function c_equilibria(system, params, lo, hi, n_grid, nmax, n, ndof, q, p, height, &
      energy, grad_norm, morse, rank1, names, lambda, omega, evec, stores) result(stat) &
      bind(C, name='tubes_find_equilibria')
    character(kind=c_char), intent(in) :: system(LEN_SYSTEM)
    real(c_double), intent(in) :: params(MAX_PARAMS), lo(MAX_DOF), hi(MAX_DOF)
    integer(c_int), value :: n_grid, nmax
    integer(c_int), intent(out) :: n, ndof
    real(c_double), intent(out) :: q(MAX_DOF, nmax), p(MAX_DOF, nmax), height(nmax), energy(nmax), &
      grad_norm(nmax), lambda(nmax), omega(MAX_DOF - 1, nmax), evec(4*MAX_DOF*MAX_DOF, nmax)
    integer(c_int), intent(out) :: morse(nmax), rank1(nmax)
    character(kind=c_char), intent(out) :: names(8, nmax)
    type(c_ptr), value :: stores          !! from tubes_seed_stores_new, or NULL
    class(hamiltonian_t), allocatable :: model
    type(equilibrium_t), allocatable :: eqs(:)
    type(seed_stores_t), pointer :: kept
    integer :: k, nd
    n = 0; ndof = 0; q = 0; p = 0; height = 0; energy = 0; grad_norm = 0; lambda = 0; omega = 0
    evec = 0; morse = -1; rank1 = 0; names = c_null_char
    call model_of(system, params, model, stat)
    if (stat /= TUBES_OK) return
    nd = model%ndof()
    ndof = nd
    kept => stores_of(stores)
    call equilibria_of(trim(c_to_f(system)), params, lo, hi, n_grid, model, eqs, stat, kept)
    if (stat /= TUBES_OK) return
    if (size(eqs) > nmax) then
      stat = TUBES_EINPUT
      return
    end if
    n = size(eqs)
    call equilibria_table(eqs, nd, q, p, height, energy, grad_norm, morse, rank1, lambda, omega, evec)
    do k = 1, n
      call f_to_c(eqs(k)%name, names(:, k))
    end do
  end function c_equilibria

  !> The equilibria's centre frequencies (freqs(MAX_DOF, nmax), NaN-padded) and linear stability
  !> (tubes_study centres_of), in tubes_find_equilibria's order.
  integer(c_int) function c_equilibria_centres(system, params, lo, hi, n_grid, nmax, n, freqs, stable, stores) &
      result(stat) bind(C, name='tubes_equilibria_centres')
    character(kind=c_char), intent(in) :: system(LEN_SYSTEM)
    real(c_double), intent(in) :: params(MAX_PARAMS), lo(MAX_DOF), hi(MAX_DOF)
    integer(c_int), value :: n_grid, nmax
    integer(c_int), intent(out) :: n, stable(nmax)
    real(c_double), intent(out) :: freqs(MAX_DOF, nmax)
    type(c_ptr), value :: stores
    type(seed_stores_t), pointer :: kept
    integer :: nn, st(nmax)
    kept => stores_of(stores)
    call centres_of(trim(c_to_f(system)), params, lo, hi, n_grid, kept, nn, freqs, st, stat)
    n = nn
    stable = st
  end function c_equilibria_centres

  !> What the search box may hide (tubes_study box_note): note '' (NUL) when nothing.
  integer(c_int) function c_box_note(system, params, lo, hi, n_grid, note, lnote, stores) result(stat) &
      bind(C, name='tubes_box_note')
    character(kind=c_char), intent(in) :: system(LEN_SYSTEM)
    real(c_double), intent(in) :: params(MAX_PARAMS), lo(MAX_DOF), hi(MAX_DOF)
    integer(c_int), value :: n_grid, lnote
    character(kind=c_char), intent(out) :: note(lnote)
    type(c_ptr), value :: stores
    type(seed_stores_t), pointer :: kept
    character(512) :: text
    kept => stores_of(stores)
    call box_note_of(trim(c_to_f(system)), params, lo, hi, n_grid, kept, text, stat)
    call f_to_c(text, note)
  end function c_box_note

  integer(c_int) function c_trajectory(system, params, n2, x0, t_end, dt_out, method, rtol, atol, h, &
      max_steps, omega_bind, solver, max_iter, sec_kind, sec_level, sec_dir, stop_first, &
      max_cross, nmax, n, t, state, energy, n_cross, cross_t, cross_x, cross_dir, counters, &
      c_damp, progress, user) result(stat) bind(C, name='tubes_run_trajectory')
    character(kind=c_char), intent(in) :: system(LEN_SYSTEM)
    real(c_double), intent(in) :: params(MAX_PARAMS)
    integer(c_int), value :: n2
    real(c_double), intent(in) :: x0(n2)
    real(c_double), value :: t_end, dt_out, rtol, atol, h, omega_bind, sec_level
    integer(c_int), value :: method, nmax, solver, max_iter, sec_kind, sec_dir, stop_first, max_cross
    integer(c_int64_t), value :: max_steps
    integer(c_int), intent(out) :: n, n_cross
    real(c_double), intent(out) :: t(nmax), state(n2, nmax), energy(nmax), c_damp
    real(c_double), intent(out) :: cross_t(max(max_cross, 1)), cross_x(n2, max(max_cross, 1))
    integer(c_int), intent(out) :: cross_dir(max(max_cross, 1))
    integer(c_int64_t), intent(out) :: counters(4)
    type(c_funptr), value :: progress
    type(c_ptr), value :: user
    type(c_sampler_t) :: obs
    obs%cb = progress
    obs%user = user
    call run_trajectory(trim(c_to_f(system)), params, x0, t_end, dt_out, method, rtol, &
                        atol, h, max_steps, &
                        method_opts_t(omega_bind=omega_bind, solver=solver, max_iter=max_iter), &
                        section_spec_t(kind=sec_kind, level=sec_level, dir=sec_dir, &
                                       stop_at_first=stop_first /= 0, max_crossings=max_cross), &
                        obs, n, t, state, energy, n_cross, cross_t, cross_x, cross_dir, counters, &
                        c_damp, stat)
  end function c_trajectory

  !> The Lyapunov family of the saddle named `saddle` (C string) at the ascending excess
  !> energies des(nde); outputs per orbit as in include/tubes.h (tubes_orbit_family).
  integer(c_int) function c_orbit_family(system, params, lo, hi, n_grid, saddle, nde, des, &
      n_segments, family, tol, rtol, atol, max_iter, nsamp, method, h, omega_bind, solver, int_max_iter, &
      energy, period, action, state0, mu_u, mu_s, mu_triv, stab, residual, closure, iterations, &
      converged, mindist, monodromy, ts, xs, history, end_de, end_reason, local, stores, nguess, guess, &
      guess_period) result(stat) bind(C, name='tubes_orbit_family')
    character(kind=c_char), intent(in) :: system(LEN_SYSTEM), saddle(8)
    real(c_double), intent(in) :: params(MAX_PARAMS), lo(MAX_DOF), hi(MAX_DOF)
    integer(c_int), value :: n_grid, nde, n_segments, family, max_iter, nsamp, method, solver, int_max_iter
    real(c_double), value :: h, omega_bind
    real(c_double), intent(in) :: des(nde)
    real(c_double), value :: tol, rtol, atol
    real(c_double), intent(out) :: energy(nde), period(nde), action(nde), &
      state0(2*MAX_DOF, nde), mu_u(nde), mu_s(nde), mu_triv(4, nde), stab(nde), residual(nde), &
      closure(nde), mindist(nde), monodromy(4*MAX_DOF*MAX_DOF, nde), ts(nsamp, nde), &
      xs(2*MAX_DOF, nsamp, nde), history(max_iter, nde), end_de
    integer(c_int), intent(out) :: iterations(nde), converged(nde), end_reason
    integer(c_int), value :: local        !! 1: on this MPI rank alone
    type(c_ptr), value :: stores          !! from tubes_seed_stores_new, or NULL
    integer(c_int), value :: nguess       !! > 0: the family through guess (2N values)
    real(c_double), intent(in) :: guess(*)
    real(c_double), value :: guess_period
    class(hamiltonian_t), allocatable :: model
    type(equilibrium_t), allocatable :: eqs(:)
    type(orbit_opts_t) :: opts
    type(orbit_t), allocatable :: orbs(:)
    type(study_t) :: st
    type(section_choice_t) :: sec
    type(seed_stores_t), pointer :: kept
    integer :: isad, reason
    real(wp) :: ede
    energy = 0; period = 0; action = 0; state0 = 0; mu_u = 0; mu_s = 0; mu_triv = 0; stab = 0
    residual = 0; closure = 0; mindist = 0; monodromy = 0; ts = 0; xs = 0; history = 0
    iterations = 0; converged = 0; end_de = -1; end_reason = 0
    opts = orbit_opts_t(n_segments=n_segments, tol=tol, rtol=rtol, atol=atol, max_iter=max_iter, &
                        n_samples=nsamp, family=family, local=local /= 0, &
                        integ=integ_of(method, h, omega_bind, solver, int_max_iter))
    call guess_opts(nguess, guess, guess_period, opts)
    call study_of(system, params, lo, hi, n_grid, saddle, 0, 0, 0.0_c_double, 0, opts%integ, st, sec)
    allocate (orbs(nde))
    kept => stores_of(stores)
    call study_family(st, des, opts, model, eqs, isad, orbs, ede, reason, stat, kept)
    if (stat < 0) return
    end_de = ede
    end_reason = reason
    call family_table(orbs, eqs(isad)%energy, des, model%dim(), energy, period, action, state0, mu_u, &
                      mu_s, mu_triv, stab, residual, closure, iterations, converged, mindist, monodromy, &
                      ts, xs, history)
    stat = TUBES_OK
  end function c_orbit_family

  !> Bifurcation monitoring of the family of tubes_orbit_family (the same arguments up to
  !> int_max_iter, include/tubes.h: tubes_orbit_bifurcations): the Floquet indices of each orbit
  !> and the bifurcations located between them (tubes_study: family_bifurcations).
  integer(c_int) function c_orbit_bifurcations(system, params, lo, hi, n_grid, saddle, nde, des, &
      n_segments, family, tol, rtol, atol, max_iter, nsamp, method, h, omega_bind, solver, int_max_iter, &
      nu, max_bif, nbif, kind, after, bde, bwidth, benergy, bperiod, bnu, bconv, bx0, btan, bracket_tol, local, &
      stores, nguess, guess, guess_period) &
      result(stat) &
      bind(C, name='tubes_orbit_bifurcations')
    character(kind=c_char), intent(in) :: system(LEN_SYSTEM), saddle(8)
    real(c_double), intent(in) :: params(MAX_PARAMS), lo(MAX_DOF), hi(MAX_DOF)
    integer(c_int), value :: n_grid, nde, n_segments, family, max_iter, nsamp, method, solver, int_max_iter
    real(c_double), value :: h, omega_bind
    real(c_double), intent(in) :: des(nde)
    real(c_double), value :: tol, rtol, atol
    real(c_double), intent(out) :: nu(2*MAX_DOF - 2, nde)
    integer(c_int), value :: max_bif
    integer(c_int), intent(out) :: nbif, kind(max_bif), after(max_bif), bconv(max_bif)
    real(c_double), intent(out) :: bde(max_bif), bwidth(max_bif), benergy(max_bif), bperiod(max_bif), &
                                   bnu(2*MAX_DOF - 2, max_bif), bracket_tol, bx0(2*MAX_DOF, max_bif), &
                                   btan(2*MAX_DOF, max_bif)
    integer(c_int), value :: local
    type(c_ptr), value :: stores
    integer(c_int), value :: nguess
    real(c_double), intent(in) :: guess(*)
    real(c_double), value :: guess_period
    type(orbit_opts_t) :: opts
    type(study_t) :: st
    type(section_choice_t) :: sec
    type(seed_stores_t), pointer :: kept
    bracket_tol = BIF_TOL
    opts = orbit_opts_t(n_segments=n_segments, tol=tol, rtol=rtol, atol=atol, max_iter=max_iter, &
                        n_samples=nsamp, family=family, local=local /= 0, &
                        integ=integ_of(method, h, omega_bind, solver, int_max_iter))
    call guess_opts(nguess, guess, guess_period, opts)
    call study_of(system, params, lo, hi, n_grid, saddle, 0, 0, 0.0_c_double, 0, opts%integ, st, sec)
    kept => stores_of(stores)
    call bifurcation_table(st, des, opts, nu, nbif, kind, after, bconv, bde, bwidth, benergy, bperiod, bnu, bx0, &
                           btan, stat, kept)
  end function c_orbit_bifurcations

  !> The parameter scan (include/tubes.h: tubes_parameter_scan; tubes_scan scan_table): the tables of
  !> n + 1 steps (maxeq = SCAN_MAXEQ equilibria, MAX_DOF coordinates, names as 8 ASCII codes
  !> each), at most max_fold folds recorded (n_fold counts all).
  integer(c_int) function c_scan(system, params, lo, hi, n_grid, saddle, ipar, to, n, nde, des, n_segments, tol, &
      rtol, atol, max_iter, nsamp, method, h, omega_bind, solver, int_max_iter, value, n_eq, researched, eq_q, &
      eq_energy, eq_index, eq_name, eq_det, saddle_found, saddle_q, saddle_energy, lambda, omega, period, action, &
      stability, converged, restarted, max_fold, n_fold, fold_step, fold_value, fold_width, fold_kind, fold_q, &
      fold_name, fold_partner, fold_tol, p_trans_on, sec_kind, sec_index, level, dir, eps, area_tol, t_max, &
      n_init, n_max, a_tube_p, a_e_p, p_trans_p, p_status_p) result(stat) bind(C, name='tubes_parameter_scan')
    character(kind=c_char), intent(in) :: system(LEN_SYSTEM), saddle(8)
    real(c_double), intent(in) :: params(MAX_PARAMS), lo(MAX_DOF), hi(MAX_DOF)
    integer(c_int), value :: n_grid, ipar, n, nde, n_segments, max_iter, nsamp, method, solver, int_max_iter, &
                             max_fold
    real(c_double), value :: to, tol, rtol, atol, h, omega_bind
    real(c_double), intent(in) :: des(*)
    real(c_double), intent(out) :: value(n + 1), eq_q(MAX_DOF, SCAN_MAXEQ, n + 1), eq_energy(SCAN_MAXEQ, n + 1), &
                                   saddle_q(MAX_DOF, n + 1), saddle_energy(n + 1), lambda(n + 1), &
                                   omega(MAX_DOF - 1, n + 1), period(max(nde, 1), n + 1), &
                                   action(max(nde, 1), n + 1), stability(max(nde, 1), n + 1), &
                                   fold_value(max_fold), fold_width(max_fold), fold_q(MAX_DOF, max_fold), fold_tol
    integer(c_int), intent(out) :: n_eq(n + 1), researched(n + 1), eq_index(SCAN_MAXEQ, n + 1), &
                                   eq_name(8, SCAN_MAXEQ, n + 1), eq_det(SCAN_MAXEQ, n + 1), saddle_found(n + 1), &
                                   converged(max(nde, 1), n + 1), restarted(max(nde, 1), n + 1), n_fold, &
                                   fold_step(max_fold), fold_kind(max_fold), fold_name(8, max_fold), &
                                   fold_partner(8, max_fold)
    integer(c_int), value :: p_trans_on, sec_kind, sec_index, dir, n_init, n_max
    real(c_double), value :: level, eps, area_tol, t_max
    type(c_ptr), value :: a_tube_p, a_e_p, p_trans_p, p_status_p   !! [max(nde, 1), n + 1] each, or NULL
    real(c_double), pointer :: a_tube(:, :), a_e(:, :), p_trans(:, :)
    integer(c_int), pointer :: p_status(:, :)
    type(orbit_opts_t) :: opts
    type(study_t) :: st
    type(section_choice_t) :: sec
    integer :: nf, s, w
    fold_tol = SCAN_FOLD_TOL
    n_fold = 0
    stat = TUBES_EINPUT
    if (n < 1 .or. nde < 0 .or. max_fold < 1) return
    opts = orbit_opts_t(n_segments=n_segments, tol=tol, rtol=rtol, atol=atol, max_iter=max_iter, &
                        n_samples=nsamp, integ=integ_of(method, h, omega_bind, solver, int_max_iter))
    call study_of(system, params, lo, hi, n_grid, saddle, sec_kind, sec_index, level, dir, opts%integ, st, sec)
    if (p_trans_on /= 0) then
      if (.not. (c_associated(a_tube_p) .and. c_associated(a_e_p) .and. c_associated(p_trans_p) .and. &
                 c_associated(p_status_p))) return
      w = max(nde, 1)
      call c_f_pointer(a_tube_p, a_tube, [w, n + 1])
      call c_f_pointer(a_e_p, a_e, [w, n + 1])
      call c_f_pointer(p_trans_p, p_trans, [w, n + 1])
      call c_f_pointer(p_status_p, p_status, [w, n + 1])
      call scan_table(st, ipar, to, n, des(1:nde), opts, value, n_eq, researched, eq_q, eq_energy, eq_index, &
                      eq_name, eq_det, saddle_found, saddle_q, saddle_energy, lambda, omega, period(1:nde, :), &
                      action(1:nde, :), stability(1:nde, :), converged(1:nde, :), restarted(1:nde, :), nf, &
                      fold_step, fold_value, fold_width, fold_kind, fold_q, fold_name, fold_partner, s, sec, &
                      tube_opts_of(-1, eps, area_tol, t_max, n_init, n_max, .true.), a_tube(1:nde, :), &
                      a_e(1:nde, :), p_trans(1:nde, :), p_status(1:nde, :))
    else
      call scan_table(st, ipar, to, n, des(1:nde), opts, value, n_eq, researched, eq_q, eq_energy, eq_index, &
                      eq_name, eq_det, saddle_found, saddle_q, saddle_energy, lambda, omega, period(1:nde, :), &
                      action(1:nde, :), stability(1:nde, :), converged(1:nde, :), restarted(1:nde, :), nf, &
                      fold_step, fold_value, fold_width, fold_kind, fold_q, fold_name, fold_partner, s)
    end if
    n_fold = nf
    stat = s
  end function c_scan

  !> The index (1-based) of parameter `name` of system that a scan takes, 0 if none; allowed:
  !> those parameters, blank-separated, NUL-terminated (include/tubes.h: tubes_scan_parameter).
  integer(c_int) function c_scan_parameter(system, name, allowed, len) result(ipar) &
      bind(C, name='tubes_scan_parameter')
    character(kind=c_char), intent(in) :: system(LEN_SYSTEM), name(LEN_PARAM)
    integer(c_int), value :: len
    character(kind=c_char), intent(out) :: allowed(len)
    character(512) :: a
    ipar = scan_index(c_to_f(system), c_to_f(name), a)
    call f_to_c(a, allowed)
  end function c_scan_parameter
  !> The start value of the scan's parameter ipar (tubes_scan_parameter's index) of system with
  !> params (include/tubes.h: tubes_scan_start): params(ipar), or a formula's constant's value.
  integer(c_int) function c_scan_start(system, params, ipar, start) result(stat) bind(C, name='tubes_scan_start')
    character(kind=c_char), intent(in) :: system(LEN_SYSTEM)
    real(c_double), intent(in) :: params(MAX_PARAMS)
    integer(c_int), value :: ipar
    real(c_double), intent(out) :: start
    type(study_t) :: st
    integer :: s
    st%system = c_to_f(system)
    st%params = params
    call scan_start(st, ipar, start, s)
    stat = s
  end function c_scan_start

  !> A C call's guess (nguess > 0: the family through it) and branch (family <= -101: 'branch:K',
  !> K = -100 - family) into opts.
  subroutine guess_opts(nguess, guess, guess_period, opts)
    integer(c_int), intent(in) :: nguess
    real(c_double), intent(in) :: guess(*), guess_period
    type(orbit_opts_t), intent(inout) :: opts
    call orbit_guess_branch(int(nguess), guess(1:max(nguess, 0)), guess_period, opts)
  end subroutine guess_opts

  !> The study (model, box, saddle, orbit corrector) and the section of a C call.
  subroutine study_of(system, params, lo, hi, n_grid, saddle, sec_kind, sec_index, level, dir, integ, st, &
                      sec)
    character(kind=c_char), intent(in) :: system(LEN_SYSTEM), saddle(8)
    real(c_double), intent(in) :: params(MAX_PARAMS), lo(MAX_DOF), hi(MAX_DOF), level
    integer(c_int), intent(in) :: n_grid, sec_kind, sec_index, dir
    type(integ_choice_t), intent(in) :: integ
    type(study_t), intent(out) :: st
    type(section_choice_t), intent(out) :: sec
    st%system = c_to_f(system)
    st%params = params
    st%lo = lo
    st%hi = hi
    st%n_grid = n_grid
    st%saddle = c_to_f(saddle)
    sec = section_choice_t(kind=sec_kind, index=sec_index, level=level, dir=dir)
    st%integ = integ
  end subroutine study_of

  !> The integrator choice of a C call or an f2py call (method code and options as
  !> tubes_run_trajectory).
  pure function integ_of(method, h, omega_bind, solver, max_iter) result(c)
    integer(c_int), intent(in) :: method, solver, max_iter
    real(c_double), intent(in) :: h, omega_bind
    type(integ_choice_t) :: c
    c%method = method
    c%h = h
    c%opts = method_opts_t(omega_bind=omega_bind, solver=solver, max_iter=max_iter)
  end function integ_of

  !> The energy surface on the section at E = E_e + de: its interval [smin, smax], its area
  !> and dA/dE.
  integer(c_int) function c_section_info(system, params, lo, hi, n_grid, saddle, sec_kind, &
      sec_index, level, dir, de, smin, smax, area, darea, stores) result(stat) &
      bind(C, name='tubes_section_info')
    character(kind=c_char), intent(in) :: system(LEN_SYSTEM), saddle(8)
    real(c_double), intent(in) :: params(MAX_PARAMS), lo(MAX_DOF), hi(MAX_DOF)
    integer(c_int), value :: n_grid, sec_kind, sec_index, dir
    real(c_double), value :: level, de
    real(c_double), intent(out) :: smin, smax, area, darea
    type(c_ptr), value :: stores          !! from tubes_seed_stores_new, or NULL
    type(study_t) :: st
    type(section_choice_t) :: sec
    type(integ_choice_t) :: none
    type(seed_stores_t), pointer :: kept
    call study_of(system, params, lo, hi, n_grid, saddle, sec_kind, sec_index, level, dir, none, st, sec)
    kept => stores_of(stores)
    call section_info(st, sec, de, smin, smax, area, darea, stat, kept)
  end function c_section_info

  !> The cut of the tube of the saddle's periodic orbit of family `family` (as &orbits family)
  !> at excess energy de with the section (include/tubes.h).
  integer(c_int) function c_tube_cut(system, params, lo, hi, n_grid, saddle, de, kind, sec_kind, &
      sec_index, level, dir, eps, area_tol, t_max, n_init, n_max, n_segments, family, orb_tol, orb_rtol, &
      orb_atol, method, h, omega_bind, solver, max_iter, nout, n, tau, r, pr, time, xs, area, &
      area_polygon, action, period, nhist, hist_n, hist_area, n_failed, fail_tau, floquet, sigma, local, &
      stores) result(stat) bind(C, name='tubes_tube_cut')
    character(kind=c_char), intent(in) :: system(LEN_SYSTEM), saddle(8)
    real(c_double), intent(in) :: params(MAX_PARAMS), lo(MAX_DOF), hi(MAX_DOF)
    integer(c_int), value :: n_grid, sec_kind, sec_index, dir
    real(c_double), value :: de, level, eps, area_tol, t_max, orb_tol, orb_rtol, orb_atol
    integer(c_int), value :: kind, n_init, n_max, n_segments, family, nout, local, method, solver, max_iter
    real(c_double), value :: h, omega_bind
    integer(c_int), intent(out) :: n, nhist, hist_n(64), n_failed
    real(c_double), intent(out) :: tau(nout), r(nout), pr(nout), time(nout), area, &
                                   area_polygon, action, period, hist_area(64), fail_tau
    real(c_double), intent(out) :: xs(2*MAX_DOF*nout)   !! the states, 2N per point (point k at 2N (k - 1) + 1)
    real(c_double), intent(out) :: floquet(2*MAX_DOF)   !! the orbit's unit Floquet vector at x0 (2N; 0: none)
    real(c_double), intent(out) :: sigma                !! the branch's sign (tube_cut_t)
    real(c_double), allocatable :: xl(:, :)
    type(c_ptr), value :: stores          !! from tubes_seed_stores_new, or NULL
    type(seed_stores_t), pointer :: kept
    type(study_t) :: st
    type(section_choice_t) :: sec
    type(orbit_t) :: orb
    type(tube_cut_t) :: cut
    n = 0; nhist = 0; hist_n = 0; hist_area = 0; area = 0; area_polygon = 0; action = 0; period = 0
    n_failed = 0; fail_tau = 0
    call study_of(system, params, lo, hi, n_grid, saddle, sec_kind, sec_index, level, dir, &
                  integ_of(method, h, omega_bind, solver, max_iter), st, sec)
    st%n_segments = n_segments
    st%family = family
    st%orb_tol = orb_tol
    st%orb_rtol = orb_rtol
    st%orb_atol = orb_atol
    kept => stores_of(stores)
    call cut_at(st, sec, de, tube_opts_of(kind, eps, area_tol, t_max, n_init, min(n_max, nout), local /= 0), &
                cut, orb, stat, kept)
    if (allocated(cut%x)) then
      allocate (xl(size(cut%x, 1), nout))
    else
      allocate (xl(4, nout))
    end if
    call cut_outputs(cut, orb, n, tau, r, pr, time, xl, area, area_polygon, action, period, n_failed, &
                     nhist, hist_n, hist_area)
    if (n > 0) xs(1:size(xl, 1)*n) = reshape(xl(:, 1:n), [size(xl, 1)*n])
    fail_tau = cut%fail_tau
    floquet = 0
    if (allocated(cut%floquet)) floquet(1:size(cut%floquet)) = cut%floquet
    sigma = cut%sigma
  end function c_tube_cut

  !> The options of a tube cut (tubes_tube_cut, the f2py facade's tube_cut): the rest are
  !> tube_opts_t's defaults.
  pure function tube_opts_of(kind, eps, area_tol, t_max, n_init, n_max, local) result(o)
    integer(c_int), intent(in) :: kind, n_init, n_max
    real(c_double), intent(in) :: eps, area_tol, t_max
    logical, intent(in) :: local
    type(tube_opts_t) :: o
    o = tube_opts_t(kind=kind, eps=eps, area_tol=area_tol, t_max=t_max, n_init=n_init, n_max=n_max, &
                    local=local)
  end function tube_opts_of

  !> Monte Carlo transition check at excess energy de (include/tubes.h).
  integer(c_int) function c_monte_carlo(system, params, lo, hi, n_grid, saddle, de, sec_kind, &
      sec_index, level, dir, nsamp, seed, t_max, gate, method, h, omega_bind, solver, max_iter, ncut, &
      cut_r, cut_pr, r, pr, outcome, inside, stores) result(stat) bind(C, name='tubes_monte_carlo')
    character(kind=c_char), intent(in) :: system(LEN_SYSTEM), saddle(8)
    real(c_double), intent(in) :: params(MAX_PARAMS), lo(MAX_DOF), hi(MAX_DOF)
    integer(c_int), value :: n_grid, sec_kind, sec_index, dir
    real(c_double), value :: de, level, t_max, gate
    integer(c_int), value :: nsamp, seed, ncut, method, solver, max_iter
    real(c_double), value :: h, omega_bind
    real(c_double), intent(in) :: cut_r(ncut), cut_pr(ncut)
    real(c_double), intent(out) :: r(nsamp), pr(nsamp)
    integer(c_int), intent(out) :: outcome(nsamp), inside(nsamp)
    type(c_ptr), value :: stores          !! from tubes_seed_stores_new, or NULL
    type(study_t) :: st
    type(section_choice_t) :: sec
    logical :: ins(nsamp)
    type(seed_stores_t), pointer :: kept
    call study_of(system, params, lo, hi, n_grid, saddle, sec_kind, sec_index, level, dir, &
                  integ_of(method, h, omega_bind, solver, max_iter), st, sec)
    kept => stores_of(stores)
    call check_at(st, sec, de, nsamp, int(seed, c_long), t_max, gate, cut_r, cut_pr, r, pr, outcome, &
                  ins, stat, kept)
    inside = merge(1, 0, ins)
  end function c_monte_carlo

  !> The eigenvalues of the saddle linearised with the model's dissipation (include/tubes.h).
  integer(c_int) function c_saddle_spectrum(system, params, lo, hi, n_grid, saddle, wr, wi, c, stores) &
      result(stat) bind(C, name='tubes_saddle_spectrum')
    character(kind=c_char), intent(in) :: system(LEN_SYSTEM), saddle(8)
    real(c_double), intent(in) :: params(MAX_PARAMS), lo(MAX_DOF), hi(MAX_DOF)
    integer(c_int), value :: n_grid
    real(c_double), intent(out) :: wr(2*MAX_DOF), wi(2*MAX_DOF), c
    type(c_ptr), value :: stores          !! from tubes_seed_stores_new, or NULL
    type(study_t) :: st
    type(section_choice_t) :: sec
    type(integ_choice_t) :: none
    type(seed_stores_t), pointer :: kept
    call study_of(system, params, lo, hi, n_grid, saddle, 1, 0, 0.0_c_double, 1, none, st, sec)
    kept => stores_of(stores)
    call damped_spectrum(st, wr, wi, c, stat, kept)
  end function c_saddle_spectrum

  !> The transition region at de of the model with its dissipation (include/tubes.h).
  integer(c_int) function c_transition_region(system, params, lo, hi, n_grid, saddle, de, sec_kind, sec_index, &
      level, dir, gate, t_max, area_tol, method, h, omega_bind, solver, max_iter, nout, mcurve, n, phi, rho, s, p, &
      t_in, m, cs, cp, res, counts, local, noiseless, stores) result(stat) bind(C, name='tubes_transition_region')
    character(kind=c_char), intent(in) :: system(LEN_SYSTEM), saddle(8)
    real(c_double), intent(in) :: params(MAX_PARAMS), lo(MAX_DOF), hi(MAX_DOF)
    integer(c_int), value :: n_grid, sec_kind, sec_index, dir, method, solver, max_iter, nout, mcurve, local, noiseless
    real(c_double), value :: de, level, gate, t_max, area_tol, h, omega_bind
    integer(c_int), intent(out) :: n, m, counts(8)
    real(c_double), intent(out) :: phi(nout), rho(nout), s(nout), p(nout), t_in(nout), cs(mcurve), cp(mcurve), &
                                   res(12)
    type(c_ptr), value :: stores          !! from tubes_seed_stores_new, or NULL
    type(study_t) :: st
    type(section_choice_t) :: sec
    type(region_t) :: reg
    type(region_info_t) :: info
    type(seed_stores_t), pointer :: kept
    type(region_opts_t) :: o
    call study_of(system, params, lo, hi, n_grid, saddle, sec_kind, sec_index, level, dir, &
                  integ_of(method, h, omega_bind, solver, max_iter), st, sec)
    kept => stores_of(stores)
    o = region_opts_t(area_tol=area_tol, t_max=t_max, local=local /= 0)
    o%n_max = min(o%n_max, nout)
    call region_at(st, sec, de, gate, o, reg, info, stat, kept, noiseless /= 0)
    call region_outputs(reg, n, phi, rho, s, p, t_in, m, cs, cp)
    call region_numbers(reg, info, res, counts)
  end function c_transition_region

  !> The reach of the saddle's NHIM across its neck at de (include/tubes.h).
  integer(c_int) function c_gate_reach(system, params, lo, hi, n_grid, saddle, de, reach, stores) result(stat) &
      bind(C, name='tubes_gate_reach')
    character(kind=c_char), intent(in) :: system(LEN_SYSTEM), saddle(8)
    real(c_double), intent(in) :: params(MAX_PARAMS), lo(MAX_DOF), hi(MAX_DOF)
    integer(c_int), value :: n_grid
    real(c_double), value :: de
    real(c_double), intent(out) :: reach
    type(c_ptr), value :: stores          !! from tubes_seed_stores_new, or NULL
    type(study_t) :: st
    type(section_choice_t) :: sec
    type(integ_choice_t) :: none
    type(seed_stores_t), pointer :: kept
    call study_of(system, params, lo, hi, n_grid, saddle, 0, 0, 0.0_wp, 0, none, st, sec)
    kept => stores_of(stores)
    call gate_reach(st, de, reach, stat, kept)
  end function c_gate_reach

  !> The flux of trajectories through the saddle's bottleneck at excess energy de
  !> (src/transport/tubes_flux.f90): sampled with nsamp points from seed (its standard error err), and the
  !> leading-order formula; counts = (points inside the shell, reacting, recrossing the other
  !> way, undecided within t_max); box(2, N-1) the sampling box of the dividing surface.
  !> TUBES_EINPUT for a model that is not natural.
  integer(c_int) function c_flux(system, params, lo, hi, n_grid, saddle, de, nsamp, seed, t_max, gate, &
      tol, method, h, omega_bind, solver, max_iter, flux, err, leading, counts, box) result(stat) &
      bind(C, name='tubes_flux_sample')
    character(kind=c_char), intent(in) :: system(LEN_SYSTEM), saddle(8)
    real(c_double), intent(in) :: params(MAX_PARAMS), lo(MAX_DOF), hi(MAX_DOF)
    integer(c_int), value :: n_grid, nsamp, seed, method, solver, max_iter
    real(c_double), value :: de, t_max, gate, tol, h, omega_bind
    real(c_double), intent(out) :: flux, err, leading, box(2, MAX_DOF - 1)
    integer(c_int), intent(out) :: counts(4)
    class(hamiltonian_t), allocatable :: model
    type(equilibrium_t), allocatable :: eqs(:)
    type(flux_result_t) :: res
    integer :: isad, ist
    flux = 0; err = 0; leading = 0; counts = 0; box = 0
    call setup_model(trim(c_to_f(system)), params, lo, hi, n_grid, trim(c_to_f(saddle)), &
                     model, eqs, isad, ist, degenerate_ok=.true., des=[de], conservative=.true.)
    stat = ist
    if (ist /= TUBES_OK) return
    leading = flux_leading_order(eqs(isad)%omegas, de)
    call flux_sampled(model, eqs(isad), de, nsamp, seed, t_max, tol, gate, &
                      maxval(hi(1:model%ndof()) - lo(1:model%ndof())), &
                      integ_of(method, h, omega_bind, solver, max_iter), res, ist)
    stat = ist
    flux = res%flux
    err = res%err
    counts = [res%n_inside, res%n_reactive, res%n_recrossing, res%n_undecided]
    box(:, 1:model%ndof() - 1) = res%box(:, 1:model%ndof() - 1)
  end function c_flux

  !> The energy surface's volume on the section q_k = c (crossed with sign(dq_k/dt) = dir) at
  !> E_s + de near the saddle, and the fraction of it that transits the bottleneck before
  !> returning (flux_sampled's section mode): volume +- volume_err, fraction +- fraction_err,
  !> counts = {inside the shell, transits, returns, undecided}. TUBES_EOUTSIDE if the section's
  !> point nearest the saddle is not inside the energy shell.
  integer(c_int) function c_section_transit(system, params, lo, hi, n_grid, saddle, de, k, c, dir, nsamp, seed, &
      t_max, gate, tol, method, h, omega_bind, solver, max_iter, volume, volume_err, fraction, fraction_err, &
      counts, x, w, cls) result(stat) bind(C, name='tubes_section_transit')
    character(kind=c_char), intent(in) :: system(LEN_SYSTEM), saddle(8)
    real(c_double), intent(in) :: params(MAX_PARAMS), lo(MAX_DOF), hi(MAX_DOF)
    integer(c_int), value :: n_grid, k, dir, nsamp, seed, method, solver, max_iter
    real(c_double), value :: de, c, t_max, gate, tol, h, omega_bind
    real(c_double), intent(out) :: volume, volume_err, fraction, fraction_err, x(2*MAX_DOF, nsamp), w(nsamp)
    integer(c_int), intent(out) :: counts(4), cls(nsamp)
    class(hamiltonian_t), allocatable :: model
    type(equilibrium_t), allocatable :: eqs(:)
    type(flux_result_t) :: res
    integer :: isad, ist, nd
    volume = 0; volume_err = 0; fraction = 0; fraction_err = 0; counts = 0
    x = ieee_value(1.0_c_double, ieee_quiet_nan)
    w = 0
    cls = 3
    call setup_model(trim(c_to_f(system)), params, lo, hi, n_grid, trim(c_to_f(saddle)), &
                     model, eqs, isad, ist, degenerate_ok=.true., des=[de], conservative=.true.)
    stat = ist
    if (ist /= TUBES_OK) return
    call flux_sampled(model, eqs(isad), de, nsamp, seed, t_max, tol, gate, &
                      maxval(hi(1:model%ndof()) - lo(1:model%ndof())), &
                      integ_of(method, h, omega_bind, solver, max_iter), res, ist, [k, dir], c)
    stat = ist
    volume = res%volume
    volume_err = res%volume_err
    fraction = res%fraction
    fraction_err = res%fraction_err
    counts = [res%n_inside, res%n_transit, res%n_return, res%n_undecided]
    if (ist /= TUBES_OK .or. .not. allocated(res%x)) return
    nd = model%ndof()
    x(1:2*nd, :) = res%x
    w = res%w
    cls = res%cls
  end function c_section_transit

  !> The cut of the stable tube of a 3-DOF saddle's NHIM at de with the plane q_k = c (crossed with
  !> sign(dq_k/dt) = dir), from the normal form of order `order` of the Taylor expansion (expo, coef)
  !> at zs, on a grid of n_cut + 1 rings of (2 n_cut)^2 NHIM points stepped off by eps
  !> (src/orbits/tubes_cut3.f90): the states at the section xcut(6, nodes), times tcut, node status stcut;
  !> diag = (the seeds' largest |H - E| / dE before their correction, the enclosed 4-volume,
  !> failed nodes); and for the points pts(6, n_pts) of the section: inside(i) = 1 inside the cut,
  !> 0 outside, -1 not a point (NaN). TUBES_ENOCROSS if a node failed, TUBES_EINPUT (msg) if the
  !> normal form or the request is refused.
  integer(c_int) function c_tube_cut3(system, params, lo, hi, n_grid, saddle, order, n_terms, expo, coef, zs, &
      de, k, c, dir, n_cut, eps, t_max, tol, method, h, omega_bind, solver, max_iter, n_pts, pts, w, cls, inside, &
      inside_pl, xcut, tcut, stcut, diag, msg, lmsg) result(stat) bind(C, name='tubes_tube_cut3')
    character(kind=c_char), intent(in) :: system(LEN_SYSTEM), saddle(8)
    real(c_double), intent(in) :: params(MAX_PARAMS), lo(MAX_DOF), hi(MAX_DOF)
    integer(c_int), value :: n_grid, order, n_terms, k, dir, n_cut, method, solver, max_iter, n_pts, lmsg
    integer(c_int), intent(in) :: expo(6, n_terms), cls(n_pts)
    real(c_double), intent(in) :: coef(n_terms), zs(6), pts(6, n_pts), w(n_pts)
    real(c_double), value :: de, c, eps, t_max, tol, h, omega_bind
    integer(c_int), intent(out) :: inside(n_pts), inside_pl(n_pts), stcut((n_cut + 1)*4*n_cut*n_cut)
    real(c_double), intent(out) :: xcut(6, (n_cut + 1)*4*n_cut*n_cut), tcut((n_cut + 1)*4*n_cut*n_cut), &
                                   diag(CUT3_NDIAG)
    character(kind=c_char), intent(out) :: msg(lmsg)
    type(cut3_t) :: cut
    character(len=256) :: m
    integer :: ist
    stcut = TUBES_EINPUT
    xcut = ieee_value(1.0_c_double, ieee_quiet_nan)
    tcut = xcut(1, 1)
    call cut3_study(trim(c_to_f(system)), params, lo, hi, n_grid, trim(c_to_f(saddle)), order, &
                    expo, coef, zs, de, k, c, dir, n_cut, eps, t_max, tol, integ_of(method, h, omega_bind, &
                    solver, max_iter), pts, w, cls, inside, inside_pl, cut, diag, m, ist)
    stat = ist
    call f_to_c(trim(m), msg)
    if (.not. allocated(cut%x)) return
    xcut = cut%x
    tcut = cut%t
    stcut = cut%st
  end function c_tube_cut3

  !> The Birkhoff normal form of H from its Taylor coefficients at a saddle x centre^(N-1)
  !> (n_terms of them: the exponents expo(2N, n_terms) of (dq, dp), coef) to degree order, and
  !> its flux at de(1:n_de): flux(k), fstat(k) (TUBES_ENOCONV where the truncated form has no
  !> bounded action region). Out: lambda, omegas(N-1), the normal form's terms (at most max_nf:
  !> nf_expo(3, .) the exponents of I_1, J_2, J_3, nf_coef), diag = (symplectic error of the
  !> linear change, largest non-normal coefficient left, largest imaginary part, smallest
  !> divisor), msg the reason of a refusal. src/orbits/tubes_normal_form.f90.
  integer(c_int) function c_normal_form(n_dof, order, n_terms, expo, coef, n_de, de, flux, fstat, lambda, &
      omegas, max_nf, n_nf, nf_expo, nf_coef, diag, nhim, round_trip, msg, lmsg) result(stat) &
      bind(C, name='tubes_birkhoff')
    integer(c_int), value :: n_dof, order, n_terms, n_de, max_nf, lmsg
    integer(c_int), intent(in) :: expo(2*n_dof, n_terms)
    real(c_double), intent(in) :: coef(n_terms), de(n_de)
    real(c_double), intent(out) :: flux(n_de), lambda, omegas(MAX_DOF - 1), nf_coef(max_nf), diag(4)
    integer(c_int), intent(out) :: fstat(n_de), n_nf, nf_expo(3, max_nf)
    real(c_double), intent(out) :: nhim(2*n_dof, NF_NPTS, n_de), round_trip(n_de)
    character(kind=c_char), intent(out) :: msg(lmsg)
    type(nf_result_t) :: res
    integer :: k
    lambda = 0; omegas = 0; n_nf = 0; nf_expo = 0; nf_coef = 0; diag = 0
    nhim = ieee_value(1.0_c_double, ieee_quiet_nan)
    round_trip = nhim(1, 1, :)
    call normal_form_flux(n_dof, order, expo, coef, de, res, flux, fstat, stat)
    call f_to_c(trim(res%message), msg)
    if (stat /= TUBES_OK) return
    lambda = res%lambda
    omegas(1:n_dof - 1) = res%omegas(1:n_dof - 1)
    diag = [res%symplectic_error, res%residual, res%imaginary, res%smallest_divisor]
    n_nf = min(res%nterms, max_nf)
    do k = 1, n_nf
      nf_expo(1:n_dof, k) = res%expo(:, k)
      nf_coef(k) = res%coef(k)
    end do
    if (allocated(res%nhim)) then
      nhim = res%nhim
      round_trip = res%round_trip
    end if
  end function c_normal_form

  !> Poincare map of the section at excess energy de: n_seeds starts on the section (half at the
  !> middle of the p_s range across the region, half across p_s at the region's middle s),
  !> n_iter returns each: pts(1:2, k, j) = (s, p_s) of the k-th return of seed j (NaN after it
  !> stops returning).
  integer(c_int) function c_poincare(system, params, lo, hi, n_grid, saddle, de, sec_kind, &
      sec_index, level, dir, n_seeds, n_iter, t_max, method, h, omega_bind, solver, max_iter, pts, &
      stores) result(stat) bind(C, name='tubes_poincare')
    character(kind=c_char), intent(in) :: system(LEN_SYSTEM), saddle(8)
    real(c_double), intent(in) :: params(MAX_PARAMS), lo(MAX_DOF), hi(MAX_DOF)
    integer(c_int), value :: n_grid, sec_kind, sec_index, dir
    real(c_double), value :: de, level, t_max
    integer(c_int), value :: n_seeds, n_iter, method, solver, max_iter
    real(c_double), value :: h, omega_bind
    real(c_double), intent(out) :: pts(2, n_iter, n_seeds)
    type(c_ptr), value :: stores          !! from tubes_seed_stores_new, or NULL
    type(study_t) :: st
    type(section_choice_t) :: sec
    type(seed_stores_t), pointer :: kept
    call study_of(system, params, lo, hi, n_grid, saddle, sec_kind, sec_index, level, dir, &
                  integ_of(method, h, omega_bind, solver, max_iter), st, sec)
    kept => stores_of(stores)
    call maps_at(st, sec, de, n_seeds, n_iter, t_max, pts, stat, kept)
  end function c_poincare

  !> Frames per track of the synthetic experiment (include/tubes.h).
  integer(c_int) function c_experiment_samples(duration, camera_rate) result(ns) &
      bind(C, name='tubes_experiment_samples')
    real(c_double), value :: duration, camera_rate
    ns = experiment_samples(duration, camera_rate)
  end function c_experiment_samples

  !> The synthetic experiment's release box [cm] and integration tolerance (rtol = atol), the
  !> defaults of experiment_opts_t (include/tubes.h).
  subroutine c_experiment_defaults(box, rtol) bind(C, name='tubes_experiment_defaults')
    real(c_double), intent(out) :: box, rtol
    type(experiment_opts_t) :: d
    box = d%box
    rtol = d%rtol
  end subroutine c_experiment_defaults

  !> Synthetic tracking data (include/tubes.h, src/experiment/tubes_experiment.f90).
  integer(c_int) function c_synthetic_experiment(params, e_e, n_tracks, duration, camera_rate, &
      pixel, noise, de_min, de_max, box, seed, rtol, method, h, omega_bind, solver, max_iter, ns, t, &
      state, energy, noisy, measured, release, c_damp, n_draws) result(stat) &
      bind(C, name='tubes_synthetic_experiment')
    real(c_double), intent(in) :: params(MAX_PARAMS)
    real(c_double), value :: e_e, duration, camera_rate, pixel, noise, de_min, de_max, box, rtol, h, &
      omega_bind
    integer(c_int), value :: n_tracks, seed, ns, method, solver, max_iter
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
    opts = experiment_opts_t(n_tracks=n_tracks, duration=duration, camera_rate=camera_rate, pixel=pixel, &
                             noise=noise, de_min=de_min, de_max=de_max, e_e=e_e, box=box, &
                             seed=int(seed, c_long), rtol=rtol, atol=rtol)
    call synthetic_experiment(params(1:NMODEL), opts, integ_of(method, h, omega_bind, solver, max_iter), t, &
                              state, energy, noisy, measured, release, c_damp, n_draws, stat)
  end function c_synthetic_experiment

  subroutine c_sampler_on_step(self, ig, t_hi)
    class(c_sampler_t), intent(inout) :: self
    class(integrator_t), intent(inout) :: ig
    real(wp), intent(in) :: t_hi
    procedure(progress_i), pointer :: f
    call self%sampler_t%on_step(ig, t_hi)
    if (mod(self%count, PROGRESS_EVERY) == 0 .and. c_associated(self%cb)) then
      call c_f_procpointer(self%cb, f)
      self%stop_now = f(ig%t, self%user) /= 0
    end if
  end subroutine c_sampler_on_step
end module tubes_capi
