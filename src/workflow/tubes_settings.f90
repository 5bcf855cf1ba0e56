!> The run's settings (tubes_config_t, as the reader left them) turned into what the scenes take:
!> the study (model, box, saddle, orbit corrector), the section, the integrator, the orbits'
!> options. One definition of each conversion (the section's angle from degrees to radians, the
!> stage solver's code, single or multiple shooting), for the C driver and for Python alike: both
!> hand a scene the settings themselves (C its struct, Python its bytes: settings_of_bytes), with
!> the two things the run resolved before any scene (tubes_setup: the saddle, the method).
module tubes_settings
  use, intrinsic :: iso_c_binding, only: c_int8_t
  use tubes_kinds, only: wp, PI
  use tubes_cstrings, only: c_to_f
  use tubes_config, only: tubes_config_t
  use tubes_methods, only: integ_choice_t, method_opts_t, METHOD_AUTO
  use tubes_orbits, only: orbit_opts_t
  use tubes_study, only: study_t, section_choice_t, SECTION_RAY, SECTION_PLANE
  implicit none
  private

  public :: settings_of_bytes, settings_bytes, settings_integ, settings_section, settings_study, &
            settings_orbit_opts, settings_n_segments, settings_text, settings_method_label, orbit_guess_branch

contains

  !> The settings from their bytes (Python holds them as the reader's read_input returned them).
  !> st /= 0: not a settings' size (a caller's mistake, said by the caller).
  subroutine settings_of_bytes(b, cfg, st)
    integer(c_int8_t), intent(in) :: b(:)
    type(tubes_config_t), intent(out) :: cfg
    integer, intent(out) :: st
    st = 0
    if (size(b) /= settings_bytes()) then
      st = 1
      return
    end if
    cfg = transfer(b, cfg)
  end subroutine settings_of_bytes

  !> The size of the settings in bytes.
  pure integer function settings_bytes()
    type(tubes_config_t) :: cfg
    integer(c_int8_t) :: one(1)
    settings_bytes = size(transfer(cfg, one))
  end function settings_bytes

  !> A C string field of the settings as Fortran text.
  pure function settings_text(c) result(s)
    character(len=1), intent(in) :: c(:)
    character(:), allocatable :: s
    s = c_to_f(c)
  end function settings_text

  !> &integrator's choice with the method the run resolved (tubes_setup method_resolved: 'auto'
  !> is the Taylor method or DOP853, never itself here).
  pure function settings_integ(cfg, method) result(c)
    type(tubes_config_t), intent(in) :: cfg
    integer, intent(in) :: method
    type(integ_choice_t) :: c
    c%method = method
    c%h = cfg%h
    c%opts = method_opts_t(omega_bind=cfg%omega_bind, solver=merge(2, 1, c_to_f(cfg%solver) == 'fixed_point'), &
                           max_iter=cfg%max_iter)
  end function settings_integ

  !> The method the run integrates with in words: &integrator method, and for 'auto' what it became
  !> ('auto (taylor)': the Taylor method for the state, DOP853 for the variational equations;
  !> 'auto (dop853)': no Taylor kernel, tubes_setup method_resolved).
  pure function settings_method_label(cfg, method) result(s)
    type(tubes_config_t), intent(in) :: cfg
    integer, intent(in) :: method
    character(:), allocatable :: s
    s = c_to_f(cfg%method)
    if (s /= 'auto') return
    s = merge('auto (taylor)', 'auto (dop853)', method == METHOD_AUTO)
  end function settings_method_label

  !> &section: the ball's ray at &section angle (degrees in the input, radians here) or the plane
  !> q_index = value.
  pure function settings_section(cfg) result(sec)
    type(tubes_config_t), intent(in) :: cfg
    type(section_choice_t) :: sec
    if (c_to_f(cfg%sec_kind) == 'ray') then
      sec = section_choice_t(kind=SECTION_RAY, index=cfg%sec_index, level=cfg%sec_angle*PI/180, dir=cfg%sec_pth_sign)
    else
      sec = section_choice_t(kind=SECTION_PLANE, index=cfg%sec_index, level=cfg%sec_value, dir=cfg%sec_direction)
    end if
  end function settings_section

  !> &orbits method: single shooting (1) or multiple shooting's n_segments.
  pure integer function settings_n_segments(cfg)
    type(tubes_config_t), intent(in) :: cfg
    settings_n_segments = merge(cfg%orb_n_segments, 1, c_to_f(cfg%orb_method) == 'multiple')
  end function settings_n_segments

  !> The study of a scene: the model (cfg%model, the library's name: expr_<hash> for a formula),
  !> its box and grid, the saddle the run chose, &orbits' corrector and family, the integrator.
  pure function settings_study(cfg, saddle, method) result(st)
    type(tubes_config_t), intent(in) :: cfg
    character(*), intent(in) :: saddle
    integer, intent(in) :: method
    type(study_t) :: st
    st%system = c_to_f(cfg%model)
    st%params = cfg%params
    st%lo = cfg%box_lo
    st%hi = cfg%box_hi
    st%n_grid = cfg%n_grid
    st%saddle = saddle
    st%n_segments = settings_n_segments(cfg)
    st%family = cfg%orb_family
    st%orb_tol = cfg%orb_tol
    st%orb_rtol = cfg%orb_rtol
    st%orb_atol = cfg%orb_atol
    st%integ = settings_integ(cfg, method)
  end function settings_study

  !> &orbits' options (the family, the corrector, a guess and its period; 'branch:K' as branch K
  !> of family 1).
  pure function settings_orbit_opts(cfg, method) result(o)
    type(tubes_config_t), intent(in) :: cfg
    integer, intent(in) :: method
    type(orbit_opts_t) :: o
    o%n_segments = settings_n_segments(cfg)
    o%tol = cfg%orb_tol
    o%rtol = cfg%orb_rtol
    o%atol = cfg%orb_atol
    o%max_iter = cfg%orb_max_iter
    o%n_samples = cfg%orb_n_samples
    o%family = cfg%orb_family
    o%integ = settings_integ(cfg, method)
    call orbit_guess_branch(cfg%orb_nguess, cfg%orb_guess, cfg%orb_period, o)
  end function settings_orbit_opts

  !> &orbits guess (nguess > 0 values: the family through it, its period) and 'branch:K' (family
  !> <= -101: branch K = -100 - family of family 1) into o, for the scenes and the C API's calls.
  pure subroutine orbit_guess_branch(nguess, guess, period, o)
    integer, intent(in) :: nguess
    real(wp), intent(in) :: guess(:), period
    type(orbit_opts_t), intent(inout) :: o
    if (nguess > 0) then
      o%guess = guess(1:nguess)
      o%guess_period = period
    end if
    if (o%family <= -101) then
      o%branch = -100 - o%family
      o%family = 1
    end if
  end subroutine orbit_guess_branch
end module tubes_settings
