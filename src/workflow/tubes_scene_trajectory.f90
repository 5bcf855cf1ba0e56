!> The trajectory scene (docs/usage.md, docs/output.md /trajectory) as one procedure of the core:
!> one trajectory of a 2-DOF model sampled every dt_out, its crossings of a section, its energy
!> error against the model's energy scale, its console lines and verdicts, in a result record
!> (tubes_record) that the program's driver writes (src/io/tubes_record_write.c). Its progress
!> lines during a long run are printed as they come (progress_line), not recorded.
module tubes_scene_trajectory
  use, intrinsic :: ieee_arithmetic, only: ieee_is_nan, ieee_is_finite, ieee_value, ieee_quiet_nan
  use tubes_kinds, only: wp, i8, PI
  use tubes_status, only: TUBES_OK, TUBES_FULL, status_message
  use tubes_cstrings, only: num
  use tubes_record, only: record_t, EXIT_BADINPUT, EXIT_NUMERIC, EXIT_PARTIAL
  use tubes_hamiltonian, only: hamiltonian_t
  use tubes_equilibria, only: equilibrium_t
  use tubes_integrator, only: integrator_t
  use tubes_methods, only: method_opts_t
  use tubes_sampler, only: sampler_t
  use tubes_run, only: run_trajectory, section_spec_t, sized_model, field_rates, SECTION_NONE, SECTION_THETA, &
                       SECTION_X, SECTION_Y
  use tubes_study, only: seed_stores_t, model_equilibria
  use tubes_models, only: make_model
  use tubes_scene_text, only: itoa, wall, progress_line
  use tubes_config, only: tubes_config_t
  use tubes_settings, only: settings_text, settings_method_label
  implicit none
  private

  public :: scene_trajectory, trajectory_section

  !> The scene's settings: &trajectory's and &integrator's (docs/input.md), the model's
  !> dissipation as the console names it.
  type, public :: trajectory_settings_t
    real(wp) :: x0(4) = 0                !! (x0, y0, px0, py0); at_rest: the momenta are 0
    logical :: at_rest = .false.
    real(wp) :: t_end = 0, dt_out = 0
    character(:), allocatable :: section !! '' (none), 'U1-', 'U1+', 'U1', 'theta', 'x', 'y'
    integer :: section_direction = 0, max_crossings = 0
    real(wp) :: section_angle = 0        !! [deg] (section 'theta')
    real(wp) :: section_level = 0        !! (sections 'x', 'y')
    logical :: stop_at_first = .false.
    integer :: method = 0                !! the method's code (tubes_methods), resolved ('auto' as run)
    character(:), allocatable :: method_label, solver
    real(wp) :: rtol = 0, atol = 0, h = 0
    integer(i8) :: max_steps = 0
    type(method_opts_t) :: mopts
    real(wp) :: zeta = 0, crr = 0        !! damping ratio, rolling resistance (0: none)
    real(wp) :: f_roll = 0               !! the rolling drag [cm/s^2] (crr > 0)
    character(:), allocatable :: dissip  !! the dissipation in words ('' conservative)
  end type trajectory_settings_t

  !> The samples with a progress line, at most one a second, every PROGRESS_EVERY steps.
  type, extends(sampler_t) :: progress_sampler_t
    real(wp) :: run_end = 0, began = 0, shown = 0   !! t_end [s]; the wall clock at the start, at the last line
  contains
    procedure :: on_step => progress_on_step
  end type progress_sampler_t
  integer, parameter :: PROGRESS_EVERY = 2000

