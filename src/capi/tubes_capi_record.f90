!> The scenes of the core (src/workflow/tubes_scene_*.f90) for the C driver, and their result
!> records read item by item (include/tubes.h, "Scenes and their records"; src/io/tubes_record_write.c
!> walks a record into the output file and onto the console).
module tubes_capi_record
  use, intrinsic :: iso_c_binding, only: c_int, c_double, c_char, c_ptr, c_intptr_t, c_long_long
  use tubes_cstrings, only: c_to_f, f_to_c
  use tubes_models, only: MAX_PARAMS, MAX_DOF, LEN_SYSTEM
  use tubes_study, only: seed_stores_t, stores_at
  use tubes_record, only: record_t, record_keep, record_drop, record_sizes, record_item_info, record_reals, &
                          record_ints, record_string, record_line, record_long
  use tubes_scene_equilibria, only: scene_equilibria
  use tubes_scene_section, only: scene_section_alone
  use tubes_scene_sections, only: scene_sections
  use tubes_scene_synthetic_experiment, only: scene_synthetic_experiment
  use tubes_scene_trajectory, only: scene_trajectory
  use tubes_scene_flux, only: scene_flux
  use tubes_config, only: tubes_config_t
  use tubes_scene_orbits, only: scene_orbits
  use tubes_orbits, only: orbit_opts_t
  use tubes_study, only: study_t, section_choice_t
  use tubes_capi, only: study_of, integ_of, guess_opts
  use tubes_scene_transition, only: scene_transition
  use tubes_scene_montecarlo, only: scene_montecarlo
  use tubes_scene_tubes, only: scene_tubes
  use tubes_scene_scan, only: scene_scan
  use tubes_scene_model, only: scene_model_of
  implicit none
  private

