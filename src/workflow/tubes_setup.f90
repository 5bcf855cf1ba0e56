!> The run's set-up rules, one definition for both front ends: src/io/tubes_scenes.c (run_setup)
!> calls the bind(C) entries, python/tubes_f2py.f90 (tubes._settings, _method, _dissipation) the
!> Fortran ones. Each
!> returns a code and, where the rule refuses, the body of the message; the front end adds its
!> head (the input file and line, or the calling function).
module tubes_setup
  use, intrinsic :: iso_c_binding, only: c_double, c_int, c_char, c_ptr, c_intptr_t
  use tubes_kinds, only: wp
  use tubes_cstrings, only: c_to_f, f_to_c, num
  use tubes_status, only: TUBES_OK, TUBES_ENOCONV, status_message
  use tubes_hamiltonian, only: hamiltonian_t
  use tubes_equilibria, only: equilibrium_t
  use tubes_study, only: seed_stores_t, model_equilibria, stores_at, de_floor
  use tubes_field, only: vector_field_t
  use tubes_models, only: system_info_t, system_info, make_field, MAX_PARAMS, MAX_DOF, LEN_SYSTEM
  use tubes_methods, only: METHOD_AUTO, METHOD_TAYLOR, METHOD_DOP853
  use tubes_taylor, only: taylor_check
  use tubes_record, only: record_t
  implicit none
  private

  !> A model's dissipation (docs/dissipation.md), from its parameters damping_ratio (zeta),
  !> rolling_resistance (crr), noise and temperature: the law, the rates they give (c = 2 zeta
  !> omega_1 [1/s], the rolling drag f = crr g [cm/s^2]) and the run's sentence about it. The one
  !> definition of what the scenes say and record of it (src/io/tubes_scenes.c, tubes._dissipation).
  type, public :: dissipation_t
    character(:), allocatable :: law    !! 'viscous', 'rolling', 'noise' joined by '+' ('': conservative)
    character(:), allocatable :: text   !! "damping_ratio = 0.025, c = 0.123 1/s; ..." ('': conservative)
    real(wp) :: zeta = 0, crr = 0, noise = 0, temperature = 0, c = 0, f = 0
  end type dissipation_t

  integer, parameter, public :: SADDLE_FOUND = 0       !! the saddle chosen
  integer, parameter, public :: SADDLE_NOT_ONE = 1     !! the name is not a saddle the scenes take
  integer, parameter, public :: SADDLE_NONE_NEAR = 2   !! no saddle the scenes take in the box

  public :: choose_saddle, scene_refused, model_dissipation, method_resolved, run_saddle, dissipation_attrs, &
            scene_dissipation, de_unresolved, default_refused

  integer, parameter, public :: SCENE_TAKEN = 0           !! the scene applies to the model
  integer, parameter, public :: SCENE_NOT_FOR_MODEL = 1   !! not with this many degrees of freedom
  integer, parameter, public :: SCENE_NEEDS_PLANE = 2     !! a 3-DOF tubes scene with a ray section

