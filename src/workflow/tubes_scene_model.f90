!> The model scene (docs/output.md /model) as one procedure of the core: the model's attributes
!> (its library, Hamiltonian, degrees of freedom, parameters), a formula model's source and
!> library and its console line, and its dissipation (tubes_setup model_dissipation: the law and
!> the rates it makes, or the verdict where its rate cannot be had). It returns a result record
!> (tubes_record) that the program's driver writes (src/io/tubes_record_write.c).
module tubes_scene_model
  use tubes_kinds, only: wp
  use tubes_status, only: TUBES_OK, TUBES_EINPUT
  use tubes_cstrings, only: num
  use tubes_scene_text, only: itoa
  use tubes_record, only: record_t, EXIT_BADINPUT, EXIT_NUMERIC
  use tubes_models, only: system_info_t, system_info
  use tubes_setup, only: dissipation_t, model_dissipation
  use tubes_config, only: tubes_config_t
  use tubes_settings, only: settings_text
  implicit none
  private

  public :: scene_model, scene_model_of, model_formula_t

  !> A model written as a formula (&model hamiltonian or surface/height, docs/models.md): what
  !> /model records of it. Assign component by component (gfortran 12, deferred-length strings).
  type :: model_formula_t
    character(:), allocatable :: sysname     !! &model system ('expression' or a surface's kind)
    character(:), allocatable :: text        !! the Hamiltonian ('expression') or the height
    character(:), allocatable :: coordinates !! &model coordinates, blank-separated ('': the default)
    character(:), allocatable :: momenta     !! &model momenta, blank-separated ('': the default)
    character(:), allocatable :: constants   !! &model constants, '; '-separated
    character(:), allocatable :: library     !! its shared library
    real(wp) :: seconds = 0                  !! the time its build or cache lookup took [s]
    logical :: cached = .false.              !! loaded from the model cache
  end type model_formula_t

contains

  !> The scene on the run's settings cfg: the model's library (cfg%model; expr_<hash> for a formula,
  !> whose &model hamiltonian or height, coordinates, momenta, constants, library and build time it
  !> records), natural and dimensioned its kind, input the input file ('' none); d its dissipation.
  subroutine scene_model_of(cfg, natural, dimensioned, input, rec, d)
    type(tubes_config_t), intent(in) :: cfg
    logical, intent(in) :: natural, dimensioned
    character(*), intent(in) :: input
    type(record_t), intent(inout) :: rec
    type(dissipation_t), intent(out) :: d
    type(model_formula_t) :: f
    character(:), allocatable :: name
    name = settings_text(cfg%model)
    if (name(1:min(5, len(name))) /= 'expr_') then
      call scene_model(name, cfg%params, name, natural, dimensioned, input, rec, d)
      return
    end if
    ! a model written as a formula (component by component: gfortran 12 garbles a constructor's
    ! deferred-length strings)
    f%sysname = settings_text(cfg%system)
    f%text = settings_text(cfg%height)
    if (f%sysname == 'expression') f%text = settings_text(cfg%hamiltonian)
    f%coordinates = joined(cfg%coordinates, ' ', .true.)
    f%momenta = joined(cfg%momenta, ' ', .true.)
    f%constants = joined(cfg%constants, '; ', .false.)
    f%library = settings_text(cfg%expr_lib)
    f%seconds = cfg%expr_seconds
    f%cached = cfg%expr_hit /= 0
    call scene_model(name, cfg%params, f%sysname, natural, dimensioned, input, rec, d, f)
  contains
    !> The C strings of c's columns joined by sep: up to the first empty one (upto), or every one
    !> not empty.
    function joined(c, sep, upto) result(r)
      character(len=1), intent(in) :: c(:, :)
      character(*), intent(in) :: sep
      logical, intent(in) :: upto
      character(:), allocatable :: r
      integer :: k
      r = ''
      do k = 1, size(c, 2)
        if (c(1, k) == achar(0) .and. upto) exit
        if (c(1, k) == achar(0)) cycle
        if (len(r) > 0) r = r // sep
        r = r // settings_text(c(:, k))
      end do
    end function joined
  end subroutine scene_model_of

  !> The scene for system (params), the library's name of the model: name its name as /model
  !> says it (the built-in's library, or for a formula (formula present) the &model system);
  !> natural: H = T + V (the formula's console line says so); dimensioned: the ball's units (the
  !> dissipation's text gives them); input: the input file, for messages ('': "tubes"). rec: the
  !> scene's record; d: the model's dissipation (law '' for a conservative one).
  subroutine scene_model(system, params, name, natural, dimensioned, input, rec, d, formula)
    character(*), intent(in) :: system, name, input
    real(wp), intent(in) :: params(:)
    logical, intent(in) :: natural, dimensioned
    type(record_t), intent(inout) :: rec
    type(dissipation_t), intent(out) :: d
    type(model_formula_t), intent(in), optional :: formula
    type(system_info_t) :: info
    character(:), allocatable :: what, who
    integer :: stat, k
    call system_info(system, info, stat)
    if (stat /= TUBES_OK) then
      d%law = ''
      d%text = ''
      rec%code = EXIT_BADINPUT
      return
    end if
    call rec%attr_string('model', 'system', name)
    call rec%attr_string('model', 'hamiltonian', trim(info%summary))
    call rec%attr_int('model', 'ndof', info%ndof)
    if (len_trim(info%surface) > 0) call rec%attr_string('model', 'surface', trim(info%surface))
    do k = 1, info%np
      call rec%attr_real('model', trim(info%params(k)%name), params(k))
    end do
    if (present(formula)) then
      call formula_attrs(formula, system, rec)
      call rec%attr_real('model', 'library_seconds', formula%seconds)
      call rec%attr_int('model', 'library_cached', merge(1, 0, formula%cached))
      what = 'code generated (SymPy) and compiled in ' // num(formula%seconds, '.2f') // ' s'
      if (formula%cached) what = 'generated code loaded from the cache in ' // num(formula%seconds*1e3_wp, '.1f') // &
                                 ' ms'
      call rec%out('model: ' // trim(info%summary) // ', ' // itoa(info%ndof) // ' degree' // &
                   trim(merge('s', ' ', info%ndof > 1)) // ' of freedom' // trim(merge(', natural', '         ', &
                   natural)) // ': ' // what // ' (' // formula%library // ')')
    end if
    call model_dissipation(system, params, dimensioned, d, stat)
    if (stat /= TUBES_OK) then   ! c = 2 zeta omega_1 (and the noise's step) need the lowest well's slow mode
      if (stat == TUBES_EINPUT) then
        what = 'temperature'
        if (d%noise > 0) what = 'noise'
        if (d%zeta > 0) what = 'damping_ratio'
        who = 'tubes'
        if (len(input) > 0) who = input
        call rec%verdict(EXIT_BADINPUT, who // ': &model ' // what // &
                         ': the model has no well (a minimum of its potential with a positive frequency) in its ' // &
                         'search box, and its dissipation is defined by the lowest well''s slow mode omega_1 ' // &
                         '(docs/dissipation.md#other-models)')
      else
        call rec%verdict(EXIT_NUMERIC, 'tubes: &model: the lowest well''s slow mode omega_1 (its dissipation''s ' // &
                         'rate) failed, status ' // itoa(stat))
      end if
      return
    end if
    if (len(d%law) > 0) then
      if (d%zeta > 0) call rec%attr_real('model', 'damping_rate', d%c)
      if (d%crr > 0) call rec%attr_real('model', 'rolling_drag', d%f)
      call rec%attr_string('model', 'dissipation', d%law)
    end if
  end subroutine scene_model

  !> /model's attributes of a model written as a formula (docs/output.md); system: its library's name.
  subroutine formula_attrs(f, system, rec)
    type(model_formula_t), intent(in) :: f
    character(*), intent(in) :: system
    type(record_t), intent(inout) :: rec
    character(:), allocatable :: coords, momenta, q
    integer :: i, j
    call rec%attr_string('model', 'formula', f%text)
    if (f%sysname == 'expression') then
      coords = f%coordinates
      if (len(coords) == 0) coords = 'x y'
      call rec%attr_string('model', 'coordinates', coords)
      momenta = f%momenta
      if (len(momenta) == 0) then   ! the default: 'p' + each coordinate (docs/input.md)
        q = coords // ' '
        i = 1
        do while (i <= len(q))
          j = index(q(i:), ' ') + i - 1
          if (j > i) then
            if (len(momenta) > 0) momenta = momenta // ' '
            momenta = momenta // 'p' // q(i:j - 1)
          end if
          i = j + 1
        end do
      end if
      call rec%attr_string('model', 'momenta', momenta)
    end if
    call rec%attr_string('model', 'constants', f%constants)
    call rec%attr_string('model', 'library', f%library)
    call rec%attr_string('model', 'library_name', system)
  end subroutine formula_attrs
end module tubes_scene_model