contains

  !> The equilibria scene (tubes_scene_equilibria): the record's handle (free it with tubes_record_free).
  integer(c_int) function c_scene_equilibria(cfg, want, asked, label, dissip, stores) result(h) &
      bind(C, name='tubes_equilibria_scene')
    type(tubes_config_t), intent(in) :: cfg
    character(kind=c_char), intent(in) :: want(8), label(64), dissip(128)
    integer(c_int), value :: asked
    type(c_ptr), value :: stores
    type(record_t), allocatable :: rec
    allocate (rec)
    call scene_equilibria(cfg, trim(c_to_f(want)), asked /= 0, trim(c_to_f(label)), trim(c_to_f(dissip)), &
                          stores_at(transfer(stores, 0_c_intptr_t)), rec)
    h = record_keep(rec)
  end function c_scene_equilibria

  !> The model scene (tubes_scene_model) on the run's settings cfg; natural and dimensioned the model's
  !> kind, input the input file ('' none). Its dissipation back for the run's drivers: law and text
  !> NUL-terminated (lens bytes each), v = (zeta, crr, noise, temperature, c, f) (tubes_setup
  !> model_dissipation's dissipation_t). The record's handle.
  integer(c_int) function c_scene_model(cfg, natural, dimensioned, input, law, text, lens, v) result(h) &
      bind(C, name='tubes_model_scene')
    use tubes_setup, only: dissipation_t
    type(tubes_config_t), intent(in) :: cfg
    character(kind=c_char), intent(in) :: input(*)
    integer(c_int), value :: natural, dimensioned, lens
    character(kind=c_char), intent(out) :: law(lens), text(lens)
    real(c_double), intent(out) :: v(6)
    type(record_t), allocatable :: rec
    type(dissipation_t) :: d
    allocate (rec)
    call scene_model_of(cfg, natural /= 0, dimensioned /= 0, c_to_f(input(1:4096)), rec, d)
    call f_to_c(d%law, law)
    call f_to_c(d%text, text)
    v = [d%zeta, d%crr, d%noise, d%temperature, d%c, d%f]
    h = record_keep(rec)
  end function c_scene_model

  !> Map k (0-based) of the sections scene (tubes_scene_sections) on the run's settings cfg, with the
  !> saddle and the method the run chose; dissipative /= 0: the run's model dissipates. The record's
  !> handle.
  integer(c_int) function c_scene_sections(cfg, saddle, method, k, dissipative, stores) result(h) &
      bind(C, name='tubes_sections_scene')
    type(tubes_config_t), intent(in) :: cfg
    character(kind=c_char), intent(in) :: saddle(8)
    integer(c_int), value :: method, k, dissipative
    type(c_ptr), value :: stores
    type(record_t), allocatable :: rec
    allocate (rec)
    call scene_sections(cfg, trim(c_to_f(saddle)), int(method), int(k), dissipative /= 0, &
                        stores_at(transfer(stores, 0_c_intptr_t)), rec)
    h = record_keep(rec)
  end function c_scene_sections

  !> The synthetic_experiment scene (tubes_scene_synthetic_experiment) on the run's settings cfg, with
  !> the saddle and the method the run chose. The record's handle.
  integer(c_int) function c_scene_synthetic_experiment(cfg, saddle, method, stores) result(h) &
      bind(C, name='tubes_synthetic_experiment_scene')
    type(tubes_config_t), intent(in) :: cfg
    character(kind=c_char), intent(in) :: saddle(8)
    integer(c_int), value :: method
    type(c_ptr), value :: stores
    type(record_t), allocatable :: rec
    allocate (rec)
    call scene_synthetic_experiment(cfg, trim(c_to_f(saddle)), int(method), stores_at(transfer(stores, 0_c_intptr_t)), &
                                    rec)
    h = record_keep(rec)
  end function c_scene_synthetic_experiment

  !> The trajectory scene (tubes_scene_trajectory) on the run's settings cfg with the method the run
  !> chose, the run's dissipation (zeta, crr, f_roll, dissip in words), label the model's name, input
  !> the input file, us and ue the time's and the energy's units in messages. The record's handle.
  integer(c_int) function c_scene_trajectory(cfg, method, zeta, crr, f_roll, dissip, label, input, us, ue, stores) &
      result(h) bind(C, name='tubes_trajectory_scene')
    type(tubes_config_t), intent(in) :: cfg
    integer(c_int), value :: method
    real(c_double), value :: zeta, crr, f_roll
    character(kind=c_char), intent(in) :: label(64)
    character(kind=c_char), intent(in) :: dissip(*), input(*), us(*), ue(*)   ! (C literals)
    type(c_ptr), value :: stores
    type(record_t), allocatable :: rec
    allocate (rec)
    call scene_trajectory(cfg, int(method), zeta, crr, f_roll, c_to_f(dissip(1:128)), trim(c_to_f(label)), &
                          c_to_f(input(1:1024)), c_to_f(us(1:16)), c_to_f(ue(1:16)), stores_at(transfer(stores, 0_c_intptr_t)), &
                          rec)
    h = record_keep(rec)
  end function c_scene_trajectory

  !> The flux scene (tubes_scene_flux) on the run's settings cfg, with the saddle and the method the
  !> run chose; who names the input file in messages. The record's handle.
  integer(c_int) function c_scene_flux(cfg, saddle, method, who, stores) result(h) bind(C, name='tubes_flux_scene')
    type(tubes_config_t), intent(in) :: cfg
    character(kind=c_char), intent(in) :: saddle(8), who(*)
    integer(c_int), value :: method
    type(c_ptr), value :: stores
    type(record_t), allocatable :: rec
    type(seed_stores_t), pointer :: kept
    allocate (rec)
    kept => stores_at(transfer(stores, 0_c_intptr_t))
    call scene_flux(cfg, trim(c_to_f(saddle)), int(method), c_to_f(who(1:4096)), kept, rec)
    h = record_keep(rec)
  end function c_scene_flux

  !> The orbits scene (tubes_scene_orbits) on the run's settings cfg, with the saddle and the method the
  !> run chose; dimensioned /= 0: the ball's units; dissipative /= 0: the run's model dissipates. The
  !> record's handle (free it with tubes_record_free).
  integer(c_int) function c_scene_orbits(cfg, saddle, method, dimensioned, dissipative, stores) result(rh) &
      bind(C, name='tubes_orbits_scene')
    type(tubes_config_t), intent(in) :: cfg
    character(kind=c_char), intent(in) :: saddle(8)
    integer(c_int), value :: method, dimensioned, dissipative
    type(c_ptr), value :: stores
    type(record_t), allocatable :: rec
    allocate (rec)
    call scene_orbits(cfg, trim(c_to_f(saddle)), int(method), dimensioned /= 0, dissipative /= 0, &
                      stores_at(transfer(stores, 0_c_intptr_t)), rec)
    rh = record_keep(rec)
  end function c_scene_orbits

  !> The transition scene (tubes_scene_transition) on the run's settings cfg, with the saddle and the
  !> method the run chose; units /= 0: the messages carry the ball's units; dissip: the dissipation in
  !> words ('' conservative); written /= 0: /section is in the output already. The record's handle.
  integer(c_int) function c_scene_transition(cfg, saddle, method, units, dissip, written, stores) result(hd) &
      bind(C, name='tubes_transition_scene')
    type(tubes_config_t), intent(in) :: cfg
    character(kind=c_char), intent(in) :: saddle(8), dissip(128)
    integer(c_int), value :: method, units, written
    type(c_ptr), value :: stores
    type(record_t), allocatable :: rec
    allocate (rec)
    call scene_transition(cfg, trim(c_to_f(saddle)), int(method), units /= 0, trim(c_to_f(dissip)), written /= 0, &
                          stores_at(transfer(stores, 0_c_intptr_t)), rec)
    hd = record_keep(rec)
  end function c_scene_transition

  !> The montecarlo scene (tubes_scene_montecarlo), as tubes_transition_scene; noisy /= 0: the model
  !> carries noise; gate_at: the head of a message about &montecarlo gate. The record's handle.
  integer(c_int) function c_scene_montecarlo(cfg, saddle, method, units, dissip, noisy, gate_at, written, stores) &
      result(hd) bind(C, name='tubes_montecarlo_scene')
    type(tubes_config_t), intent(in) :: cfg
    character(kind=c_char), intent(in) :: saddle(8), dissip(128), gate_at(1024)
    integer(c_int), value :: method, units, noisy, written
    type(c_ptr), value :: stores
    type(record_t), allocatable :: rec
    allocate (rec)
    call scene_montecarlo(cfg, trim(c_to_f(saddle)), int(method), units /= 0, trim(c_to_f(dissip)), noisy /= 0, &
                          c_to_f(gate_at), written /= 0, stores_at(transfer(stores, 0_c_intptr_t)), rec)
    hd = record_keep(rec)
  end function c_scene_montecarlo

  !> The tubes scene (tubes_scene_tubes), as tubes_transition_scene; length: the coordinates' units in
  !> words; check_eps /= 0: each cut repeated with eps/10. The record's handle.
  integer(c_int) function c_scene_tubes(cfg, saddle, method, units, length, dissip, check_eps, written, stores) &
      result(hd) bind(C, name='tubes_tubes_scene')
    type(tubes_config_t), intent(in) :: cfg
    character(kind=c_char), intent(in) :: saddle(8), length(32), dissip(128)
    integer(c_int), value :: method, units, check_eps, written
    type(c_ptr), value :: stores
    type(record_t), allocatable :: rec
    allocate (rec)
    call scene_tubes(cfg, trim(c_to_f(saddle)), int(method), units /= 0, trim(c_to_f(length)), trim(c_to_f(dissip)), &
                     check_eps /= 0, written /= 0, stores_at(transfer(stores, 0_c_intptr_t)), rec)
    hd = record_keep(rec)
  end function c_scene_tubes

  !> /section alone (tubes_scene_section) on the run's settings cfg, with the saddle and the method the
  !> run chose, for a scene that draws on the section without its own use of it (sections); written
  !> /= 0: /section exists already. The record's handle.
  integer(c_int) function c_scene_section(cfg, saddle, method, written, stores) result(hd) &
      bind(C, name='tubes_section_scene')
    type(tubes_config_t), intent(in) :: cfg
    character(kind=c_char), intent(in) :: saddle(8)
    integer(c_int), value :: method, written
    type(c_ptr), value :: stores
    type(record_t), allocatable :: rec
    allocate (rec)
    call scene_section_alone(cfg, trim(c_to_f(saddle)), int(method), written /= 0, &
                             stores_at(transfer(stores, 0_c_intptr_t)), rec)
    hd = record_keep(rec)
  end function c_scene_section

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
    integer(c_long_long), intent(out) :: dims(5)
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

  !> Item k's integer attribute (64 bits).
  integer(c_long_long) function c_record_long(h, k) result(v) bind(C, name='tubes_record_long')
    integer(c_int), value :: h, k
    v = record_long(h, k)
  end function c_record_long

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

  !> The scan scene (tubes_scene_scan) on the run's settings cfg (&scan: parameter scan_ipar to scan_to in
  !> scan_n steps, the orbits at scan_de, p_trans with scan_p_trans), with the saddle and the method the
  !> run chose; dissip ("" conservative), input the input's name for messages. The record's handle.
  integer(c_int) function c_scene_scan(cfg, saddle, method, dissip, input) result(hd) bind(C, name='tubes_scan_scene')
    type(tubes_config_t), intent(in) :: cfg
    character(kind=c_char), intent(in) :: saddle(8), dissip(128), input(*)
    integer(c_int), value :: method
    type(record_t), allocatable :: rec
    allocate (rec)
    call scene_scan(cfg, trim(c_to_f(saddle)), int(method), int(cfg%scan_ipar), trim(c_to_f(cfg%scan_parameter)), &
                    cfg%scan_to, int(cfg%scan_n), cfg%scan_de(1:max(cfg%scan_nde, 0)), cfg%scan_p_trans /= 0, &
                    trim(c_to_f(dissip)), c_to_f(input(1:1024)), rec)
    hd = record_keep(rec)
  end function c_scene_scan
end module tubes_capi_record