contains

  !> The run's saddle among the equilibria found in the &equilibria box: names(i), kinds(i) (1 a
  !> rank-1 saddle, 2 a degenerate one: a mode without quadratic term, 0 anything else) and
  !> positions q(:, i) (ndof rows). By name, or (use_near) the nearest to near (squared distance;
  !> the first of equal ones) of those the scenes take: a rank-1 saddle, or a degenerate one where
  !> every scene takes it (degenerate_ok: equilibria and the sampled flux). k: the index chosen
  !> (0 where none). label: the model's name in the message; dflt: the name is the system's
  !> default (not given).
  integer function choose_saddle(names, kinds, q, name, use_near, near, degenerate_ok, label, dflt, k, msg) &
      result(code)
    character(*), intent(in) :: names(:), name, label
    integer, intent(in) :: kinds(:)
    real(wp), intent(in) :: q(:, :), near(:)
    logical, intent(in) :: use_near, degenerate_ok, dflt
    integer, intent(out) :: k
    character(*), intent(out) :: msg
    integer :: i, nd
    real(wp) :: d, dbest
    character(:), allocatable :: listed
    code = SADDLE_FOUND
    msg = ''
    k = 0
    nd = size(q, 1)
    if (use_near) then
      dbest = 0
      do i = 1, size(names)
        if (.not. takes(i)) cycle
        d = sum((q(1:nd, i) - near(1:nd))**2)
        if (k == 0 .or. d < dbest) then
          k = i
          dbest = d
        end if
      end do
      if (k == 0) then
        code = SADDLE_NONE_NEAR
        msg = 'system ' // trim(label) // ' has no rank-1 saddle in the &equilibria box (its equilibria: the ' // &
          'equilibria scene lists them); widen &equilibria box or name a saddle'
      end if
      return
    end if
    do i = 1, size(names)
      if (trim(names(i)) == trim(name)) k = i
    end do
    if (k > 0) then
      if (takes(k)) return
    end if
    code = SADDLE_NOT_ONE
    listed = ''
    do i = 1, size(names)
      if (kinds(i) /= 1) cycle
      if (len(listed) > 0) listed = listed // ','
      listed = listed // ' ' // trim(names(i))
    end do
    if (len(listed) == 0) listed = ' none'
    msg = 'saddle = ''' // trim(name) // ''''
    if (dflt) msg = trim(msg) // ' (the system''s default)'
    msg = trim(msg) // ' is not a rank-1 saddle of system ' // trim(label) // ' in the &equilibria box; its ' // &
      'rank-1 saddles are:' // listed // ' (choose one, or set &orbits saddle_near)'
    if (k > 0) then
      if (kinds(k) == 2) msg = trim(msg) // '; ' // trim(name) // ' is a degenerate saddle (a mode without ' // &
        'quadratic term): only the scenes equilibria and flux (sampled) take it'
    end if
    k = 0

  contains

    logical function takes(j)
      integer, intent(in) :: j
      takes = kinds(j) == 1 .or. (kinds(j) == 2 .and. degenerate_ok)
    end function takes
  end function choose_saddle

  !> The run's saddle: the model's equilibria in the box [lo, hi] (n_grid starts per axis; kept in
  !> stores), then choose_saddle among them (name, use_near, near, degenerate_ok, label, dflt as
  !> there). Returns choose_saddle's code, or the equilibria search's status (< 0) with msg saying
  !> so; chosen, e_saddle: the saddle's name and energy where found.
  integer function run_saddle(system, params, lo, hi, n_grid, stores, name, use_near, near, degenerate_ok, label, &
                              dflt, chosen, e_saddle, msg) result(code)
    character(*), intent(in) :: system, name, label
    real(wp), intent(in) :: params(:), lo(:), hi(:), near(:)
    integer, intent(in) :: n_grid
    type(seed_stores_t), pointer, intent(in) :: stores
    logical, intent(in) :: use_near, degenerate_ok, dflt
    character(*), intent(out) :: chosen, msg
    real(wp), intent(out) :: e_saddle
    class(hamiltonian_t), allocatable :: model
    type(equilibrium_t), allocatable :: eqs(:)
    character(8), allocatable :: names(:)
    real(wp), allocatable :: q(:, :)
    integer :: stat, k, i, nd
    chosen = ''
    e_saddle = 0
    call model_equilibria(system, params, lo, hi, n_grid, stores, model, eqs, stat)
    if (stat /= TUBES_OK) then
      code = stat
      msg = 'the equilibria of ' // trim(label) // ' in the &equilibria box could not be found: ' // &
            status_message(stat) // ' (status ' // itoa(stat) // ')'
      if (stat == TUBES_ENOCONV) msg = trim(msg) // '; or the box holds more than 256 of them: a smaller box'
      return
    end if
    nd = model%ndof()
    allocate (names(size(eqs)), q(nd, size(eqs)))
    do i = 1, size(eqs)
      names(i) = eqs(i)%name
      q(:, i) = eqs(i)%q(1:nd)
    end do
    code = choose_saddle(names, [(merge(1, merge(2, 0, eqs(i)%degenerate), eqs(i)%rank1), i = 1, size(eqs))], q, &
                         name, use_near, near(1:nd), degenerate_ok, label, dflt, k, msg)
    if (k < 1) return
    chosen = eqs(k)%name
    e_saddle = eqs(k)%energy
  contains
    pure function itoa(i) result(t)
      integer, intent(in) :: i
      character(:), allocatable :: t
      character(16) :: b
      write (b, '(i0)') i
      t = trim(b)
    end function itoa
  end function run_saddle

  !> Whether the scene applies to a model with ndof degrees of freedom (plane: the section is a
  !> plane, not the ball's ray): the scenes on a Poincare section's region (transition, montecarlo,
  !> sections) and the trajectory scene need 2; the tubes scene 2, or 3 with a plane (it cuts the
  !> manifolds of any family there: docs/tubes.md, "Tubes of halo orbits"); the orbits scene at
  !> least 2. label: the model's name in the message.
  integer function scene_refused(scene, ndof, plane, label, msg) result(code)
    character(*), intent(in) :: scene, label
    integer, intent(in) :: ndof
    logical, intent(in) :: plane
    character(*), intent(out) :: msg
    character(12) :: n
    code = SCENE_TAKEN
    msg = ''
    write (n, '(i0)') ndof
    select case (scene)
    case ('transition', 'montecarlo', 'sections', 'tubes')
      if (ndof == 2 .or. (scene == 'tubes' .and. ndof == 3 .and. plane)) return
      if (scene == 'tubes' .and. ndof == 3) then
        code = SCENE_NEEDS_PLANE
        msg = 'the tubes scene of system ' // trim(label) // ' (' // trim(n) // ' degrees of freedom) cuts the ' // &
          'manifolds with a plane: set kind = ''plane'', index, value and direction'
        return
      end if
      code = SCENE_NOT_FOR_MODEL
      msg = '''' // trim(scene) // ''' works on the region of a Poincare section of a model with 2 degrees of ' // &
        'freedom; system ' // trim(label) // ' has ' // trim(n) // ' (with ' // trim(n) // ': equilibria, ' // &
        'orbits (&orbits family), tubes (on a plane), flux)'
    case ('trajectory')
      if (ndof == 2) return
      code = SCENE_NOT_FOR_MODEL
      msg = '''trajectory'' takes (x0, y0, px0, py0) of a model with 2 degrees of freedom; system ' // &
        trim(label) // ' has ' // trim(n) // ' (Python''s tubes.integrate takes any state)'
    case ('orbits')
      if (ndof >= 2) return
      code = SCENE_NOT_FOR_MODEL
      msg = '''orbits'' follows the Lyapunov orbits of a saddle''s centre directions: system ' // trim(label) // &
        ' has 1 degree of freedom and none (its saddles have no periodic orbits)'
    end select
  end function scene_refused

  !> The dissipation of system (params): d. dimensioned: the model has the ball's units (the text
  !> gives them). stat: TUBES_OK, or make_field's status where the law needs the lowest well's slow
  !> mode omega_1 and it failed (TUBES_EINPUT: the model has no well in its box).
  subroutine model_dissipation(system, params, dimensioned, d, stat)
    character(*), intent(in) :: system
    real(wp), intent(in) :: params(:)
    logical, intent(in) :: dimensioned
    type(dissipation_t), intent(out) :: d
    integer, intent(out) :: stat
    type(system_info_t) :: info
    class(vector_field_t), allocatable :: field
    real(wp) :: p(MAX_PARAMS)
    integer :: k
    d%law = ''
    d%text = ''
    call system_info(system, info, stat)
    if (stat /= TUBES_OK) return
    do k = 1, info%np
      select case (trim(info%params(k)%name))
      case ('damping_ratio'); d%zeta = params(k)
      case ('rolling_resistance'); d%crr = params(k)
      case ('noise'); d%noise = params(k)
      case ('temperature'); d%temperature = params(k)
      end select
    end do
    if (d%zeta > 0) d%law = 'viscous'
    if (d%crr > 0) d%law = join(d%law, 'rolling', '+')
    if (d%noise > 0 .or. d%temperature > 0) d%law = join(d%law, 'noise', '+')
    if (d%law == '') return
    p = 0
    p(1:min(size(params), MAX_PARAMS)) = params(1:min(size(params), MAX_PARAMS))
    call make_field(system, p, field, d%c, stat, d%f)
    if (stat /= TUBES_OK) return
    if (d%zeta > 0) d%text = 'damping_ratio = ' // num(d%zeta) // ', c = ' // num(d%c, '%.6g') // units(' 1/s')
    if (d%crr > 0) d%text = join(d%text, 'rolling_resistance = ' // num(d%crr) // ', f = ' // num(d%f, '%.6g') // &
                                 units(' cm/s^2'), '; ')
    if (d%noise > 0) then
      d%text = join(d%text, 'noise = ' // num(d%noise) // units(' (cm/s)^2/s'), '; ')
    else if (d%temperature > 0) then
      d%text = join(d%text, 'temperature = ' // num(d%temperature) // units(' (cm/s)^2'), '; ')
    end if
  contains
    pure function join(a, b, sep) result(r)
      character(*), intent(in) :: a, b, sep
      character(:), allocatable :: r
      r = b
      if (len(a) > 0) r = a // sep // b
    end function join
    function units(u) result(r)
      character(*), intent(in) :: u
      character(:), allocatable :: r
      r = ''
      if (dimensioned) r = u
    end function units
  end subroutine model_dissipation

  !> The dissipation d's attributes of group in rec (docs/output.md): dissipation (the law),
  !> damping_ratio and damping_rate, rolling_resistance and rolling_drag (those of the laws in use),
  !> noise, temperature; none for a conservative model. held: only where rec already holds an item
  !> of group (named held, where not '').
  subroutine dissipation_attrs(d, group, rec, held)
    type(dissipation_t), intent(in) :: d
    character(*), intent(in) :: group
    type(record_t), intent(inout) :: rec
    character(*), intent(in), optional :: held
    integer :: k
    if (.not. allocated(d%law)) return
    if (len(d%law) == 0) return
    if (present(held)) then
      do k = 1, rec%n_items
        if (rec%items(k)%group /= group) cycle
        if (len(held) == 0) exit
        if (rec%items(k)%name == held) exit
      end do
      if (k > rec%n_items) return
    end if
    call rec%attr_string(group, 'dissipation', d%law)
    if (d%zeta > 0) then
      call rec%attr_real(group, 'damping_ratio', d%zeta)
      call rec%attr_real(group, 'damping_rate', d%c)
    end if
    if (d%crr > 0) then
      call rec%attr_real(group, 'rolling_resistance', d%crr)
      call rec%attr_real(group, 'rolling_drag', d%f)
    end if
    if (d%noise > 0) call rec%attr_real(group, 'noise', d%noise)
    if (d%temperature > 0) call rec%attr_real(group, 'temperature', d%temperature)
  end subroutine dissipation_attrs

  !> The dissipation of system (params) for a scene's records (model_dissipation's, its text
  !> without units): conservative where it fails (the model scene said so before any other ran).
  function scene_dissipation(system, params) result(d)
    character(*), intent(in) :: system
    real(wp), intent(in) :: params(:)
    type(dissipation_t) :: d
    integer :: stat
    call model_dissipation(system, params, .false., d, stat)
    if (stat /= TUBES_OK) d%law = ''
  end function scene_dissipation

  !> The method a run integrates with (docs/integrators-taylor.md): code itself, but 'taylor' and
  !> 'auto' need the model's Taylor kernel at relative tolerance eps (built or loaded now): without
  !> it 'auto' becomes DOP853 throughout (why: the reason, for the run's warning) and 'taylor' is
  !> refused (result 0; why: the reason).
  integer function method_resolved(code, system, params, eps, why) result(m)
    integer, intent(in) :: code
    character(*), intent(in) :: system
    real(wp), intent(in) :: params(:), eps
    character(*), intent(out) :: why
    class(vector_field_t), allocatable :: field
    real(wp) :: c, p(MAX_PARAMS)
    integer :: stat
    m = code
    why = ''
    if (code /= METHOD_AUTO .and. code /= METHOD_TAYLOR) return
    p = 0
    p(1:min(size(params), MAX_PARAMS)) = params(1:min(size(params), MAX_PARAMS))
    call make_field(system, p, field, c, stat)
    if (stat == TUBES_OK) call taylor_check(field, eps, why, stat)
    if (stat == TUBES_OK) return
    if (why == '') why = 'the model could not be made'
    m = merge(METHOD_DOP853, 0, code == METHOD_AUTO)
  end function method_resolved

  !> The first of a group's excess energies des below what the energy resolves at the saddle (its
  !> energy ee; tubes_study de_floor): its index (1-based) and the message's body in msg, or 0.
  integer function de_unresolved(des, group, saddle, ee, msg) result(k)
    real(wp), intent(in) :: des(:), ee
    character(*), intent(in) :: group, saddle
    character(*), intent(out) :: msg
    real(wp) :: need, res
    msg = ''
    need = de_floor(ee)
    res = need/1e6_wp
    do k = 1, size(des)
      if (abs(des(k)) >= need) cycle
      msg = '&' // group // ' de = ' // num(des(k)) // ': below what the energy resolves at the saddle ' // saddle // &
            ': E_e = ' // num(ee, '.10g') // ' is known to about ' // num(res, '.2g') // ' (16 ulps), and E_e + dE ' // &
            'only to a relative ' // num(res/abs(des(k)), '.2g') // ' of dE; dE must be at least ' // num(need, '.3g') // &
            ' (16 ulps a millionth of it), or H''s additive constant smaller (a large constant term: the ball''s h0)'
      return
    end do
    k = 0
  end function de_unresolved

  !> The defaults that are the paper's, in the four-well ball's units and place: the scenes' excess
  !> energies (&GROUP de) and the trajectory's start (GROUP 'trajectory': x0, y0). Which models have
  !> them is the registry's (their annotations' DEFAULT 'rolling_ball: ...; other models: required' in
  !> src/workflow/tubes_config.f90; default_given is generated from them): the library's rolling ball
  !> (model 'rolling_ball') has them; any other model (another system, or the ball on a formula
  !> surface) must give them. Before, a formula model ran the ball's 15 energies 1 .. 750 (NaN rows,
  !> exit 4) and Henon-Heiles' trajectory started at the ball's (4, 12.6) cm and blew up. 0 when the
  !> model has the default, else 1 with the message's body in msg (label: the model as messages name
  !> it).
  integer function default_refused(model, group, label, msg) result(k)
    character(*), intent(in) :: model, group, label
    character(*), intent(out) :: msg
    msg = ''
    k = 0
    if (group == 'trajectory') then
      if (default_given(model, group, 'x0') .and. default_given(model, group, 'y0')) return
      k = 1
      msg = '&trajectory: x0 or y0 is not set: system ' // label // ' has no default start (the default, (' // &
            default_text(group, 'x0') // ', ' // default_text(group, 'y0') // ') cm, is on the four-well ball''s ' // &
            'surface); give x0, y0 (and px0, py0 or at_rest) in the model''s units (docs/input.md)'
    else
      if (default_given(model, group, 'de')) return
      k = 1
      msg = '&' // group // ': de is not set: system ' // label // ' has no default excess energies (the ' // &
            'defaults are the four-well ball''s, in (cm/s)^2); give de in the model''s energy units for the ' // &
            'scene ''' // group // ''' (docs/input.md)'
    end if
  end function default_refused

  ! the registry's per-model defaults: default_given, default_text (generated, src/io/tubes_registry_gen.awk)
  include 'nml_defaults.inc'

  ! ---------------------------------------------------------------- the C entries (src/io/tubes_scenes.c)

  !> default_refused for C: model, group and label NUL-terminated, msg (len bytes) NUL-terminated.
  integer(c_int) function c_default_refused(model, group, label, msg, len) result(k) &
      bind(C, name='tubes_default_refused')
    character(kind=c_char), intent(in) :: model(*), group(*), label(*)
    integer(c_int), value :: len
    character(kind=c_char), intent(out) :: msg(len)
    character(1024) :: m
    k = default_refused(c_to_f(model(1:32)), c_to_f(group(1:32)), c_to_f(label(1:256)), m)
    call f_to_c(m, msg)
  end function c_default_refused


  !> de_unresolved for C: group and saddle NUL-terminated, msg (len bytes) NUL-terminated.
  integer(c_int) function c_de_unresolved(n, des, group, saddle, ee, msg, len) result(k) &
      bind(C, name='tubes_de_unresolved')
    integer(c_int), value :: n, len
    real(c_double), intent(in) :: des(n)
    character(kind=c_char), intent(in) :: group(*), saddle(*)
    real(c_double), value :: ee
    character(kind=c_char), intent(out) :: msg(len)
    character(1024) :: m
    k = de_unresolved(des, c_to_f(group(1:32)), c_to_f(saddle(1:8)), ee, m)
    call f_to_c(m, msg)
  end function c_de_unresolved

  integer(c_int) function c_scene_refused(scene, ndof, plane, label, msg, len) result(code) &
      bind(C, name='tubes_scene_refused')
    character(kind=c_char), intent(in) :: scene(*), label(*)
    integer(c_int), value :: ndof, plane, len
    character(kind=c_char), intent(out) :: msg(len)
    character(1024) :: m
    code = scene_refused(c_to_f(scene(1:32)), ndof, plane /= 0, c_to_f(label(1:64)), m)
    call f_to_c(m, msg)
  end function c_scene_refused


  !> method_resolved for C (why: NUL-terminated, lwhy bytes).
  integer(c_int) function c_method_resolved(code, system, params, eps, why, lwhy) result(m) &
      bind(C, name='tubes_method_resolved')
    integer(c_int), value :: code, lwhy
    character(kind=c_char), intent(in) :: system(LEN_SYSTEM)
    real(c_double), intent(in) :: params(MAX_PARAMS)
    real(c_double), value :: eps
    character(kind=c_char), intent(out) :: why(lwhy)
    character(1024) :: w
    m = method_resolved(code, trim(c_to_f(system)), params, eps, w)
    call f_to_c(w, why)
  end function c_method_resolved

  !> run_saddle for C: name, label NUL-terminated; chosen (8 bytes) and msg (len bytes) NUL-terminated.
  integer(c_int) function c_run_saddle(system, params, lo, hi, n_grid, stores, name, use_near, near, degenerate_ok, &
                                       label, dflt, chosen, e_saddle, msg, len) result(code) bind(C, name='tubes_run_saddle')
    character(kind=c_char), intent(in) :: system(LEN_SYSTEM), name(8), label(*)
    real(c_double), intent(in) :: params(MAX_PARAMS), lo(MAX_DOF), hi(MAX_DOF), near(MAX_DOF)
    integer(c_int), value :: n_grid, use_near, degenerate_ok, dflt, len
    type(c_ptr), value :: stores
    character(kind=c_char), intent(out) :: chosen(8), msg(len)
    real(c_double), intent(out) :: e_saddle
    type(seed_stores_t), pointer :: kept
    character(2048) :: m
    character(8) :: ch
    kept => stores_at(transfer(stores, 0_c_intptr_t))
    code = run_saddle(trim(c_to_f(system)), params, lo, hi, n_grid, kept, c_to_f(name), use_near /= 0, near, &
                      degenerate_ok /= 0, c_to_f(label(1:64)), dflt /= 0, ch, e_saddle, m)
    call f_to_c(ch, chosen)
    call f_to_c(m, msg)
  end function c_run_saddle
end module tubes_setup
