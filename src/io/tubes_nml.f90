!> Namelist input: Fortran's intrinsic namelist READ behind bind(C) (include/tubes_config.h).
!> The C side (tubes_input.c) lexes the file first for line-accurate messages and validates
!> ranges; this module only reads values and writes the effective namelist.
module tubes_nml
  use, intrinsic :: iso_c_binding, only: c_int, c_double, c_char, c_int64_t, c_null_char, c_sizeof
  use, intrinsic :: iso_fortran_env, only: iostat_end
  use tubes_cstrings, only: c_to_f, f_to_c
  use tubes_models, only: system_info_t, system_info, MAX_PARAMS, MAX_DOF
  use tubes_config, only: tubes_config_t, NGROUPS, NSCENES, LSCENE, LPATH, LNAME, MAXDE, LSADDLE, MAXGUESS, &
                          LEXPR, LSYM, LCONST, MAXCONST, LMSG, UNSET, UNSET_INT
  use tubes_scan, only: scan_index
  implicit none
  private


  !> Namelist variables as Fortran sees them (one instance per call, never saved), with their
  !> defaults: the values a group the file leaves out keeps (UNSET: the system's, resolve).
  type :: vars_t
    character(LSCENE) :: scenes(NSCENES) = ''   !! scenes(1) = 'equilibria': set_defaults
    character(LPATH) :: output = 'tubes.h5'
    real(c_double) :: alpha = UNSET, beta = UNSET, gamma = UNSET, xi = UNSET, h0 = UNSET, g = UNSET, &
                      damping_ratio = UNSET, rolling_resistance = UNSET, noise_d = UNSET, temperature = UNSET
    real(c_double) :: box = 0
    character(LSADDLE) :: saddle = ''
    character(LSADDLE) :: orb_saddle = ''
    real(c_double) :: orb_de(MAXDE) = UNSET
    real(c_double) :: sec_angle = UNSET
    integer :: sec_pth_sign = UNSET_INT
    real(c_double) :: mc_gate = UNSET
    character(LPATH) :: exp_csv = ''
    character(LNAME) :: system = 'rolling_ball'
    real(c_double) :: m_a = UNSET, m_b = UNSET, d = UNSET, lambda = UNSET, zeta = UNSET, eps_s = UNSET, &
                      omega = UNSET, eps = UNSET, mu = UNSET
    real(c_double) :: box_list(MAX_DOF) = UNSET, box_center(MAX_DOF) = UNSET, orb_saddle_near(MAX_DOF) = UNSET
    character(LNAME) :: sec_kind = ''
    integer :: sec_index = UNSET_INT, sec_direction = UNSET_INT
    real(c_double) :: sec_value = UNSET
    character(LEXPR) :: hamiltonian = '', height = ''
    character(LSYM) :: coordinates(MAX_DOF) = '', momenta(MAX_DOF) = ''
    character(LCONST) :: constants(MAXCONST) = ''
    character(LNAME) :: surface = 'fourwell'
    character(LNAME) :: dissipation = ''
    character(LNAME) :: model_name = ''   !! the library's name of the model (written only)
    real(c_double) :: flux_gate = UNSET
    integer :: orb_family = 1
    logical :: spatial = .false.
    character(LNAME) :: scan_parameter = ''
    real(c_double) :: scan_to = UNSET
    real(c_double) :: scan_de(MAXDE) = UNSET
    real(c_double) :: orb_guess(MAXGUESS) = UNSET   !! &orbits guess (a longer list is said so)
    real(c_double) :: orb_period = 0
    real(c_double) :: orb_jacobi(MAXDE) = UNSET, orb_periods(MAXDE) = UNSET   !! &orbits jacobi, periods
    include 'nml_vars.inc'   ! the registered variables (src/io/tubes_registry_gen.awk)
  end type vars_t

contains

  !> The defaults of every variable: vars_t's, and the one scene run when &run names none.
  subroutine set_defaults(v)
    type(vars_t), intent(out) :: v   ! intent(out): every component takes its default
    v%scenes(1) = 'equilibria'
  end subroutine set_defaults

  subroutine to_c(v, cfg, build)
    type(vars_t), intent(in) :: v
    type(tubes_config_t), intent(out) :: cfg
    logical, intent(in) :: build   !! build a model written as a formula (not after a read error)
    integer :: k
    do k = 1, NSCENES
      call f_to_c(v%scenes(k), cfg%scenes(:, k))
    end do
    call f_to_c(v%output, cfg%output)
    call f_to_c(v%saddle, cfg%saddle)
    cfg%spatial = merge(1, 0, v%spatial)
    call f_to_c(v%orb_saddle, cfg%orb_saddle)
    cfg%orb_de = v%orb_de
    cfg%orb_nde = count(v%orb_de /= UNSET)
    if (cfg%orb_nde == 0) then          ! default list of excess energies
      cfg%orb_de(1:3) = [1.0_c_double, 10.0_c_double, 100.0_c_double]
      cfg%orb_nde = 3
    end if
    cfg%orb_family = v%orb_family
    cfg%orb_nguess = count(v%orb_guess /= UNSET)
    cfg%orb_guess = 0
    cfg%orb_guess(1:min(cfg%orb_nguess, 2*MAX_DOF)) = v%orb_guess(1:min(cfg%orb_nguess, 2*MAX_DOF))
    cfg%orb_period = v%orb_period
    cfg%orb_de_given = merge(1, 0, count(v%orb_de /= UNSET) > 0)
    cfg%orb_njacobi = findloc(v%orb_jacobi /= UNSET, .true., dim=1, back=.true.)   ! the last set (a gap: said)
    cfg%orb_jacobi = 0
    cfg%orb_jacobi(1:cfg%orb_njacobi) = v%orb_jacobi(1:cfg%orb_njacobi)
    cfg%orb_nperiods = findloc(v%orb_periods /= UNSET, .true., dim=1, back=.true.)
    cfg%orb_periods = 0
    cfg%orb_periods(1:cfg%orb_nperiods) = v%orb_periods(1:cfg%orb_nperiods)
    include 'nml_to_c.inc'   ! the registered variables
    call f_to_c(v%exp_csv, cfg%exp_csv)
    call f_to_c(v%hamiltonian, cfg%hamiltonian)
    call f_to_c(v%height, cfg%height)
    call f_to_c(v%surface, cfg%surface)
    call f_to_c(v%dissipation, cfg%dissipation)
    do k = 1, MAX_DOF
      call f_to_c(v%coordinates(k), cfg%coordinates(:, k))
      call f_to_c(v%momenta(k), cfg%momenta(:, k))
    end do
    do k = 1, MAXCONST
      call f_to_c(v%constants(k), cfg%constants(:, k))
    end do
    call f_to_c(v%scan_parameter, cfg%scan_parameter)
    cfg%scan_to = v%scan_to
    cfg%scan_de = v%scan_de
    cfg%scan_nde = count(v%scan_de /= UNSET)
    if (cfg%scan_nde == 0 .and. count(v%orb_de /= UNSET) > 0) then   ! &orbits de, as given
      cfg%scan_de = v%orb_de
      cfg%scan_nde = count(v%orb_de /= UNSET)
    end if
    call resolve(v, cfg, build)   ! last: it fills the effective values of the fields above
    block
      character(512) :: allowed
      cfg%scan_ipar = 0
      if (cfg%nparams >= 0) cfg%scan_ipar = scan_index(trim(c_to_f(cfg%model)), trim(v%scan_parameter), allowed)
    end block
  end subroutine to_c

  !> The value of &model variable `name` in v (UNSET if not set in the file).
  pure real(c_double) function model_var(v, name) result(x)
    type(vars_t), intent(in) :: v
    character(*), intent(in) :: name
    select case (name)
    case ('alpha'); x = v%alpha
    case ('beta'); x = v%beta
    case ('gamma'); x = v%gamma
    case ('xi'); x = v%xi
    case ('h0'); x = v%h0
    case ('g'); x = v%g
    case ('damping_ratio'); x = v%damping_ratio
    case ('rolling_resistance'); x = v%rolling_resistance
    case ('noise'); x = v%noise_d
    case ('temperature'); x = v%temperature
    case ('m_a'); x = v%m_a
    case ('m_b'); x = v%m_b
    case ('d'); x = v%d
    case ('lambda'); x = v%lambda
    case ('zeta'); x = v%zeta
    case ('eps_s'); x = v%eps_s
    case ('omega'); x = v%omega
    case ('eps'); x = v%eps
    case ('mu'); x = v%mu
    case default; x = UNSET
    end select
  end function model_var

  !> v's &model variables: the system's parameters with their effective values (cfg%params),
  !> the others unset (the effective namelist writes the system's parameters only).
  subroutine effective_model(cfg, v)
    type(tubes_config_t), intent(in) :: cfg
    type(vars_t), intent(inout) :: v
    type(system_info_t) :: info
    integer :: st, k
    v%alpha = UNSET; v%beta = UNSET; v%gamma = UNSET; v%xi = UNSET; v%h0 = UNSET; v%g = UNSET
    v%damping_ratio = UNSET
    v%rolling_resistance = UNSET
    v%noise_d = UNSET
    v%temperature = UNSET
    v%m_a = UNSET; v%m_b = UNSET; v%d = UNSET; v%lambda = UNSET; v%zeta = UNSET; v%eps_s = UNSET
    v%omega = UNSET; v%eps = UNSET; v%mu = UNSET
    call system_info(trim(c_to_f(cfg%model)), info, st)
    if (st /= 0) return
    do k = 1, info%np
      select case (trim(info%params(k)%name))
      case ('alpha'); v%alpha = cfg%params(k)
      case ('beta'); v%beta = cfg%params(k)
      case ('gamma'); v%gamma = cfg%params(k)
      case ('xi'); v%xi = cfg%params(k)
      case ('h0'); v%h0 = cfg%params(k)
      case ('g'); v%g = cfg%params(k)
      case ('damping_ratio'); v%damping_ratio = cfg%params(k)
      case ('rolling_resistance'); v%rolling_resistance = cfg%params(k)
      case ('noise'); v%noise_d = cfg%params(k)
      case ('temperature'); v%temperature = cfg%params(k)
      case ('m_a'); v%m_a = cfg%params(k)
      case ('m_b'); v%m_b = cfg%params(k)
      case ('d'); v%d = cfg%params(k)
      case ('lambda'); v%lambda = cfg%params(k)
      case ('zeta'); v%zeta = cfg%params(k)
      case ('eps_s'); v%eps_s = cfg%params(k)
      case ('omega'); v%omega = cfg%params(k)
      case ('eps'); v%eps = cfg%params(k)
      case ('mu'); v%mu = cfg%params(k)
      end select
    end do
  end subroutine effective_model

  !> The effective model, box, saddle, section and gate: the file's values, else the system's
  !> defaults from the library's table (src/models/tubes_models.f90). An unknown system leaves
  !> nparams = -1 (nml_validate reports it).
  subroutine resolve(v, cfg, build)
    type(vars_t), intent(in) :: v
    type(tubes_config_t), intent(inout) :: cfg
    logical, intent(in) :: build
    type(system_info_t) :: info
    integer :: st, k, nd
    real(c_double) :: x, half(MAX_DOF), centre(MAX_DOF)
    call f_to_c(v%system, cfg%system)
    if (v%spatial .and. trim(v%system) == 'cr3bp') then
      call f_to_c('cr3bp_spatial', cfg%model)     ! the spatial problem: its own entry of the library
    else
      call f_to_c(v%system, cfg%model)
    end if
    cfg%expr_var = c_null_char; cfg%expr_msg = c_null_char; cfg%expr_lib = c_null_char
    cfg%expr_seconds = 0
    cfg%expr_hit = 0
    cfg%alpha = v%alpha; cfg%beta = v%beta; cfg%gamma = v%gamma; cfg%xi = v%xi
    cfg%h0 = v%h0; cfg%g = v%g; cfg%damping_ratio = v%damping_ratio
    cfg%rolling_resistance = v%rolling_resistance
    cfg%noise_d = v%noise_d
    cfg%temperature = v%temperature
    cfg%m_a = v%m_a; cfg%m_b = v%m_b; cfg%d = v%d; cfg%lambda = v%lambda; cfg%zeta = v%zeta
    cfg%eps_s = v%eps_s; cfg%omega = v%omega; cfg%eps = v%eps; cfg%mu = v%mu
    cfg%box_list = v%box_list
    cfg%box_center = v%box_center
    cfg%orb_saddle_near = v%orb_saddle_near
    cfg%params = 0
    cfg%box_lo = 0
    cfg%box_hi = 0
    cfg%box = 0
    cfg%orb_use_near = 0
    cfg%sec_angle = v%sec_angle; cfg%sec_pth_sign = v%sec_pth_sign
    call f_to_c(v%sec_kind, cfg%sec_kind)
    cfg%sec_index = v%sec_index; cfg%sec_value = v%sec_value; cfg%sec_direction = v%sec_direction
    cfg%mc_gate = v%mc_gate
    cfg%flux_gate = v%flux_gate
    if (is_expression(v)) then   ! the model's library: its name replaces the system's
      cfg%nparams = -2
      cfg%ndof = 0
      if (.not. build) return
      call build_expression(v, cfg, st)
      if (st /= 0) return
    end if
    call system_info(trim(c_to_f(cfg%model)), info, st)
    if (st /= 0) then
      cfg%nparams = -1
      cfg%ndof = 0
      return
    end if
    cfg%nparams = info%np
    cfg%ndof = info%ndof
    nd = info%ndof
    do k = 1, info%np
      x = model_var(v, trim(info%params(k)%name))
      if (x == UNSET) x = info%params(k)%default
      cfg%params(k) = x
    end do
    if (trim(c_to_f(cfg%model)) == 'rolling_ball') then      ! the scenes still read these by name
      cfg%alpha = cfg%params(1); cfg%beta = cfg%params(2); cfg%gamma = cfg%params(3)
      cfg%xi = cfg%params(4); cfg%h0 = cfg%params(5); cfg%g = cfg%params(6)
      cfg%damping_ratio = cfg%params(7)
      cfg%rolling_resistance = cfg%params(8)
      cfg%noise_d = cfg%params(9)
      cfg%temperature = cfg%params(10)
    else
      cfg%damping_ratio = 0
      cfg%rolling_resistance = 0
      cfg%noise_d = 0
      cfg%temperature = 0
    end if
    ! the box: one value = every coordinate; box(k) alone sets coordinate k
    half = info%box
    if (v%box_list(1) /= UNSET) half = v%box_list(1)
    do k = 2, MAX_DOF
      if (v%box_list(k) /= UNSET) half(k) = v%box_list(k)
    end do
    centre = info%box_center
    do k = 1, MAX_DOF
      if (v%box_center(k) /= UNSET) centre(k) = v%box_center(k)
    end do
    cfg%box_lo(1:nd) = centre(1:nd) - half(1:nd)
    cfg%box_hi(1:nd) = centre(1:nd) + half(1:nd)
    cfg%box_list = 0
    cfg%box_list(1:nd) = half(1:nd)
    cfg%box_center = 0
    cfg%box_center(1:nd) = centre(1:nd)
    cfg%box = half(1)
    ! the saddle: by name, by position, or the system's default
    if (len_trim(v%orb_saddle) == 0 .and. all(v%orb_saddle_near == UNSET)) then
      if (len_trim(info%saddle) > 0) then
        call f_to_c(info%saddle, cfg%orb_saddle)
      else
        cfg%orb_use_near = 1
        cfg%orb_saddle_near = 0
        cfg%orb_saddle_near(1:nd) = info%saddle_near(1:nd)
      end if
    else if (any(v%orb_saddle_near /= UNSET)) then
      cfg%orb_use_near = 1
      where (cfg%orb_saddle_near == UNSET) cfg%orb_saddle_near = 0
    end if
    ! the section
    if (len_trim(v%sec_kind) == 0) call f_to_c(info%section_kind, cfg%sec_kind)
    if (c_to_f(cfg%sec_kind) == 'ray') then
      if (v%sec_angle == UNSET) cfg%sec_angle = info%section_angle
      if (v%sec_angle == UNSET .and. info%section_angle == 0) cfg%sec_angle = 45
      if (v%sec_pth_sign == UNSET_INT) cfg%sec_pth_sign = merge(info%section_direction, 1, &
                                                               info%section_direction /= 0)
    else
      if (v%sec_index == UNSET_INT) cfg%sec_index = info%section_index
      if (v%sec_value == UNSET) cfg%sec_value = info%section_value
      if (v%sec_direction == UNSET_INT) cfg%sec_direction = info%section_direction
    end if
    if (v%mc_gate == UNSET) cfg%mc_gate = info%gate
    if (v%flux_gate == UNSET) cfg%flux_gate = cfg%mc_gate
  end subroutine resolve

  !> Is the model written as a formula? (system 'expression', or a ball on surface 'expression')
  pure logical function is_expression(v)
    type(vars_t), intent(in) :: v
    is_expression = trim(v%system) == 'expression' .or. &
                    (trim(v%system) == 'rolling_ball' .and. trim(v%surface) == 'expression')
  end function is_expression

  !> The spec of a model written as a formula (python/tubes/codegen.py reads it): the formula,
  !> the coordinates (default x, y), the momenta (default p<coordinate>), the constants.
  function expression_spec(v) result(spec)
    type(vars_t), intent(in) :: v
    character(:), allocatable :: spec
    character, parameter :: NL = achar(10)
    integer :: k
    if (trim(v%system) == 'expression') then
      spec = 'tubes-expression 1' // NL // 'kind hamiltonian' // NL // 'expr ' // trim(v%hamiltonian) // NL
      spec = spec // 'coordinates'
      if (all(len_trim(v%coordinates) == 0)) then
        spec = spec // ' x y'
      else
        do k = 1, MAX_DOF
          if (len_trim(v%coordinates(k)) > 0) spec = spec // ' ' // trim(v%coordinates(k))
        end do
      end if
      spec = spec // NL // 'momenta'
      do k = 1, MAX_DOF
        if (all(len_trim(v%momenta) == 0)) then
          if (all(len_trim(v%coordinates) == 0)) then
            if (k <= 2) spec = spec // ' p' // trim(merge('x', 'y', k == 1))
          else if (len_trim(v%coordinates(k)) > 0) then
            spec = spec // ' p' // trim(v%coordinates(k))
          end if
        else if (len_trim(v%momenta(k)) > 0) then
          spec = spec // ' ' // trim(v%momenta(k))
        end if
      end do
      spec = spec // NL
    else
      spec = 'tubes-expression 1' // NL // 'kind surface' // NL // 'expr ' // trim(v%height) // NL // &
             'coordinates x y' // NL
    end if
    do k = 1, MAXCONST
      if (len_trim(v%constants(k)) > 0) spec = spec // 'constant ' // trim(adjustl(v%constants(k))) // NL
    end do
  end function expression_spec

  !> Build (or find in the cache) the library of v's formula: cfg%model becomes its name; on
  !> failure st /= 0 and cfg%expr_var, cfg%expr_msg say why (src/io/tubes_expr.c).
  subroutine build_expression(v, cfg, st)
    type(vars_t), intent(in) :: v
    type(tubes_config_t), intent(inout) :: cfg
    integer, intent(out) :: st
    interface
      integer(c_int) function expr_build(spec, key, var, lvar, msg, lmsg, lib, llib, seconds, hit) &
          bind(C, name='tubes_expr_build')
        import :: c_int, c_char, c_double
        character(kind=c_char), intent(in) :: spec(*)
        character(kind=c_char), intent(out) :: key(*), var(*), msg(*), lib(*)
        integer(c_int), value :: lvar, lmsg, llib
        real(c_double), intent(out) :: seconds
        integer(c_int), intent(out) :: hit
      end function expr_build
    end interface
    character(:), allocatable :: spec
    spec = expression_spec(v)
    cfg%model = c_null_char
    st = int(expr_build(spec // c_null_char, cfg%model, cfg%expr_var, LNAME, cfg%expr_msg, LMSG, cfg%expr_lib, LPATH, &
                        cfg%expr_seconds, cfg%expr_hit))
  end subroutine build_expression

  !> A list with unset entries: its default when none is set.
  pure subroutine put_list(a, c, n, dflt)
    real(c_double), intent(in) :: a(:), dflt(:)
    real(c_double), intent(out) :: c(:)
    integer(c_int), intent(out) :: n
    c = a
    n = count(a /= UNSET)
    if (n == 0) then
      c(1:size(dflt)) = dflt
      n = size(dflt)
    end if
  end subroutine put_list

  subroutine from_c(cfg, v)
    type(tubes_config_t), intent(in) :: cfg
    type(vars_t), intent(out) :: v
    integer :: k
    do k = 1, NSCENES
      v%scenes(k) = c_to_f(cfg%scenes(:, k))
    end do
    v%output = c_to_f(cfg%output)
    v%system = c_to_f(cfg%system)
    v%alpha = cfg%alpha; v%beta = cfg%beta; v%gamma = cfg%gamma; v%xi = cfg%xi
    v%h0 = cfg%h0; v%g = cfg%g; v%damping_ratio = cfg%damping_ratio
    v%rolling_resistance = cfg%rolling_resistance
    v%noise_d = cfg%noise_d
    v%temperature = cfg%temperature
    v%m_a = cfg%m_a; v%m_b = cfg%m_b; v%d = cfg%d; v%lambda = cfg%lambda; v%zeta = cfg%zeta
    v%eps_s = cfg%eps_s; v%omega = cfg%omega; v%eps = cfg%eps; v%mu = cfg%mu
    v%box = cfg%box
    v%box_list = cfg%box_list
    v%box_center = cfg%box_center
    v%orb_saddle_near = cfg%orb_saddle_near
    v%sec_kind = c_to_f(cfg%sec_kind)
    v%sec_index = cfg%sec_index; v%sec_value = cfg%sec_value; v%sec_direction = cfg%sec_direction
    v%hamiltonian = c_to_f(cfg%hamiltonian)
    v%height = c_to_f(cfg%height)
    v%surface = c_to_f(cfg%surface)
    v%dissipation = c_to_f(cfg%dissipation)
    v%model_name = c_to_f(cfg%model)
    do k = 1, MAX_DOF
      v%coordinates(k) = c_to_f(cfg%coordinates(:, k))
      v%momenta(k) = c_to_f(cfg%momenta(:, k))
    end do
    do k = 1, MAXCONST
      v%constants(k) = c_to_f(cfg%constants(:, k))
    end do
    call effective_model(cfg, v)
    v%saddle = c_to_f(cfg%saddle)
    v%spatial = cfg%spatial /= 0
    v%orb_saddle = c_to_f(cfg%orb_saddle)
    v%orb_de = cfg%orb_de
    v%orb_family = cfg%orb_family
    v%orb_guess = UNSET
    v%orb_guess(1:min(cfg%orb_nguess, 2*MAX_DOF)) = cfg%orb_guess(1:min(cfg%orb_nguess, 2*MAX_DOF))
    v%orb_period = cfg%orb_period
    v%orb_jacobi = UNSET
    v%orb_jacobi(1:cfg%orb_njacobi) = cfg%orb_jacobi(1:cfg%orb_njacobi)
    v%orb_periods = UNSET
    v%orb_periods(1:cfg%orb_nperiods) = cfg%orb_periods(1:cfg%orb_nperiods)
    if (cfg%orb_de_given == 0 .and. cfg%orb_njacobi + cfg%orb_nperiods > 0) v%orb_de = UNSET   ! the default's not written
    v%sec_angle = cfg%sec_angle; v%sec_pth_sign = cfg%sec_pth_sign
    v%mc_gate = cfg%mc_gate
    v%flux_gate = cfg%flux_gate
    include 'nml_from_c.inc'   ! the registered variables
    v%exp_csv = c_to_f(cfg%exp_csv)
    v%scan_parameter = c_to_f(cfg%scan_parameter)
    v%scan_to = cfg%scan_to
    v%scan_de = cfg%scan_de
  end subroutine from_c

  subroutine c_defaults(cfg) bind(C, name='tubes_nml_defaults')
    type(tubes_config_t), intent(out) :: cfg
    type(vars_t) :: v
    call set_defaults(v)
    call to_c(v, cfg, .false.)
  end subroutine c_defaults

  !> Read group number grp (0 run, 1 model, 2 equilibria, 3 trajectory, 4 integrator,
  !> 5 orbits, ..., 11 experiment) from unit u into v, or write it (mode 'w'). One subroutine per group keeps the
  !> namelist names (saddle, method, rtol, ...) separate between groups.
  subroutine group_io(grp, mode, u, v, ios, iomsg)
    integer, intent(in) :: grp, u
    character, intent(in) :: mode
    type(vars_t), intent(inout) :: v
    integer, intent(out) :: ios
    character(*), intent(inout) :: iomsg
    ios = 0
    select case (grp)
    case (0); call io_run()
    case (1); call io_model()
    case (2); call io_equilibria()
    case (3); call io_trajectory()
    case (4); call io_integrator()
    case (5); call io_orbits()
    case (6); call io_section()
    case (7); call io_tubes()
    case (8); call io_transition()
    case (9); call io_montecarlo()
    case (10); call io_sections()
    case (11); call io_experiment()
    case (12); call io_flux()
    case (13); call io_scan()
    end select
  contains
    subroutine io_run()
      character(LSCENE), allocatable :: scenes(:)
      character(:), allocatable :: output
      character(LPATH) :: out
      integer :: m, k
      namelist /run/ scenes, output
      if (mode == 'r') then
        allocate (scenes(NSCENES))
        scenes = v%scenes
        out = v%output
        output = out
        read (u, nml=run, iostat=ios, iomsg=iomsg)
        v%scenes = scenes
        v%output = output
      else
        m = max(1, count(len_trim(v%scenes) > 0))
        allocate (scenes(m))
        scenes = ''
        m = 0
        do k = 1, NSCENES
          if (len_trim(v%scenes(k)) > 0) then
            m = m + 1
            scenes(m) = v%scenes(k)
          end if
        end do
        output = trim(v%output)
        write (u, nml=run, iostat=ios, iomsg=iomsg)
      end if
    end subroutine io_run
    subroutine io_model()
      character(LNAME) :: system, surface, dissipation
      real(c_double) :: alpha, beta, gamma, xi, h0, g, damping_ratio, rolling_resistance, noise, temperature, &
                        m_a, m_b, d, lambda, zeta, eps_s, omega, eps, mu
      logical :: spatial
      character(LEXPR) :: hamiltonian, height
      character(LSYM) :: coordinates(MAX_DOF), momenta(MAX_DOF)
      character(LCONST) :: constants(MAXCONST)
      namelist /model/ system, alpha, beta, gamma, xi, h0, g, damping_ratio, rolling_resistance, noise, temperature, &
        m_a, m_b, d, lambda, &
        zeta, eps_s, omega, eps, mu, hamiltonian, coordinates, momenta, constants, surface, height, spatial, &
        dissipation
      system = v%system
      spatial = v%spatial
      hamiltonian = v%hamiltonian; height = v%height; surface = v%surface
      dissipation = v%dissipation
      coordinates = v%coordinates; momenta = v%momenta; constants = v%constants
      alpha = v%alpha; beta = v%beta; gamma = v%gamma; xi = v%xi; h0 = v%h0; g = v%g
      damping_ratio = v%damping_ratio; m_a = v%m_a; m_b = v%m_b; d = v%d; lambda = v%lambda
      rolling_resistance = v%rolling_resistance
      noise = v%noise_d
      temperature = v%temperature
      zeta = v%zeta; eps_s = v%eps_s; omega = v%omega; eps = v%eps; mu = v%mu
      if (mode == 'r') then
        read (u, nml=model, iostat=ios, iomsg=iomsg)
        v%system = system
        v%spatial = spatial
        v%alpha = alpha; v%beta = beta; v%gamma = gamma; v%xi = xi; v%h0 = h0; v%g = g
        v%damping_ratio = damping_ratio; v%m_a = m_a; v%m_b = m_b; v%d = d; v%lambda = lambda
        v%rolling_resistance = rolling_resistance
        v%noise_d = noise
        v%temperature = temperature
        v%zeta = zeta; v%eps_s = eps_s; v%omega = omega; v%eps = eps; v%mu = mu
        v%hamiltonian = hamiltonian; v%height = height; v%surface = surface
        v%dissipation = dissipation
        v%coordinates = coordinates; v%momenta = momenta; v%constants = constants
      else
        call write_model()
      end if
    end subroutine io_model
    !> The effective &model: the system and its own parameters only (the namelist WRITE of the
    !> whole group would print the other systems' unset variables).
    subroutine write_model()
      type(system_info_t) :: info
      integer :: k, st
      character(64) :: num
      write (u, '(a)', iostat=ios) '&MODEL'
      write (u, '(a)', iostat=ios) ' SYSTEM=''' // trim(v%system) // ''','
      if (v%spatial) write (u, '(a)', iostat=ios) ' SPATIAL=T,'
      if (trim(v%system) == 'expression') then
        call write_string('HAMILTONIAN', v%hamiltonian)
        call write_list('COORDINATES', v%coordinates)
        call write_list('MOMENTA', v%momenta)
      else if (trim(v%system) == 'rolling_ball' .and. trim(v%surface) /= 'fourwell') then
        call write_string('SURFACE', v%surface)
        call write_string('HEIGHT', v%height)
      end if
      if (is_expression(v)) call write_list('CONSTANTS', v%constants)
      if (v%dissipation /= '') call write_string('DISSIPATION', v%dissipation)
      call system_info(trim(v%model_name), info, st)
      if (st /= 0) info%np = 0
      do k = 1, info%np
        write (num, '(es24.16e3)') model_var(v, trim(info%params(k)%name))
        write (u, '(a)', iostat=ios) ' ' // trim(upper(info%params(k)%name)) // '=' // trim(adjustl(num)) // ','
      end do
      write (u, '(a)', iostat=ios) ' /'
    end subroutine write_model
    !> name='text', with ' doubled (namelist quoting)
    subroutine write_string(name, text)
      character(*), intent(in) :: name, text
      write (u, '(a)', iostat=ios) ' ' // name // '=''' // quoted(trim(text)) // ''','
    end subroutine write_string
    subroutine write_list(name, items)
      character(*), intent(in) :: name, items(:)
      integer :: k, n
      n = 0
      do k = 1, size(items)
        if (len_trim(items(k)) > 0) n = k
      end do
      if (n == 0) return
      write (u, '(a)', iostat=ios, advance='no') ' ' // name // '='
      do k = 1, n
        write (u, '(a)', iostat=ios, advance='no') '''' // quoted(trim(items(k))) // ''','
      end do
      write (u, '(a)', iostat=ios) ''
    end subroutine write_list
    pure function quoted(a) result(b)
      character(*), intent(in) :: a
      character(:), allocatable :: b
      integer :: i
      b = ''
      do i = 1, len(a)
        b = b // a(i:i)
        if (a(i:i) == '''') b = b // ''''
      end do
    end function quoted
    pure function upper(a) result(b)
      character(*), intent(in) :: a
      character(len(a)) :: b
      integer :: i
      b = a
      do i = 1, len(a)
        if (a(i:i) >= 'a' .and. a(i:i) <= 'z') b(i:i) = achar(iachar(a(i:i)) - 32)
      end do
    end function upper
    subroutine io_equilibria()
      real(c_double), allocatable :: box(:), box_center(:)
      character(8) :: saddle
      namelist /equilibria/ box, box_center
      include 'nml_equilibria_decl.inc'   ! the registered variables (src/io/tubes_registry_gen.awk): n_grid
      namelist /equilibria/ saddle
      saddle = v%saddle
      include 'nml_equilibria_in.inc'
      if (mode == 'r') then
        box = v%box_list
        box_center = v%box_center
        read (u, nml=equilibria, iostat=ios, iomsg=iomsg)
        v%box_list = box
        v%box_center = box_center
      else
        call list_io(v%box_list, box)
        call list_io(v%box_center, box_center)
        write (u, nml=equilibria, iostat=ios, iomsg=iomsg)
      end if
      v%saddle = saddle
      include 'nml_equilibria_out.inc'
    end subroutine io_equilibria
    subroutine io_trajectory()
      include 'nml_trajectory_decl.inc'   ! the registered variables (src/io/tubes_registry_gen.awk): all
      include 'nml_trajectory_io.inc'   ! the copies in, the READ or WRITE, the copies out
    end subroutine io_trajectory
    subroutine io_integrator()
      include 'nml_integrator_decl.inc'   ! the registered variables (src/io/tubes_registry_gen.awk): all
      include 'nml_integrator_io.inc'   ! the copies in, the READ or WRITE, the copies out
    end subroutine io_integrator
    subroutine io_orbits()
      character(8) :: saddle
      real(c_double), allocatable :: de(:)
      integer :: m, ifam, iosf
      character(LNAME) :: family
      real(c_double), allocatable :: saddle_near(:), guess(:)
      real(c_double) :: period
      real(c_double), allocatable :: jacobi(:), periods(:)
      character(512) :: buf(40)
      logical :: by_name
      integer :: k
      namelist /orbits/ saddle, saddle_near, de
      include 'nml_orbits_decl.inc'   ! the registered variables (src/io/tubes_registry_gen.awk): method .. n_samples
      namelist /orbits/ family, guess, period, jacobi, periods
      saddle = v%orb_saddle
      period = v%orb_period
      call list_io(v%orb_guess, guess)
      call list_io(v%orb_jacobi, jacobi)
      call list_io(v%orb_periods, periods)
      select case (v%orb_family)
      case (-1)
        family = 'halo_north'
      case (-2)
        family = 'halo_south'
      case (-3)
        family = 'vertical'
      case (-4)
        family = 'lyapunov'
      case (-5)
        family = 'axial'
      case (:-101)
        write (family, '(a,i0)') 'branch:', -100 - v%orb_family
      case default
        write (family, '(i0)') v%orb_family
      end select
      call list_io(v%orb_saddle_near, saddle_near)
      include 'nml_orbits_in.inc'
      if (mode == 'r') then
        allocate (de(MAXDE))
        de = v%orb_de
        read (u, nml=orbits, iostat=ios, iomsg=iomsg)
        v%orb_de = de
        v%orb_saddle_near = saddle_near
        v%orb_guess = guess
        v%orb_jacobi = jacobi
        v%orb_periods = periods
      else
        m = count(v%orb_de /= UNSET)
        allocate (de(max(m, 1)))
        de = 0
        if (m > 0) de = v%orb_de(1:m)
        ! the saddle is chosen once, by name or by position: the effective namelist states that
        ! choice and leaves the other variable out (both set is refused when the text is read back)
        buf = ''
        write (buf, nml=orbits, delim='apostrophe', iostat=ios, iomsg=iomsg)
        by_name = len_trim(saddle) > 0
        do k = 1, size(buf)
          if (len_trim(buf(k)) == 0) cycle
          if (by_name .and. index(buf(k), ' SADDLE_NEAR=') == 1) cycle
          if (.not. by_name .and. index(buf(k), ' SADDLE=') == 1) cycle
          ! guess and period only when a guess is given (the effective namelist as before)
          if (count(v%orb_guess /= UNSET) == 0 .and. (index(buf(k), ' GUESS=') == 1 .or. &
              index(buf(k), ' PERIOD=') == 1)) cycle
          ! jacobi and periods only when given; de not when they replace it
          if (count(v%orb_jacobi /= UNSET) == 0 .and. index(buf(k), ' JACOBI=') == 1) cycle
          if (count(v%orb_periods /= UNSET) == 0 .and. index(buf(k), ' PERIODS=') == 1) cycle
          if (count(v%orb_de /= UNSET) == 0 .and. index(buf(k), ' DE=') == 1) cycle
          ! a numbered family is an integer (the text is read back by the same rules), in the
          ! layout of an integer's (i0 in 11 columns: the effective namelist as before)
          if (index(buf(k), " FAMILY='") == 1 .and. verify(trim(family), '0123456789') == 0) &
            buf(k) = ' FAMILY=' // family(1:11) // ','   ! as gfortran writes an integer
          write (u, '(a)', iostat=ios) trim(buf(k))
        end do
      end if
      v%orb_saddle = saddle
      v%orb_period = period
      include 'nml_orbits_out.inc'
      select case (trim(family))
      case ('halo_north')
        v%orb_family = -1
      case ('halo_south')
        v%orb_family = -2
      case ('vertical')   ! the families by name (tubes_orbits FAMILY_VERTICAL, _PLANAR, _AXIAL)
        v%orb_family = -3
      case ('lyapunov')
        v%orb_family = -4
      case ('axial')
        v%orb_family = -5
      case ('branch:1':'branch:99999')   ! 'branch:K', K >= 1 (a bad K is said as a bad name)
        read (family(8:), *, iostat=iosf) ifam
        v%orb_family = -100 - ifam
        if (iosf /= 0 .or. verify(trim(family(8:)), '0123456789') /= 0 .or. ifam < 1) v%orb_family = -99
      case default
        read (family, *, iostat=iosf) ifam
        v%orb_family = ifam
        if (iosf /= 0 .or. verify(trim(family), '0123456789+-') /= 0) v%orb_family = -99
        if (v%orb_family < 0 .and. v%orb_family /= -99) v%orb_family = 0   ! out of range, said as a number
      end select
    end subroutine io_orbits
    !> A list (dE) in read mode keeps its unset entries; in write mode only the set ones.
    subroutine list_io(a, out)
      real(c_double), intent(in) :: a(:)
      real(c_double), allocatable, intent(out) :: out(:)
      integer :: m
      if (mode == 'r') then
        out = a
      else
        m = count(a /= UNSET)
        allocate (out(max(m, 1)))
        out = 0
        if (m > 0) out = a(1:m)
      end if
    end subroutine list_io
    subroutine io_section()
      real(c_double) :: angle, value
      integer :: p_theta_sign, index, direction
      character(LNAME) :: kind
      namelist /section/ kind, angle, p_theta_sign, index, value, direction
      angle = v%sec_angle; p_theta_sign = v%sec_pth_sign; kind = v%sec_kind
      index = v%sec_index; value = v%sec_value; direction = v%sec_direction
      if (mode == 'r') then
        read (u, nml=section, iostat=ios, iomsg=iomsg)
      else if (trim(kind) == 'ray') then
        write (u, '(a)', iostat=ios) '&SECTION'
        write (u, '(a,es24.16e3,a,i0,a)', iostat=ios) " KIND='ray', ANGLE=", angle, &
          ', P_THETA_SIGN=', p_theta_sign, ','
        write (u, '(a)', iostat=ios) ' /'
      else
        write (u, '(a)', iostat=ios) '&SECTION'
        write (u, '(a,a,a,i0,a,es24.16e3,a,i0,a)', iostat=ios) " KIND='", trim(kind), "', INDEX=", &
          index, ', VALUE=', value, ', DIRECTION=', direction, ','
        write (u, '(a)', iostat=ios) ' /'
      end if
      v%sec_angle = angle; v%sec_pth_sign = p_theta_sign; v%sec_kind = kind
      v%sec_index = index; v%sec_value = value; v%sec_direction = direction
    end subroutine io_section
    subroutine io_tubes()
      include 'nml_tubes_decl.inc'   ! the registered variables (src/io/tubes_registry_gen.awk): all
      include 'nml_tubes_io.inc'   ! the copies in, the READ or WRITE, the copies out
    end subroutine io_tubes
    subroutine io_transition()
      include 'nml_transition_decl.inc'   ! the registered variables (src/io/tubes_registry_gen.awk): all
      include 'nml_transition_io.inc'   ! the copies in, the READ or WRITE, the copies out
    end subroutine io_transition
    subroutine io_montecarlo()
      real(c_double) :: gate
      include 'nml_montecarlo_decl.inc'   ! the registered variables (src/io/tubes_registry_gen.awk): de .. t_max
      namelist /montecarlo/ gate
      include 'nml_montecarlo_decl_2.inc'   ! area_tol
      gate = v%mc_gate
      include 'nml_montecarlo_io.inc'   ! the copies in, the READ or WRITE, the copies out
      v%mc_gate = gate
    end subroutine io_montecarlo
    subroutine io_flux()
      real(c_double) :: gate
      include 'nml_flux_decl.inc'   ! the registered variables (src/io/tubes_registry_gen.awk): de .. t_max
      namelist /flux/ gate
      include 'nml_flux_decl_2.inc'   ! tol .. cut_eps
      gate = v%flux_gate
      include 'nml_flux_io.inc'   ! the copies in, the READ or WRITE, the copies out
      v%flux_gate = gate
    end subroutine io_flux
    subroutine io_scan()
      character(LNAME) :: parameter
      real(c_double) :: to
      real(c_double), allocatable :: de(:)
      namelist /scan/ parameter, to
      include 'nml_scan_decl.inc'   ! the registered variables (src/io/tubes_registry_gen.awk): n
      namelist /scan/ de
      include 'nml_scan_decl_2.inc'   ! p_trans
      if (mode /= 'r' .and. len_trim(v%scan_parameter) == 0) return   ! echoed only when set
      parameter = v%scan_parameter
      to = v%scan_to
      call list_io(v%scan_de, de)
      include 'nml_scan_in.inc'
      if (mode == 'r') then
        read (u, nml=scan, iostat=ios, iomsg=iomsg)
        v%scan_de = de
      else
        write (u, nml=scan, iostat=ios, iomsg=iomsg)
      end if
      v%scan_parameter = parameter
      v%scan_to = to
      include 'nml_scan_out.inc'
    end subroutine io_scan
    subroutine io_sections()
      include 'nml_sections_decl.inc'   ! the registered variables (src/io/tubes_registry_gen.awk): all
      include 'nml_sections_io.inc'   ! the copies in, the READ or WRITE, the copies out
    end subroutine io_sections
    subroutine io_experiment()
      character(:), allocatable :: csv
      character(LPATH) :: buf
      include 'nml_experiment_decl.inc'   ! the registered variables (src/io/tubes_registry_gen.awk): n_tracks .. seed
      namelist /experiment/ csv
      include 'nml_experiment_in.inc'
      if (mode == 'r') then
        buf = v%exp_csv
        csv = buf
        read (u, nml=experiment, iostat=ios, iomsg=iomsg)
        v%exp_csv = csv
      else
        csv = trim(v%exp_csv)
        write (u, nml=experiment, iostat=ios, iomsg=iomsg)
      end if
      include 'nml_experiment_out.inc'
    end subroutine io_experiment
  end subroutine group_io

  integer(c_int) function c_read(path, cfg, group, msg, msglen) result(ios) &
      bind(C, name='tubes_nml_read')
    character(kind=c_char), intent(in) :: path(*)
    type(tubes_config_t), intent(out) :: cfg
    integer(c_int), intent(out) :: group
    integer(c_int), value :: msglen
    character(kind=c_char), intent(out) :: msg(msglen)
    type(vars_t) :: v
    character(LPATH) :: fname
    character(512) :: iomsg
    integer :: u, grp
    call set_defaults(v)
    group = -1
    msg = c_null_char
    fname = c_to_f(path(1:LPATH))
    open (newunit=u, file=trim(fname), status='old', action='read', iostat=ios, iomsg=iomsg)
    if (ios /= 0) then
      call f_to_c(iomsg, msg)
      call to_c(v, cfg, .false.)
      return
    end if
    do grp = 0, NGROUPS - 1
      rewind (u)
      iomsg = ''
      call group_io(grp, 'r', u, v, ios, iomsg)
      if (ios == iostat_end) ios = 0       ! group absent (C checks presence separately)
      if (ios /= 0) then
        group = grp
        call f_to_c(iomsg, msg)
        exit
      end if
    end do
    close (u)
    call to_c(v, cfg, ios == 0)
  end function c_read

  !> The size of tubes_config_t here, for C's check of its generated struct (tubes_input.c).
  integer(c_int) function c_config_size() result(n) bind(C, name='tubes_nml_config_size')
    type(tubes_config_t) :: cfg
    n = int(c_sizeof(cfg), c_int)
  end function c_config_size

  integer(c_int) function c_write(cfg, buf, buflen) result(n) bind(C, name='tubes_nml_write')
    type(tubes_config_t), intent(in) :: cfg
    integer(c_int), value :: buflen
    character(kind=c_char), intent(out) :: buf(buflen)
    type(vars_t) :: v
    character(4608) :: line
    character(512) :: iomsg
    integer :: u, ios, i, grp
    call from_c(cfg, v)
    open (newunit=u, status='scratch', action='readwrite', delim='apostrophe', iostat=ios)
    if (ios /= 0) then
      n = -1
      return
    end if
    do grp = 0, NGROUPS - 1
      call group_io(grp, 'w', u, v, ios, iomsg)
    end do
    rewind (u)
    n = 0
    buf = c_null_char
    do
      read (u, '(a)', iostat=ios) line
      if (ios /= 0) exit
      do i = 1, len_trim(line)
        if (n >= buflen - 2) then
          n = -1
          close (u)
          return
        end if
        n = n + 1
        buf(n) = line(i:i)
      end do
      n = n + 1
      buf(n) = achar(10)
    end do
    close (u)
    if (n < buflen) buf(n + 1) = c_null_char
  end function c_write
end module tubes_nml
