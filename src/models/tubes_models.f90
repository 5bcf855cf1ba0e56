!> The library of models, chosen by name: each system's parameters (names, units, defaults,
!> meaning), its default search box, saddle and section, and its constructor. This table is
!> the one definition: the namelist reader, --help, docs/models.md and Python all ask it
!> (tubes_model_info in include/tubes.h). A model travels across the C and Python boundaries
!> as (system name, parameter vector in the order of this table).
module tubes_models
  use, intrinsic :: iso_c_binding, only: c_int, c_char
  use tubes_cstrings, only: c_to_f, f_to_c
  use tubes_kinds, only: wp, i8, PI
  use tubes_lapack, only: dgesv, eigen
  use tubes_field, only: vector_field_t
  use tubes_hamiltonian, only: hamiltonian_t, natural_t, damped_t, make_damped
  use tubes_ball, only: ball_t, make_ball, ROLL
  use tubes_fourwell, only: fourwell_t
  use tubes_henon_heiles, only: henon_heiles_t
  use tubes_de_leon_berne, only: de_leon_berne_t
  use tubes_coupled_quartic, only: coupled_quartic_t
  use tubes_cr3bp, only: cr3bp_t
  use tubes_expression, only: expr_lib_t, expr_model, expr_surface, expr_surface_t, KIND_SURFACE
  use tubes_equilibria, only: equilibrium_t, find_equilibria
  use tubes_status, only: TUBES_OK, TUBES_EINPUT
  implicit none
  private

  integer, parameter, public :: MAX_PARAMS = 16   !! parameters of one system at most
  integer, parameter, public :: MAX_DOF = 3       !! degrees of freedom of a built-in system at most
  integer, parameter, public :: LEN_SYSTEM = 32   !! length of a system's name
  integer, parameter, public :: LEN_PARAM = 24    !! length of a parameter's name
  integer, parameter, public :: NSYSTEMS = 6      !! built-in systems
  integer, parameter, public :: NMODEL = 10       !! rolling_ball's parameters (the old vector)
  !> Rolling resistance is regularised at rest: the drag C_rr g s / sqrt(s^2 + V_ROLL^2) at path
  !> speed s [cm/s] (docs/dissipation.md): within 0.5 % of C_rr g above 1 cm/s
  real(wp), parameter, public :: V_ROLL = 0.1_wp

  !> One parameter of a system.
  type, public :: param_info_t
    character(LEN_PARAM) :: name = ''     !! namelist variable in &model
    real(wp) :: default = 0               !! its default
    character(16) :: units = ''           !! units
    character(96) :: doc = ''             !! meaning
    character(16) :: symbol = ''          !! its name in the system's formula ('' : not in it)
  end type param_info_t

  !> A system of the library with its defaults for the scenes.
  type, public :: system_info_t
    character(LEN_SYSTEM) :: name = ''    !! &model system
    character(160) :: summary = ''        !! one line: the Hamiltonian
    character(160) :: surface = ''        !! rolling_ball: the surface's formula (/model@surface)
    integer :: ndof = 2                   !! degrees of freedom
    integer :: np = 0                     !! parameters
    type(param_info_t) :: params(MAX_PARAMS)
    character(8) :: length_units = ''     !! units of the coordinates
    real(wp) :: box(MAX_DOF) = 0          !! default half-widths of the equilibrium search box
    real(wp) :: box_center(MAX_DOF) = 0   !! and its centre
    character(8) :: saddle = ''           !! default saddle by name ('' : by saddle_near)
    real(wp) :: saddle_near(MAX_DOF) = 0  !! default saddle by position (when saddle = '')
    character(8) :: section_kind = ''     !! default section: 'ray', 'plane' or '' (none)
    integer :: section_index = 0          !! plane: coordinate index k of q_k = value
    real(wp) :: section_value = 0         !! plane: the level
    integer :: section_direction = 0      !! plane: sign of dq_k/dt; ray: sign of p_theta
    real(wp) :: section_angle = 0         !! ray: angle [deg]
    real(wp) :: gate = 0                  !! default transit gate (distance past the saddle)
    !> the system as a formula (python/tubes/codegen.py's language), for the Taylor method's jet:
    !> a Hamiltonian of (coordinates, momenta), or a ball's surface h(x, y) ('' : none)
    character(400) :: formula = ''
    character(12) :: formula_kind = ''    !! 'hamiltonian' or 'surface'
    character(16) :: coordinates = ''     !! their names in the formula
    character(24) :: momenta = ''
  end type system_info_t

  interface
    !> src/io/tubes_expr.c: the loaded library of a model written as a formula
    integer(c_int) function expr_open(key, lib) bind(C, name='tubes_expr_open')
      import :: c_int, c_char, expr_lib_t, LEN_SYSTEM
      character(kind=c_char), intent(in) :: key(LEN_SYSTEM)
      type(expr_lib_t), intent(out) :: lib
    end function expr_open
    !> src/io/tubes_expr.c: the spec text of a formula model
    integer(c_int) function expr_spec(key, buf, len) bind(C, name='tubes_expr_spec')
      import :: c_int, c_char, LEN_SYSTEM
      character(kind=c_char), intent(in) :: key(LEN_SYSTEM)
      character(kind=c_char), intent(out) :: buf(*)
      integer(c_int), value :: len
    end function expr_spec
  end interface

  public :: system_info, system_name, make_model, make_field, conservative_ball, model_ball, &
            damping_rate, momentum_of, potential_of, shape_derivs_of, damping_ratio_of, dissipative, param_of, noisy_params

contains

  !> s in n characters: as it is when it fits, else cut with '...' at the end (a one-line
  !> summary: /model@hamiltonian and @surface; a formula's full text is /model@formula).
  pure function clip(s, n) result(c)
    character(*), intent(in) :: s
    integer, intent(in) :: n
    character(len=n) :: c
    if (len(s) <= n) then
      c = s
    else
      c = s(1:n - 3) // '...'
    end if
  end function clip

  pure function p(name, default, units, doc, symbol) result(pi)
    character(*), intent(in) :: name, units, doc
    real(wp), intent(in) :: default
    character(*), intent(in), optional :: symbol   !! its name in the formula (default: name)
    type(param_info_t) :: pi
    pi%name = name
    pi%default = default
    pi%units = units
    pi%doc = doc
    pi%symbol = name
    if (present(symbol)) pi%symbol = symbol
  end function p

  !> The dissipation parameters of a natural model, appended to its table from entry k0 on: the
  !> viscous damping ratio, the noise and its fluctuation-dissipation form, and for a ball (rolling)
  !> the rolling resistance; units in the model's (u_p2t: momentum^2/time, u_e: energy). None is in
  !> the formula (the field adds them: damped_t). np becomes k0 - 1 + 3 (4 with rolling).
  pure subroutine dissipation_params(info, k0, rolling, u_p2t, u_e)
    type(system_info_t), intent(inout) :: info
    integer, intent(in) :: k0
    logical, intent(in) :: rolling
    character(*), intent(in) :: u_p2t, u_e
    integer :: k
    k = k0
    info%params(k) = p('damping_ratio', 0.0_wp, '1', 'zeta: c = 2 zeta omega_1, omega_1 the lowest well''s ' // &
                       'slow mode (docs/dissipation.md)', symbol='')
    if (rolling) then
      k = k + 1
      info%params(k) = p('rolling_resistance', 0.0_wp, '1', 'C_rr: a drag C_rr g opposing the velocity ' // &
                         '(docs/dissipation.md)', symbol='')
    end if
    info%params(k + 1) = p('noise', 0.0_wp, u_p2t, 'D: white noise sqrt(2 D) dW on each momentum ' // &
                           '(docs/dissipation.md)', symbol='')
    info%params(k + 2) = p('temperature', 0.0_wp, u_e, 'theta: noise by fluctuation-dissipation, ' // &
                           '2 c theta A^-1 (docs/dissipation.md)', symbol='')
    info%np = k + 2
  end subroutine dissipation_params

  !> The name of system k = 1..NSYSTEMS.
  pure function system_name(k) result(name)
    integer, intent(in) :: k
    character(LEN_SYSTEM) :: name
    character(LEN_SYSTEM), parameter :: NAMES(NSYSTEMS) = [character(LEN_SYSTEM) :: &
      'rolling_ball', 'henon_heiles', 'de_leon_berne', 'coupled_quartic', 'cr3bp', 'cr3bp_spatial']
    name = ''
    if (k >= 1 .and. k <= NSYSTEMS) name = NAMES(k)
  end function system_name

  !> The table entry of a system; stat = TUBES_EINPUT for an unknown name.
  subroutine system_info(name, info, stat)
    character(*), intent(in) :: name
    type(system_info_t), intent(out) :: info
    integer, intent(out) :: stat
    stat = TUBES_OK
    info%name = name
    select case (trim(name))
    case ('rolling_ball')
      info%summary = 'a ball rolling on the four-well surface z = H(x, y) (Ross et al. 2018)'
      info%surface = 'fourwell: H = alpha (x^2+y^2) - beta (sqrt(x^2+gamma) + sqrt(y^2+gamma)) ' // &
                     '- xi x y + h0'
      info%params(1) = p('alpha', 0.07_wp, '1/cm', 'curvature of the bowl')
      info%params(2) = p('beta', 1.017_wp, '1', 'depth of the wells')
      info%params(3) = p('gamma', 15.103_wp, 'cm^2', 'smoothing of the ridges (> 0)')
      info%params(4) = p('xi', 0.00656_wp, '1/cm', 'tilt coupling of x and y')
      info%params(5) = p('h0', 12.065_wp, 'cm', 'height offset')
      info%params(6) = p('g', 981.0_wp, 'cm/s^2', 'gravitational acceleration (> 0)', symbol='')
      call dissipation_params(info, 7, .true., '(cm/s)^2/s', '(cm/s)^2')
      info%length_units = 'cm'
      info%box(1:2) = 20
      info%saddle = 'S12'
      info%formula_kind = 'surface'
      info%formula = 'alpha*(x^2 + y^2) - beta*(sqrt(x^2 + gamma) + sqrt(y^2 + gamma)) - xi*x*y + h0'
      info%coordinates = 'x y'
      info%section_kind = 'ray'
      info%section_angle = 45
      info%section_direction = 1
      info%gate = 1.5_wp
    case ('henon_heiles')
      info%summary = 'H = (px^2 + py^2)/2 + (x^2 + y^2)/2 + x^2 y - y^3/3 (Henon & Heiles 1964)'
      info%formula = '(px^2 + py^2)/2 + (x^2 + y^2)/2 + x^2*y - y^3/3'
      call dissipation_params(info, 1, .false., '1', '1')
      info%length_units = '1'
      info%box(1:2) = 1.5_wp
      info%saddle_near(1:2) = [0.0_wp, 1.0_wp]
      info%section_kind = 'plane'
      info%section_index = 2
      info%section_value = 0
      info%section_direction = 1
      info%gate = 0.1_wp
    case ('de_leon_berne')
      info%summary = 'H = px^2/(2 m_a) + py^2/(2 m_b) + D (1 - exp(-lambda x))^2 ' // &
                     '+ 4 y^2 (y^2 - 1) exp(-zeta lambda x) + eps_s (De Leon & Berne 1981)'
      info%params(1) = p('m_a', 8.0_wp, '1', 'mass of the x mode (> 0)')
      info%params(2) = p('m_b', 8.0_wp, '1', 'mass of the y mode (> 0)')
      info%params(3) = p('d', 10.0_wp, '1', 'dissociation energy D of the Morse oscillator')
      info%params(4) = p('lambda', 1.5_wp, '1', 'range of the Morse oscillator (> 0)', symbol='lam')
      info%params(5) = p('zeta', 1.0_wp, '1', 'decay of the double well along x')
      info%params(6) = p('eps_s', 1.0_wp, '1', 'energy of the saddle')
      call dissipation_params(info, 7, .false., '1', '1')
      info%formula = 'px^2/(2*m_a) + py^2/(2*m_b) + d*(1 - exp(-lam*x))^2 ' // &
                     '+ 4*y^2*(y^2 - 1)*exp(-zeta*lam*x) + eps_s'
      info%length_units = '1'
      info%box(1:2) = [1.0_wp, 1.5_wp]
      info%saddle_near(1:2) = 0
      info%section_kind = 'plane'
      info%section_index = 2
      info%section_value = 1/sqrt(2.0_wp)
      info%section_direction = -1
      info%gate = 0.1_wp
    case ('coupled_quartic')
      info%summary = 'H = px^2/(2 m_a) + py^2/(2 m_b) - alpha x^2/2 + beta x^4/4 + omega y^2/2 ' // &
                     '+ eps (x - y)^2/2 (UPOsHam)'
      info%params(1) = p('m_a', 1.0_wp, '1', 'mass of the x mode (> 0)')
      info%params(2) = p('m_b', 1.0_wp, '1', 'mass of the y mode (> 0)')
      info%params(3) = p('alpha', 1.0_wp, '1', 'negative curvature of the x double well')
      info%params(4) = p('beta', 1.0_wp, '1', 'quartic stiffness of x (> 0)')
      info%params(5) = p('omega', 1.0_wp, '1', 'stiffness of the y mode')
      info%params(6) = p('eps', 0.1_wp, '1', 'coupling of x and y')
      call dissipation_params(info, 7, .false., '1', '1')
      info%formula = 'px^2/(2*m_a) + py^2/(2*m_b) - alpha*x^2/2 + beta*x^4/4 + omega*y^2/2 ' // &
                     '+ eps*(x - y)^2/2'
      info%length_units = '1'
      info%box(1:2) = 2
      info%saddle_near(1:2) = 0
      info%section_kind = 'plane'
      info%section_index = 1
      info%section_value = -1
      info%section_direction = 1
      info%gate = 0.1_wp
    case ('cr3bp', 'cr3bp_spatial')
      info%np = 1
      info%params(1) = p('mu', 0.01215058560962404_wp, '1', 'mass ratio m2/(m1 + m2) in (0, 1/2]')
      info%length_units = '1'
      info%saddle = 'L1'
      info%section_kind = ''
      info%gate = 0.05_wp
      if (name == 'cr3bp') then
        info%summary = 'planar circular restricted three-body problem, rotating frame: H = ' // &
                       '(px^2 + py^2)/2 + y px - x py - (1 - mu)/r1 - mu/r2'
        info%formula = '(px^2 + py^2)/2 + y*px - x*py - (1 - mu)/sqrt((x + mu)^2 + y^2) ' // &
                       '- mu/sqrt((x - 1 + mu)^2 + y^2)'
        info%box(1:2) = 1.5_wp
      else
        info%summary = 'spatial circular restricted three-body problem, rotating frame: H = ' // &
                       '|p|^2/2 + y px - x py - (1 - mu)/r1 - mu/r2 (also cr3bp with spatial = .true.)'
        info%ndof = 3
        info%formula = '(px^2 + py^2 + pz^2)/2 + y*px - x*py - (1 - mu)/sqrt((x + mu)^2 + y^2 + z^2)' // &
                       ' - mu/sqrt((x - 1 + mu)^2 + y^2 + z^2)'
        info%coordinates = 'x y z'
        info%momenta = 'px py pz'
        info%box(1:3) = [1.5_wp, 1.5_wp, 0.3_wp]
      end if
    case default
      call expression_info(name, info, stat)
      return
    end select
    if (info%formula_kind == '') info%formula_kind = 'hamiltonian'
    if (info%coordinates == '') info%coordinates = 'x y'
    if (info%momenta == '' .and. info%formula_kind == 'hamiltonian') info%momenta = 'px py'
  end subroutine system_info

  !> A built-in system with parameters params as a formula spec (the text python/tubes/codegen.py
  !> reads, as src/io/tubes_nml.f90 writes it for a formula model): the Taylor method's source.
  function builtin_spec(info, params) result(text)
    type(system_info_t), intent(in) :: info
    real(wp), intent(in) :: params(:)
    character(:), allocatable :: text
    character, parameter :: NL = new_line('a')
    integer :: k
    text = 'tubes-expression 1' // NL // 'kind ' // trim(info%formula_kind) // NL // &
           'expr ' // trim(info%formula) // NL // 'coordinates ' // trim(info%coordinates) // NL
    if (info%momenta /= '') text = text // 'momenta ' // trim(info%momenta) // NL
    do k = 1, info%np
      if (info%params(k)%symbol == '') cycle
      text = text // 'constant ' // trim(info%params(k)%symbol) // ' = ' // f64(params(k)) // NL
    end do
    if (info%formula_kind == 'surface') then
      text = text // 'gravity ' // f64(params(6)) // NL
    end if
  end function builtin_spec

  !> A model written as a formula (system name expr_<hash>, src/io/tubes_expr.c): its entry is
  !> generic, no default section, the lowest rank-1 saddle S1, a search box of half-width 1
  !> (the rolling ball's: 20 cm); docs/models.md.
  subroutine expression_info(name, info, stat)
    character(*), intent(in) :: name
    type(system_info_t), intent(inout) :: info
    integer, intent(out) :: stat
    type(expr_lib_t) :: lib
    character(len=160) :: formula           ! the library's own copy is 160 characters (tubes_expression)
    stat = TUBES_EINPUT
    if (len_trim(name) /= 21 .or. name(1:min(5, len(name))) /= 'expr_') return
    if (open_library(name, lib) /= TUBES_OK) return
    formula = c_to_f(lib%formula)
    info%saddle = 'S1'
    info%section_kind = ''
    if (lib%kind == KIND_SURFACE) then
      info%summary = clip('a ball rolling on z = ' // trim(formula), len(info%summary))
      info%surface = clip(trim(formula), len(info%surface))
      info%params(1) = p('g', 981.0_wp, 'cm/s^2', 'gravitational acceleration (> 0)')
      call dissipation_params(info, 2, .true., '(cm/s)^2/s', '(cm/s)^2')
      info%length_units = 'cm'
      info%box(1:2) = 20
      info%gate = 1.5_wp
    else
      info%summary = clip('H = ' // trim(formula), len(info%summary))
      info%ndof = lib%ndof
      info%np = 0
      if (lib%natural /= 0) call dissipation_params(info, 1, .false., '1', '1')
      info%length_units = '1'
      info%box(1:lib%ndof) = 1
      info%gate = 0.1_wp
    end if
    stat = TUBES_OK
  end subroutine expression_info

  integer function open_library(name, lib) result(stat)
    character(*), intent(in) :: name
    type(expr_lib_t), intent(out) :: lib
    character(kind=c_char) :: key(LEN_SYSTEM)
    call f_to_c(name, key)
    stat = int(expr_open(key, lib))
  end function open_library

  !> The conservative model of a system with parameters params (in the table's order).
  !> stat = TUBES_EINPUT for an unknown system or parameters out of range.
  subroutine make_model(system, params, model, stat)
    character(*), intent(in) :: system
    real(wp), intent(in) :: params(:)
    class(hamiltonian_t), allocatable, intent(out) :: model
    integer, intent(out) :: stat
    type(system_info_t) :: info
    type(ball_t) :: ball
    call system_info(system, info, stat)
    if (stat /= TUBES_OK) return
    stat = TUBES_EINPUT
    if (size(params) < info%np) return
    if (.not. all(abs(params(1:info%np)) <= huge(1.0_wp))) return
    select case (trim(system))
    case ('rolling_ball')
      call conservative_ball(params(1:NMODEL), ball, stat)
      if (stat /= TUBES_OK) return
      allocate (model, source=ball)
    case ('henon_heiles')
      allocate (model, source=henon_heiles_t())
    case ('de_leon_berne')
      if (params(1) <= 0 .or. params(2) <= 0 .or. params(4) <= 0) return
      allocate (model, source=de_leon_berne_t(m_a=params(1), m_b=params(2), d=params(3), &
                                              lambda=params(4), zeta=params(5), eps_s=params(6)))
    case ('coupled_quartic')
      if (params(1) <= 0 .or. params(2) <= 0 .or. params(4) <= 0) return
      allocate (model, source=coupled_quartic_t(m_a=params(1), m_b=params(2), alpha=params(3), &
                                                beta=params(4), omega=params(5), eps=params(6)))
    case ('cr3bp')
      if (.not. (params(1) > 0 .and. params(1) <= 0.5_wp)) return
      allocate (model, source=cr3bp_t(mu=params(1)))
    case ('cr3bp_spatial')
      if (.not. (params(1) > 0 .and. params(1) <= 0.5_wp)) return
      allocate (model, source=cr3bp_t(mu=params(1), nd=3))
    case default
      call expression_model(system, params, model, stat)
      return
    end select
    model%formula = builtin_spec(info, params)
    stat = TUBES_OK
  end subroutine make_model

  !> The model of a formula's library: a Hamiltonian, or the ball on a surface (params g,
  !> damping_ratio).
  subroutine expression_model(system, params, model, stat)
    character(*), intent(in) :: system
    real(wp), intent(in) :: params(:)
    class(hamiltonian_t), allocatable, intent(out) :: model
    integer, intent(out) :: stat
    type(expr_lib_t) :: lib
    type(expr_surface_t) :: surf
    type(ball_t) :: ball
    character(:), allocatable :: text
    stat = open_library(system, lib)
    if (stat /= TUBES_OK) return
    call library_spec(system, text)
    if (lib%kind /= KIND_SURFACE) then
      call expr_model(lib, model, stat)
      if (stat == TUBES_OK .and. len(text) > 0) model%formula = text
      return
    end if
    stat = TUBES_EINPUT
    if (.not. params(1) > 0) return
    call expr_surface(lib, surf, stat)
    if (stat /= TUBES_OK) return
    call make_ball(ball, surf, params(1), four_well=.false.)
    if (len(text) > 0) then
      ball%formula = text // 'gravity ' // f64(params(1)) // new_line('a')
    end if
    allocate (model, source=ball)
  end subroutine expression_model

  !> A double as its exact bits, 'f64:' and 16 hexadecimal digits (the formula specs' numbers:
  !> exact, and cheap to write; python/tubes/codegen.py reads them).
  pure function f64(x) result(s)
    real(wp), intent(in) :: x
    character(20) :: s
    write (s, '(a, z16.16)') 'f64:', transfer(x, 0_i8)
  end function f64

  !> The spec text of a formula model's library ('' if it cannot be read).
  subroutine library_spec(name, text)
    character(*), intent(in) :: name
    character(:), allocatable, intent(out) :: text
    character(kind=c_char) :: key(LEN_SYSTEM), buf(8192)
    call f_to_c(name, key)
    text = ''
    if (expr_spec(key, buf, size(buf)) /= TUBES_OK) return
    text = c_to_f(buf)
  end subroutine library_spec

  !> The damping ratio zeta of a system's parameters (its parameter damping_ratio; 0 for a system
  !> without one).
  real(wp) function damping_ratio_of(system, params) result(zeta)
    character(*), intent(in) :: system
    real(wp), intent(in) :: params(:)
    zeta = param_of(system, params, 'damping_ratio')
  end function damping_ratio_of

  !> The parameter `name` of a system's parameters (0 for a system without it).
  real(wp) function param_of(system, params, name) result(x)
    character(*), intent(in) :: system, name
    real(wp), intent(in) :: params(:)
    type(system_info_t) :: info
    integer :: k, stat
    x = 0
    call system_info(system, info, stat)
    if (stat /= TUBES_OK) return
    do k = 1, min(info%np, size(params))
      if (info%params(k)%name == name) x = params(k)
    end do
  end function param_of

  !> Is the model of these parameters dissipative (damping_ratio, rolling_resistance, noise or
  !> temperature > 0)?
  logical function dissipative(system, params)
    character(*), intent(in) :: system
    real(wp), intent(in) :: params(:)
    dissipative = param_of(system, params, 'damping_ratio') > 0 .or. &
                  param_of(system, params, 'rolling_resistance') > 0 .or. noisy_params(system, params)
  end function dissipative

  !> Does the model of these parameters carry noise (noise or temperature > 0)?
  logical function noisy_params(system, params)
    character(*), intent(in) :: system
    real(wp), intent(in) :: params(:)
    noisy_params = param_of(system, params, 'noise') > 0 .or. param_of(system, params, 'temperature') > 0
  end function noisy_params

  !> The vector field a scene integrates: the conservative model, or for the rolling ball with
  !> dissipation (damping_ratio, rolling_resistance, noise, temperature) the damped_t wrapper: the
  !> viscous rate c = 2 zeta omega_1, the rolling drag f = C_rr g, the noise and its stochastic
  !> step 2 pi / omega_1 / 1000 (docs/dissipation.md). noiseless: without the noise (the
  !> deterministic model: the transition region). c: the viscous rate used (0 if none); f_roll: the
  !> rolling drag [cm/s^2] (0 if none).
  subroutine make_field(system, params, field, c, stat, f_roll, noiseless)
    character(*), intent(in) :: system
    real(wp), intent(in) :: params(:)
    class(vector_field_t), allocatable, intent(out) :: field
    real(wp), intent(out) :: c
    integer, intent(out) :: stat
    real(wp), intent(out), optional :: f_roll
    logical, intent(in), optional :: noiseless
    class(hamiltonian_t), allocatable :: model
    type(damped_t) :: damped
    real(wp) :: zeta, crr, d, theta, w1
    c = 0
    if (present(f_roll)) f_roll = 0
    call make_model(system, params, model, stat)
    if (stat /= TUBES_OK) return
    zeta = param_of(system, params, 'damping_ratio')
    crr = param_of(system, params, 'rolling_resistance')
    d = param_of(system, params, 'noise')
    theta = param_of(system, params, 'temperature')
    if (present(noiseless)) then
      if (noiseless) d = 0
      if (noiseless) theta = 0
    end if
    select type (model)
    type is (ball_t)
      if (zeta > 0 .or. crr > 0 .or. d > 0 .or. theta > 0) then
        w1 = 0
        if (zeta > 0 .or. d > 0 .or. theta > 0) call slow_frequency(model, w1, stat)
        if (stat /= TUBES_OK) return
        c = 2*zeta*w1
        call make_damped(damped, model, c)
        if (crr > 0) then               ! |v3| = sqrt(ROLL p . v), M v = ROLL p (docs/dissipation.md)
          damped%f = crr*model%g
          damped%sigma = ROLL
          damped%v_reg = V_ROLL
        end if
        damped%noise = d
        damped%temperature = theta
        if (d > 0 .or. theta > 0) damped%h_noise = 2*PI/w1/1000
        if (present(f_roll)) f_roll = damped%f
        allocate (field, source=damped)
        return
      end if
    class is (natural_t)             ! any other natural model: viscous damping and noise
      if (zeta > 0 .or. d > 0 .or. theta > 0) then
        call well_frequency(model, system, w1, stat)
        if (stat /= TUBES_OK) return
        c = 2*zeta*w1
        call make_damped(damped, model, c)
        damped%noise = d
        damped%temperature = theta
        if (d > 0 .or. theta > 0) damped%h_noise = 2*PI/w1/1000
        allocate (field, source=damped)
        return
      end if
    end select
    allocate (field, source=model)
  end subroutine make_field

  !> omega_1, the slowest small-oscillation frequency of the lowest well of a natural model
  !> [rad/time]: the smallest sqrt of the eigenvalues of A K at the minimum (A the kinetic matrix,
  !> K the potential's Hessian; the ball's sqrt(5/7 g kappa_1)), its wells searched in the
  !> table's box. stat = TUBES_EINPUT without a well there.
  subroutine well_frequency(model, system, w1, stat)
    class(natural_t), intent(in) :: model
    character(*), intent(in) :: system
    real(wp), intent(out) :: w1
    integer, intent(out) :: stat
    type(equilibrium_t), allocatable :: eqs(:)
    type(system_info_t) :: info
    real(wp), allocatable :: a(:, :), k(:, :), grad(:), wr(:), wi(:)
    integer :: i, kbest, n
    w1 = 0
    call system_info(system, info, stat)
    if (stat /= TUBES_OK) return
    n = model%ndof()
    call find_equilibria(model, info%box_center(1:n) - info%box(1:n), info%box_center(1:n) + info%box(1:n), &
                         41, eqs, stat)
    if (stat /= TUBES_OK) return
    kbest = 0
    do i = 1, size(eqs)
      if (eqs(i)%morse /= 0) cycle
      if (kbest == 0) then
        kbest = i
      else if (eqs(i)%energy < eqs(kbest)%energy) then
        kbest = i
      end if
    end do
    stat = TUBES_EINPUT               ! no well to define the damping ratio against
    if (kbest == 0) return
    allocate (a(n, n), k(n, n), grad(n), wr(n), wi(n))
    call model%rest_kinetic_matrix(eqs(kbest)%q, a)
    call model%shape_derivs(eqs(kbest)%q, grad, k)
    call eigen(matmul(a, model%potential_scale()*k), wr, wi, stat)
    if (stat /= TUBES_OK) return
    stat = TUBES_EINPUT
    if (.not. all(wr > 0)) return     ! a flat mode (zero curvature): no frequency
    w1 = sqrt(minval(wr))
    stat = TUBES_OK
  end subroutine well_frequency

  !> Natural systems: the momenta of velocity v at q, p = A(q)^-1 v (the ball: its own
  !> (7/5) M v). stat = TUBES_EINPUT for other models.
  subroutine momentum_of(model, q, v, p, stat)
    class(hamiltonian_t), intent(in) :: model
    real(wp), intent(in) :: q(:), v(:)
    real(wp), intent(out) :: p(:)
    integer, intent(out) :: stat
    real(wp) :: a(size(q), size(q)), b(size(q))
    integer :: ipiv(size(q)), info, n
    p = 0
    stat = TUBES_EINPUT
    n = size(q)
    select type (model)
    type is (ball_t)
      p = model%momentum(q, v)
      stat = TUBES_OK
    class is (natural_t)
      call model%kinetic_matrix(q, a)
      b = v
      call dgesv(n, 1, a, n, ipiv, b, n, info)
      if (info /= 0) return
      p = b
      stat = TUBES_OK
    end select
  end subroutine momentum_of

  !> Natural systems: V(q). stat = TUBES_EINPUT for other models.
  subroutine potential_of(model, q, v, stat)
    class(hamiltonian_t), intent(in) :: model
    real(wp), intent(in) :: q(:)
    real(wp), intent(out) :: v
    integer, intent(out) :: stat
    v = 0
    stat = TUBES_EINPUT
    select type (model)
    class is (natural_t)
      v = model%potential(q)
      stat = TUBES_OK
    end select
  end subroutine potential_of

  !> Natural systems: gradient and Hessian of the potential's shape (the ball: of H(x, y)).
  subroutine shape_derivs_of(model, q, grad, hess, stat)
    class(hamiltonian_t), intent(in) :: model
    real(wp), intent(in) :: q(:)
    real(wp), intent(out) :: grad(:), hess(:, :)
    integer, intent(out) :: stat
    grad = 0
    hess = 0
    stat = TUBES_EINPUT
    select type (model)
    class is (natural_t)
      call model%shape_derivs(q, grad, hess)
      stat = TUBES_OK
    end select
  end subroutine shape_derivs_of

  !> The conservative ball on the four-well surface of params(1:6).
  subroutine conservative_ball(params, ball, stat)
    real(wp), intent(in) :: params(NMODEL)
    type(ball_t), intent(out) :: ball
    integer, intent(out) :: stat
    stat = TUBES_OK
    if (params(3) <= 0 .or. params(6) <= 0) then   ! gamma > 0 keeps sqrt real; g > 0
      stat = TUBES_EINPUT
      return
    end if
    call make_ball(ball, fourwell_t(alpha=params(1), beta=params(2), gamma=params(3), &
                                    xi=params(4), h0=params(5)), params(6))
  end subroutine conservative_ball

  !> Damping rate c = 2 zeta omega_1 [1/s], omega_1 the lower small-oscillation frequency at
  !> the lowest well (docs/theory.md, "Damping"): a property of the surface, so its wells are
  !> searched in the table's box for rolling_ball (not the run's &equilibria box). Only call
  !> when zeta > 0.
  subroutine damping_rate(ball, zeta, c, stat)
    type(ball_t), intent(in) :: ball
    real(wp), intent(in) :: zeta   !! damping ratio [1]
    real(wp), intent(out) :: c     !! damping rate [1/s]
    integer, intent(out) :: stat
    real(wp) :: w1
    call slow_frequency(ball, w1, stat)
    c = 2*zeta*w1
  end subroutine damping_rate

  !> omega_1 [rad/s], the slow small-oscillation frequency of the lowest well (docs/theory.md,
  !> "Damping"), its wells searched in the table's box for rolling_ball.
  subroutine slow_frequency(ball, w1, stat)
    type(ball_t), intent(in) :: ball
    real(wp), intent(out) :: w1
    integer, intent(out) :: stat
    type(equilibrium_t), allocatable :: eqs(:)
    type(system_info_t) :: info
    integer :: k, kbest
    w1 = 0
    call system_info('rolling_ball', info, stat)
    call find_equilibria(ball, info%box_center(1:2) - info%box(1:2), info%box_center(1:2) + info%box(1:2), &
                         41, eqs, stat)
    if (stat /= TUBES_OK) return
    kbest = 0
    do k = 1, size(eqs)
      if (eqs(k)%morse /= 0) cycle
      if (kbest == 0) then
        kbest = k
      else if (eqs(k)%energy < eqs(kbest)%energy) then
        kbest = k
      end if
    end do
    if (kbest == 0) then
      stat = TUBES_EINPUT   ! no well to define the damping ratio against
      return
    end if
    w1 = sqrt(ROLL*ball%g*eqs(kbest)%curv(1))
  end subroutine slow_frequency

  !> The rolling ball a scene integrates: conservative unless params(7) (zeta) > 0.
  subroutine model_ball(params, model, c, stat)
    real(wp), intent(in) :: params(NMODEL)
    class(vector_field_t), allocatable, intent(out) :: model
    real(wp), intent(out) :: c      !! damping rate used [1/s] (0 if conservative)
    integer, intent(out) :: stat
    call make_field('rolling_ball', params, model, c, stat)
  end subroutine model_ball
end module tubes_models