contains

  !> The scene for system (params) and the settings s; the equilibria in the box [lo, hi] (n_grid
  !> starts per axis) give the energy scale. label: the model in messages; input: the input file
  !> ('tubes' without one); us, ue: ' s' and ' (cm/s)^2' as messages write them after a time and an
  !> energy ('' for a dimensionless model). stores: the run's kept results (or null). rec: the
  !> scene's record.
  !> The scene on the run's settings cfg (&trajectory, &integrator with the method the run chose), the
  !> run's dissipation (zeta, crr, f_roll [cm/s^2], dissip in words: tubes_setup model_dissipation's),
  !> label the model's name, input the input file and us, ue the time's and the energy's units in
  !> messages.
  subroutine scene_trajectory(cfg, method, zeta, crr, f_roll, dissip, label, input, us, ue, stores, rec)
    type(tubes_config_t), intent(in) :: cfg
    integer, intent(in) :: method
    real(wp), intent(in) :: zeta, crr, f_roll
    character(*), intent(in) :: dissip, label, input, us, ue
    type(seed_stores_t), pointer, intent(in) :: stores
    type(record_t), intent(inout) :: rec
    type(trajectory_settings_t) :: s
    ! (component by component: gfortran 12 garbles a constructor's deferred-length strings)
    s%x0 = [cfg%x0, cfg%y0, cfg%px0, cfg%py0]
    s%at_rest = cfg%at_rest /= 0
    s%t_end = cfg%t_end
    s%dt_out = cfg%dt_out
    s%section = settings_text(cfg%section)
    s%section_direction = cfg%section_direction
    s%max_crossings = cfg%max_crossings
    s%section_angle = cfg%section_angle
    s%section_level = cfg%section_level
    s%stop_at_first = cfg%stop_at_first /= 0
    s%method = method
    s%method_label = settings_method_label(cfg, method)
    s%solver = settings_text(cfg%solver)
    s%rtol = cfg%rtol
    s%atol = cfg%atol
    s%h = cfg%h
    s%max_steps = cfg%max_steps
    s%mopts = method_opts_t(omega_bind=cfg%omega_bind, solver=merge(2, 1, s%solver == 'fixed_point'), &
                            max_iter=cfg%max_iter)
    s%zeta = zeta
    s%crr = crr
    s%f_roll = f_roll
    s%dissip = dissip
    call trajectory_scene_body(settings_text(cfg%model), cfg%params, s, cfg%box_lo, cfg%box_hi, cfg%n_grid, label, &
                               input, us, ue, stores, rec)
  end subroutine scene_trajectory

  subroutine trajectory_scene_body(system, params, s, lo, hi, n_grid, label, input, us, ue, stores, rec)
    character(*), intent(in) :: system, label, input, us, ue
    real(wp), intent(in) :: params(:), lo(:), hi(:)
    type(trajectory_settings_t), intent(in) :: s
    integer, intent(in) :: n_grid
    type(seed_stores_t), pointer, intent(in) :: stores
    type(record_t), intent(inout) :: rec
    class(hamiltonian_t), allocatable :: model
    type(equilibrium_t), allocatable :: eqs(:)
    type(section_spec_t) :: sec
    type(progress_sampler_t) :: obs
    real(wp), allocatable :: t(:), st(:, :), en(:), ct(:), cx(:, :), rr(:)
    integer, allocatable :: cd(:)
    real(wp) :: x0(4), e, f(4), sl, t0, tw, cdamp, e0, abserr, escale, range, elo, ehi, maxerr, tlast, lost
    integer(i8) :: cnt(4)
    integer :: stat, nd, nmax, n, ncross, k, neq, ierr
    logical :: known
    character(:), allocatable :: msg, line
    x0 = s%x0
    if (s%at_rest) x0(3:4) = 0
    call make_model(system, params, model, stat)
    nd = 0
    if (stat == TUBES_OK) nd = model%ndof()
    if (nd /= 2) then
      call rec%verdict(EXIT_BADINPUT, 'tubes: trajectory: system ' // label // ' has ' // itoa(nd) // &
                       ' degrees of freedom; the trajectory scene takes (x0, y0, px0, py0) of a 2-DOF model')
      return
    end if
    ! H and Hamilton's equations are finite at the start (a formula may not be: log(x) at x < 0)
    e = 0
    call sized_model(system, params, 4, .false., model, stat)
    if (stat == TUBES_OK) e = model%energy(x0)
    ierr = stat
    f = 0
    call field_rates(system, params, x0, f, stat)
    if (ierr < 0 .or. stat < 0 .or. .not. ieee_is_finite(e) .or. .not. ieee_is_finite(f(1) + f(2) + f(3) + f(4))) then
      call rec%verdict(EXIT_BADINPUT, input // ': &trajectory: the model is not defined at the starting point ' // &
                       '(x0, y0, px0, py0) = (' // num(x0(1)) // ', ' // num(x0(2)) // ', ' // num(x0(3)) // ', ' // &
                       num(x0(4)) // '): H = ' // num(e) // ', dx/dt = (' // num(f(1)) // ', ' // num(f(2)) // ', ' // &
                       num(f(3)) // ', ' // num(f(4)) // '); start where H is finite')
      return
    end if
    nmax = int(floor(s%t_end/s%dt_out*(1 + 1e-12_wp)) + 2)
    ! the section: kind, level, orientation (docs/input.md)
    sec = section_spec_t(stop_at_first=s%stop_at_first, max_crossings=s%max_crossings)
    call trajectory_section(s%section, s%section_angle, s%section_level, s%section_direction, sec%kind, sec%level, &
                            sec%dir, known)
    sl = sec%level
    allocate (t(nmax), st(4, nmax), en(nmax), ct(max(s%max_crossings, 1)), cx(4, max(s%max_crossings, 1)), &
              cd(max(s%max_crossings, 1)), stat=ierr)
    if (ierr /= 0) then
      call rec%verdict(EXIT_NUMERIC, 'tubes: trajectory: cannot allocate ' // itoa(nmax) // ' samples')
      return
    end if
    t0 = wall()
    obs%run_end = s%t_end
    obs%began = t0
    obs%shown = t0
    call run_trajectory(system, params, x0, s%t_end, s%dt_out, s%method, s%rtol, s%atol, s%h, s%max_steps, s%mopts, &
                        sec, obs, n, t, st, en, ncross, ct, cx, cd, cnt, cdamp, stat)
    tw = wall() - t0
    msg = status_message(stat)
    e0 = ieee_value(1.0_wp, ieee_quiet_nan)        ! no sample (a start the model refuses): none
    if (n > 0) e0 = en(1)
    abserr = 0
    do k = 1, n
      abserr = fmax(abserr, abs(en(k) - e0))
    end do
    ! the relative error's scale: |E0|, but at least the energy range spanned by E0 and the
    ! equilibria in the &equilibria box (barriers, the start's height above the lowest well), so
    ! that a start near E = 0 (the coupled quartic's saddle) is not measured against ~0
    ! (docs/output.md)
    escale = abs(e0)
    range = 0
    neq = 0
    if (n > 0) then
      call model_equilibria(system, params, lo, hi, n_grid, stores, model, eqs, ierr)
      if (ierr >= 0) then
        if (size(eqs) > 0) then
          elo = e0
          ehi = e0
          do k = 1, size(eqs)
            elo = fmin(elo, eqs(k)%energy)
            ehi = fmax(ehi, eqs(k)%energy)
          end do
          range = ehi - elo
          neq = size(eqs)
        end if
      end if
    end if
    escale = fmax(escale, range)
    maxerr = ieee_value(1.0_wp, ieee_quiet_nan)
    if (escale > 0) maxerr = abserr/escale
    tlast = 0
    if (n > 0) tlast = t(n)
    if (stat < 0) call rec%verdict(EXIT_NUMERIC, 'tubes: trajectory: integration failed after the sample at t = ' // &
                                   num(tlast, '.17g') // us // ': ' // msg // ' (status ' // itoa(stat) // ') after ' // &
                                   itoa(cnt(2)) // ' steps, ' // itoa(cnt(3)) // ' rejected, ' // itoa(cnt(1)) // &
                                   ' evaluations; the samples up to there are written')
    call rec%out('trajectory: ' // s%method_label // ' from (' // num(x0(1)) // ', ' // num(x0(2)) // ', ' // &
                 num(x0(3)) // ', ' // num(x0(4)) // '), E0 = ' // num(e0, '.10g') // ue // ', to t = ' // num(tlast) // &
                 us // ': ' // itoa(n) // ' samples, ' // itoa(cnt(2)) // ' steps (' // itoa(cnt(3)) // ' rejected), ' // &
                 itoa(cnt(1)) // ' evaluations, ' // num(tw, '.3f') // ' s')
    if (sec%kind /= SECTION_NONE) call rec%out('  section ' // s%section // ': ' // itoa(ncross) // ' crossings')
    if (stat == TUBES_FULL) &                       ! before, t_end = 200000 s ended at 24,488 s, exit 0, nothing said
      call rec%verdict(EXIT_PARTIAL, 'tubes: trajectory: stopped at t = ' // num(tlast) // us // ', before t_end = ' // &
                       num(s%t_end) // us // ': the ' // itoa(s%max_crossings) // ' crossings max_crossings allows ' // &
                       'were recorded; the samples up to there are written (raise &trajectory max_crossings, at ' // &
                       'most 1e7, or set stop_at_first)')
    lost = ieee_value(1.0_wp, ieee_quiet_nan)
    if (n > 0) lost = e0 - en(n)
    if (s%zeta > 0 .and. .not. s%crr > 0) then
      call rec%out('  damped (zeta = ' // num(s%zeta) // ', c = ' // num(cdamp, '.6g') // ' 1/s): energy lost ' // &
                   num(lost, '.6g') // ' (cm/s)^2')
    else if (len(s%dissip) > 0) then
      call rec%out('  damped (' // s%dissip // '): energy lost ' // num(lost, '.6g') // ue)
    else
      line = '  max energy error |E - E0| ' // num(abserr, '.3e') // ue // ', relative ' // num(maxerr, '.3e') // &
             ' to the energy scale ' // num(escale, '.6g') // ue
      if (escale == abs(e0) .and. escale > 0) then
        line = line // ' (|E0|)'
      else if (escale > 0) then
        line = line // ' (the energy range of E0 and the ' // itoa(neq) // ' equilibria in the &equilibria box; ' // &
               '|E0| = ' // num(abs(e0), '.3g') // ')'
      else
        line = line // ' (none: E0 = 0 and no equilibria at other energies)'
      end if
      call rec%out(line)
    end if
    call rec%real('trajectory', 't', t(1:n), [n])
    call rec%real('trajectory', 'state', reshape(st(:, 1:n), [4*n]), [n, 4], 'cm, cm, cm/s, cm/s')
    call rec%real('trajectory', 'energy', en(1:n), [n])
    call rec%attr_string('trajectory', 'method', s%method_label)
    call rec%attr_real('trajectory', 'rtol', s%rtol)
    call rec%attr_real('trajectory', 'atol', s%atol)
    call rec%attr_real('trajectory', 'h', s%h)
    call rec%attr_int('trajectory', 'nfev', cnt(1))
    call rec%attr_int('trajectory', 'nsteps', cnt(2))
    call rec%attr_int('trajectory', 'nrejected', cnt(3))
    call rec%attr_int('trajectory', 'niter', cnt(4))
    call rec%attr_real('trajectory', 'omega_bind', s%mopts%omega_bind)
    call rec%attr_string('trajectory', 'solver', s%solver)
    call rec%attr_real('trajectory', 'wall_seconds', tw)
    call rec%attr_real('trajectory', 'damping_rate', cdamp)
    if (s%crr > 0) call rec%attr_real('trajectory', 'rolling_drag', s%f_roll)
    call rec%attr_real('trajectory', 'max_rel_energy_error', maxerr)
    call rec%attr_real('trajectory', 'max_energy_error', abserr)
    call rec%attr_real('trajectory', 'energy_scale', escale)
    call rec%attr_int('trajectory', 'status', stat)
    call rec%attr_string('trajectory', 'status_message', msg)
    if (sec%kind == SECTION_NONE) return
    call rec%real('trajectory/crossings', 't', ct(1:ncross), [ncross])
    call rec%real('trajectory/crossings', 'state', reshape(cx(:, 1:ncross), [4*ncross]), [ncross, 4], &
                  'cm, cm, cm/s, cm/s')
    call rec%int('trajectory/crossings', 'direction', cd(1:ncross), [ncross])
    call rec%attr_string('trajectory/crossings', 'section', s%section)
    call rec%attr_real('trajectory/crossings', 'level', merge(sl, s%section_level, sec%kind == SECTION_THETA))
    if (sec%kind /= SECTION_THETA) return
    ! polar canonical coordinates on the ray (docs/events.md)
    allocate (rr(ncross))
    rr = hypot(cx(1, 1:ncross), cx(2, 1:ncross))
    call rec%real('trajectory/crossings', 'r', rr, [ncross])
    call rec%real('trajectory/crossings', 'p_r', (cx(1, 1:ncross)*cx(3, 1:ncross) + cx(2, 1:ncross)*cx(4, 1:ncross))/rr, &
                  [ncross])
    call rec%real('trajectory/crossings', 'p_theta', cx(1, 1:ncross)*cx(4, 1:ncross) - cx(2, 1:ncross)*cx(3, 1:ncross), &
                  [ncross])
  end subroutine trajectory_scene_body

  !> The section of &trajectory section = name (docs/input.md; Python's integrate too): its kind
  !> (tubes_run SECTION_*), level and orientation dir. angle [deg]: the ray's ('theta'); level: the
  !> line's ('x', 'y'); direction: their orientation. known = .false.: no such name (none).
  pure subroutine trajectory_section(name, angle, level, direction, kind, lvl, dir, known)
    character(*), intent(in) :: name
    real(wp), intent(in) :: angle, level
    integer, intent(in) :: direction
    integer, intent(out) :: kind, dir
    real(wp), intent(out) :: lvl
    logical, intent(out) :: known
    kind = SECTION_NONE
    lvl = 0
    dir = direction
    known = .true.
    select case (name)
    case ('U1-')                                    ! p_theta > 0
      kind = SECTION_THETA
      lvl = PI/4
      dir = 1
    case ('U1+')
      kind = SECTION_THETA
      lvl = PI/4
      dir = -1
    case ('U1')
      kind = SECTION_THETA
      lvl = PI/4
      dir = 0
    case ('theta')
      kind = SECTION_THETA
      lvl = angle*PI/180
    case ('x')
      kind = SECTION_X
      lvl = level
    case ('y')
      kind = SECTION_Y
      lvl = level
    case ('', 'none')
      dir = 0
    case default
      dir = 0
      known = .false.
    end select
  end subroutine trajectory_section

  !> The samples, and every PROGRESS_EVERY steps a progress line if a second has passed since the
  !> last (or the start).
  subroutine progress_on_step(self, ig, t_hi)
    class(progress_sampler_t), intent(inout) :: self
    class(integrator_t), intent(inout) :: ig
    real(wp), intent(in) :: t_hi
    character(:), allocatable :: line
    real(wp) :: w
    call self%sampler_t%on_step(ig, t_hi)
    if (mod(self%count, PROGRESS_EVERY) /= 0) return
    w = wall()
    if (w - self%shown < 1) return
    line = 'trajectory: t = ' // num(ig%t, '.4g') // ' of ' // num(self%run_end, '.4g') // ' s (' // &
           num(100*ig%t/self%run_end, '.0f') // '%), ' // num(w - self%began, '.1f') // ' s elapsed'
    call progress_line(line, .false.)
    self%shown = w
  end subroutine progress_on_step

  !> C's fmin: the smaller of a and b, a NaN ignored.
  pure real(wp) function fmin(a, b)
    real(wp), intent(in) :: a, b
    fmin = min(a, b)
    if (ieee_is_nan(a)) fmin = b
    if (ieee_is_nan(b)) fmin = a
  end function fmin

  !> C's fmax: the larger of a and b, a NaN ignored (fmin of the negatives: negation is exact).
  pure real(wp) function fmax(a, b)
    real(wp), intent(in) :: a, b
    fmax = -fmin(-a, -b)
  end function fmax
end module tubes_scene_trajectory
