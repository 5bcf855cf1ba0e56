!> The scenes of the core (src/workflow/tubes_scene_*.f90) for the C driver, and their result
!> records read item by item (include/tubes.h, "Scenes and their records"; src/io/tubes_record_write.c
!> walks a record into the output file and onto the console).
module tubes_capi_record
  use, intrinsic :: iso_c_binding, only: c_int, c_double, c_char, c_ptr, c_intptr_t, c_long_long
  use tubes_cstrings, only: c_to_f, f_to_c
  use tubes_models, only: MAX_PARAMS, MAX_DOF, LEN_SYSTEM
  use tubes_study, only: seed_stores_t, stores_at
  use tubes_record, only: record_t, record_keep, record_drop, record_sizes, record_item_info, record_reals, &
                          record_ints, record_string, record_line
  use tubes_scene_equilibria, only: scene_equilibria
  use tubes_scene_sections, only: scene_sections
  use tubes_scene_synthetic_experiment, only: scene_synthetic_experiment
  use tubes_scene_trajectory, only: scene_trajectory, trajectory_settings_t
  implicit none
  private

contains

  !> The equilibria scene (tubes_scene_equilibria): the record's handle (free it with tubes_record_free).
  integer(c_int) function c_scene_equilibria(system, params, lo, hi, n_grid, box, want, asked, label, dissip, &
                                             stores) result(h) bind(C, name='tubes_equilibria_scene')
    character(kind=c_char), intent(in) :: system(LEN_SYSTEM), want(8), label(64), dissip(128)
    real(c_double), intent(in) :: params(MAX_PARAMS), lo(MAX_DOF), hi(MAX_DOF)
    integer(c_int), value :: n_grid, asked
    real(c_double), value :: box
    type(c_ptr), value :: stores
    type(record_t), allocatable :: rec
    type(seed_stores_t), pointer :: kept
    allocate (rec)
    kept => stores_at(transfer(stores, 0_c_intptr_t))
    call scene_equilibria(trim(c_to_f(system)), params, lo, hi, n_grid, box, trim(c_to_f(want)), asked /= 0, &
                          trim(c_to_f(label)), trim(c_to_f(dissip)), kept, rec)
    h = record_keep(rec)
  end function c_scene_equilibria

  !> Map k (0-based) of the sections scene (tubes_scene_sections) at excess energy de: the
  !> record's handle. The section and integrator arguments as tubes_poincare's (include/tubes.h).
  integer(c_int) function c_scene_sections(system, params, lo, hi, n_grid, saddle, sec_kind, sec_index, level, &
                                           dir, de, k, n_seeds, n_iter, t_max, method, step, omega_bind, solver, &
                                           max_iter, dissipative, stores) result(h) bind(C, name='tubes_sections_scene')
    use tubes_study, only: study_t, section_choice_t
    use tubes_capi, only: study_of, integ_of
    character(kind=c_char), intent(in) :: system(LEN_SYSTEM), saddle(8)
    real(c_double), intent(in) :: params(MAX_PARAMS), lo(MAX_DOF), hi(MAX_DOF)
    integer(c_int), value :: n_grid, sec_kind, sec_index, dir, k, n_seeds, n_iter, method, solver, max_iter, &
                             dissipative
    real(c_double), value :: level, de, t_max, step, omega_bind
    type(c_ptr), value :: stores
    type(record_t), allocatable :: rec
    type(seed_stores_t), pointer :: kept
    type(study_t) :: st
    type(section_choice_t) :: sec
    allocate (rec)
    call study_of(system, params, lo, hi, n_grid, saddle, sec_kind, sec_index, level, dir, &
                  integ_of(method, step, omega_bind, solver, max_iter), st, sec)
    kept => stores_at(transfer(stores, 0_c_intptr_t))
    call scene_sections(st, sec, de, k, n_seeds, n_iter, t_max, dissipative /= 0, kept, rec)
    h = record_keep(rec)
  end function c_scene_sections

  !> The synthetic_experiment scene (tubes_scene_synthetic_experiment): &experiment's settings,
  !> the integrator (its arguments as tubes_synthetic_experiment's; method_label its name for
  !> /tracks@method): the record's handle.
  integer(c_int) function c_scene_synthetic_experiment(system, params, lo, hi, n_grid, saddle, n_tracks, duration, &
                                                       camera_rate, pixel, noise, de_min, de_max, damping_ratio, &
                                                       rolling_resistance, seed, method, step, omega_bind, solver, &
                                                       max_iter, method_label, stores) result(h) &
      bind(C, name='tubes_synthetic_experiment_scene')
    use, intrinsic :: iso_c_binding, only: c_long
    use tubes_experiment, only: experiment_opts_t
    use tubes_capi, only: integ_of
    character(kind=c_char), intent(in) :: system(LEN_SYSTEM), saddle(8), method_label(32)
    real(c_double), intent(in) :: params(MAX_PARAMS), lo(MAX_DOF), hi(MAX_DOF)
    integer(c_int), value :: n_grid, n_tracks, seed, method, solver, max_iter
    real(c_double), value :: duration, camera_rate, pixel, noise, de_min, de_max, damping_ratio, rolling_resistance, &
                             step, omega_bind
    type(c_ptr), value :: stores
    type(record_t), allocatable :: rec
    type(seed_stores_t), pointer :: kept
    allocate (rec)
    kept => stores_at(transfer(stores, 0_c_intptr_t))
    call scene_synthetic_experiment(trim(c_to_f(system)), params, lo, hi, n_grid, trim(c_to_f(saddle)), &
                                    experiment_opts_t(n_tracks=n_tracks, duration=duration, camera_rate=camera_rate, &
                                                      pixel=pixel, noise=noise, de_min=de_min, de_max=de_max, &
                                                      seed=int(seed, c_long)), damping_ratio, rolling_resistance, &
                                    integ_of(method, step, omega_bind, solver, max_iter), trim(c_to_f(method_label)), &
                                    kept, rec)
    h = record_keep(rec)
  end function c_scene_synthetic_experiment

  !> The trajectory scene (tubes_scene_trajectory): &trajectory's start x0 (at_rest: its momenta
  !> 0), times, section and its settings, the integrator (method as run, its name method_label,
  !> solver its code and solver_name its name), the dissipation (zeta, crr, f_roll, dissip in
  !> words), the box of the equilibria (the energy scale), label and input for messages, us and
  !> ue the time's and the energy's units in them: the record's handle.
  integer(c_int) function c_scene_trajectory(system, params, x0, at_rest, t_end, dt_out, section, section_direction, &
                                             section_angle, section_level, stop_at_first, max_crossings, method, &
                                             method_label, rtol, atol, step, max_steps, omega_bind, solver, &
                                             solver_name, max_iter, zeta, crr, f_roll, dissip, lo, hi, n_grid, label, &
                                             input, us, ue, stores) result(h) bind(C, name='tubes_trajectory_scene')
    use tubes_methods, only: method_opts_t
    character(kind=c_char), intent(in) :: system(LEN_SYSTEM), section(32), solver_name(32), label(64)
    character(kind=c_char), intent(in) :: method_label(*), dissip(*), input(*), us(*), ue(*)   ! (C literals)
    real(c_double), intent(in) :: params(MAX_PARAMS), x0(4), lo(MAX_DOF), hi(MAX_DOF)
    integer(c_int), value :: at_rest, section_direction, stop_at_first, max_crossings, method, solver, max_iter, n_grid
    real(c_double), value :: t_end, dt_out, section_angle, section_level, rtol, atol, step, omega_bind, zeta, crr, f_roll
    integer(c_long_long), value :: max_steps
    type(c_ptr), value :: stores
    type(record_t), allocatable :: rec
    type(seed_stores_t), pointer :: kept
    type(trajectory_settings_t) :: s
    allocate (rec)
    ! (component by component: gfortran 12 garbles a constructor's deferred-length strings)
    s%x0 = x0
    s%at_rest = at_rest /= 0
    s%t_end = t_end
    s%dt_out = dt_out
    s%section = trim(c_to_f(section))
    s%section_direction = section_direction
    s%max_crossings = max_crossings
    s%section_angle = section_angle
    s%section_level = section_level
    s%stop_at_first = stop_at_first /= 0
    s%method = method
    s%method_label = c_to_f(method_label(1:32))
    s%solver = trim(c_to_f(solver_name))
    s%rtol = rtol
    s%atol = atol
    s%h = step
    s%max_steps = max_steps
    s%mopts = method_opts_t(omega_bind=omega_bind, solver=solver, max_iter=max_iter)
    s%zeta = zeta
    s%crr = crr
    s%f_roll = f_roll
    s%dissip = c_to_f(dissip(1:128))
    kept => stores_at(transfer(stores, 0_c_intptr_t))
    call scene_trajectory(trim(c_to_f(system)), params, s, lo, hi, n_grid, trim(c_to_f(label)), &
                          c_to_f(input(1:1024)), c_to_f(us(1:16)), c_to_f(ue(1:16)), kept, rec)
    h = record_keep(rec)
  end function c_scene_trajectory

  !> The record's exit code (the worst verdict's; 0: none), or -1 for no record.
  integer(c_int) function c_record_code(h) result(code) bind(C, name='tubes_record_code')
    integer(c_int), value :: h
    integer :: ni, nl, cd
    call record_sizes(h, cd, ni, nl)
    code = cd
  end function c_record_code

  !> Its numbers of items and of console lines.
  subroutine c_record_sizes(h, n_items, n_lines) bind(C, name='tubes_record_sizes')
    integer(c_int), value :: h
    integer(c_int), intent(out) :: n_items, n_lines
    integer :: ni, nl, cd
    call record_sizes(h, cd, ni, nl)
    n_items = ni
    n_lines = nl
  end subroutine c_record_sizes

  !> Line j (1-based) of its console: stream 1 stdout, 2 stderr; its text into buf (len bytes,
  !> NUL-terminated); its length (to ask again with a larger buf), or -1 for no such line.
  integer(c_int) function c_record_line(h, j, stream, buf, len) result(n) bind(C, name='tubes_record_line')
    integer(c_int), value :: h, j, len
    integer(c_int), intent(out) :: stream
    character(kind=c_char), intent(out) :: buf(len)
    character(:), allocatable :: text
    integer :: s
    call record_line(h, j, s, text)
    stream = s
    n = merge(len_trim(text), -1, s /= 0)
    call f_to_c(text, buf)
  end function c_record_line

  !> Item k (1-based): its kind (tubes_record REC_*), group path, name, units (NUL-terminated),
  !> rank and dims (C order); the number of its values (strings: their count, and in slen the
  !> longest's length). -1: no such item.
  integer(c_int) function c_record_item(h, k, kind, group, name, units, rank, dims, slen) result(n) &
      bind(C, name='tubes_record_item')
    integer(c_int), value :: h, k
    integer(c_int), intent(out) :: kind, rank, slen
    character(kind=c_char), intent(out) :: group(256), name(64), units(32)
    integer(c_long_long), intent(out) :: dims(4)
    character(:), allocatable :: g, nm, u
    integer :: kd, rk, nn, sl
    call record_item_info(h, k, kd, g, nm, u, rk, dims, nn, sl)
    kind = kd
    rank = rk
    n = nn
    slen = sl
    call f_to_c(g, group)
    call f_to_c(nm, name)
    call f_to_c(u, units)
  end function c_record_item

  !> Item k's real values (n of them, C order).
  subroutine c_record_reals(h, k, n, v) bind(C, name='tubes_record_reals')
    integer(c_int), value :: h, k, n
    real(c_double), intent(out) :: v(n)
    call record_reals(h, k, v)
  end subroutine c_record_reals

  !> Item k's integer values (n of them, C order).
  subroutine c_record_ints(h, k, n, v) bind(C, name='tubes_record_ints')
    integer(c_int), value :: h, k, n
    integer(c_int), intent(out) :: v(n)
    call record_ints(h, k, v)
  end subroutine c_record_ints

  !> String j (1-based) of item k, trailing blanks dropped, into buf (len bytes, NUL-terminated).
  subroutine c_record_string(h, k, j, buf, len) bind(C, name='tubes_record_string')
    integer(c_int), value :: h, k, j, len
    character(kind=c_char), intent(out) :: buf(len)
    call f_to_c(record_string(h, k, j), buf)
  end subroutine c_record_string

  !> Forget the record.
  subroutine c_record_free(h) bind(C, name='tubes_record_free')
    integer(c_int), value :: h
    call record_drop(h)
  end subroutine c_record_free
end module tubes_capi_record
