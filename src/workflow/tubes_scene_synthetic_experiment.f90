!> The synthetic_experiment scene (docs/experiment-data.md, docs/output.md /tracks) as one
!> procedure of the core: the rolling ball's synthetic tracks released around the saddle's energy,
!> their console line and verdicts, in a result record (tubes_record) that the program's driver
!> writes (src/io/tubes_record_write.c; the CSV copy of /tracks is the driver's, a file) and
!> Python's synthetic_experiment reads.
module tubes_scene_synthetic_experiment
  use tubes_kinds, only: wp
  use tubes_status, only: TUBES_OK, TUBES_EINPUT, status_message
  use tubes_cstrings, only: num
  use tubes_record, only: record_t, EXIT_NUMERIC
  use tubes_hamiltonian, only: hamiltonian_t
  use tubes_equilibria, only: equilibrium_t
  use tubes_models, only: MAX_PARAMS, NMODEL
  use tubes_methods, only: integ_choice_t
  use tubes_study, only: seed_stores_t, model_equilibria
  use tubes_experiment, only: experiment_opts_t, experiment_samples, synthetic_experiment
  use tubes_scene_text, only: itoa, wall, progress_line
  use tubes_config, only: tubes_config_t
  use tubes_settings, only: settings_integ, settings_text, settings_method_label
  use, intrinsic :: iso_c_binding, only: c_long
  implicit none
  private

  public :: scene_synthetic_experiment

contains

  !> The scene for the ball (params) whose saddle named saddle is found in the box [lo, hi]
  !> (n_grid starts per axis): ex's tracks (&experiment: n_tracks, duration, camera_rate, pixel,
  !> noise, de_min, de_max, seed; its box, rtol and atol are the defaults, e_e the saddle's), the
  !> ball damped by damping_ratio and rolling_resistance (the model's own dissipation replaced,
  !> without noise), integrated by integ (method: its name for /tracks@method). stores: the run's
  !> kept results (or null). rec: the scene's record.
  !> The scene on the run's settings cfg (&experiment; the integrator with the method the run chose)
  !> at the saddle the run chose.
  subroutine scene_synthetic_experiment(cfg, saddle, method, stores, rec)
    type(tubes_config_t), intent(in) :: cfg
    character(*), intent(in) :: saddle
    integer, intent(in) :: method
    type(seed_stores_t), pointer, intent(in) :: stores
    type(record_t), intent(inout) :: rec
    call experiment_scene_body(settings_text(cfg%model), cfg%params, cfg%box_lo, cfg%box_hi, cfg%n_grid, saddle, &
                               experiment_opts_t(n_tracks=cfg%exp_n_tracks, duration=cfg%exp_duration, &
                                                 camera_rate=cfg%exp_camera_rate, pixel=cfg%exp_pixel, &
                                                 noise=cfg%exp_noise, de_min=cfg%exp_de_min, de_max=cfg%exp_de_max, &
                                                 seed=int(cfg%exp_seed, c_long)), &
                               cfg%exp_damping_ratio, cfg%exp_rolling_resistance, settings_integ(cfg, method), &
                               settings_method_label(cfg, method), stores, rec)
  end subroutine scene_synthetic_experiment

  subroutine experiment_scene_body(system, params, lo, hi, n_grid, saddle, ex, damping_ratio, &
                                   rolling_resistance, integ, method, stores, rec)
    use, intrinsic :: ieee_arithmetic, only: ieee_is_nan
    character(*), intent(in) :: system, saddle, method
    real(wp), intent(in) :: params(:), lo(:), hi(:), damping_ratio, rolling_resistance
    integer, intent(in) :: n_grid
    type(experiment_opts_t), intent(in) :: ex
    type(integ_choice_t), intent(in) :: integ
    type(seed_stores_t), pointer, intent(in) :: stores
    type(record_t), intent(inout) :: rec
    class(hamiltonian_t), allocatable :: model
    type(equilibrium_t), allocatable :: eqs(:)
    type(experiment_opts_t) :: opts
    real(wp), allocatable :: t(:), state(:, :, :), energy(:, :), noisy(:, :, :), meas(:, :, :), rel(:, :)
    real(wp) :: par(MAX_PARAMS), ee, cd, t0
    character(:), allocatable :: roll
    integer :: stat, nt, ns, n, k, j, ndraw, nbad, first, ierr
    ! the saddle's energy E_e: the releases' reference
    ee = 0
    call model_equilibria(system, params, lo, hi, n_grid, stores, model, eqs, stat)
    if (stat >= 0) then
      stat = TUBES_EINPUT
      do k = 1, size(eqs)
        if (eqs(k)%name == saddle .and. eqs(k)%rank1) then
          ee = eqs(k)%energy
          stat = TUBES_OK
          exit
        end if
      end do
    end if
    if (stat /= TUBES_OK) then
      call rec%verdict(EXIT_NUMERIC, 'tubes: synthetic_experiment: the saddle ' // saddle // &
                       ' (E_e) was not found (status ' // itoa(stat) // ')')
      return
    end if
    opts = ex
    opts%e_e = ee
    opts%atol = opts%rtol
    nt = opts%n_tracks
    ns = experiment_samples(opts%duration, opts%camera_rate)
    n = nt*ns
    allocate (t(ns), state(4, ns, nt), energy(ns, nt), noisy(2, ns, nt), meas(2, ns, nt), rel(3, nt), stat=ierr)
    if (ierr /= 0) then
      call rec%verdict(EXIT_NUMERIC, 'tubes: synthetic_experiment: cannot allocate ' // itoa(n) // ' frames')
      return
    end if
    par = 0
    par(1:size(params)) = params
    par(7) = damping_ratio
    par(8) = rolling_resistance
    par(9:10) = 0                  ! no noise: the experiment's ball has its own dissipation alone
    t0 = wall()
    roll = 'synthetic_experiment: ' // itoa(nt) // ' tracks of ' // num(opts%duration) // ' s at ' // &
           num(opts%camera_rate) // ' Hz...'
    call progress_line(roll, .false.)
    call synthetic_experiment(par(1:NMODEL), opts, integ, t, state, energy, noisy, meas, rel, cd, ndraw, stat)
    if (stat == TUBES_EINPUT) then
      call rec%verdict(EXIT_NUMERIC, 'tubes: synthetic_experiment: found fewer than ' // itoa(nt) // &
                       ' release points with g H - E_e in [' // num(opts%de_min) // ', ' // num(opts%de_max) // &
                       '] (cm/s)^2 in the box |x|, |y| <= ' // num(opts%box) // ' cm after ' // itoa(ndraw) // &
                       ' draws (E_e = ' // num(ee, '.10g') // ' (cm/s)^2 of ' // saddle // '); widen [de_min, de_max]')
      return
    end if
    if (stat < 0) then
      call rec%verdict(EXIT_NUMERIC, 'tubes: synthetic_experiment: an integration failed: ' // status_message(stat) // &
                       ' (status ' // itoa(stat) // '); the frames up to the failure are written, NaN after it')
      nbad = count(ieee_is_nan(state(1, ns, :)))
      if (nbad > 0) then
        do first = 1, nt
          if (ieee_is_nan(state(1, ns, first))) exit
        end do
        call rec%verdict(EXIT_NUMERIC, 'tubes: synthetic_experiment: ' // itoa(nbad) // ' of ' // itoa(nt) // &
                         ' tracks stop early; the first, track ' // itoa(first - 1) // ' released at (' // &
                         num(rel(1, first), '.10g') // ', ' // num(rel(2, first), '.10g') // ') cm with dE = ' // &
                         num(rel(3, first), '.10g') // ' (cm/s)^2')
      end if
    end if
    roll = ''
    if (rolling_resistance > 0) roll = ', rolling resistance ' // num(rolling_resistance) // ' (' // &
                                       num(rolling_resistance*params(6), '.6g') // ' cm/s^2)'
    call rec%out('synthetic_experiment: ' // itoa(nt) // ' tracks x ' // itoa(ns) // ' frames (' // &
                 num(opts%camera_rate) // ' Hz, ' // num(opts%duration) // ' s), releases at dE in [' // &
                 num(opts%de_min) // ', ' // num(opts%de_max) // '] (cm/s)^2 (' // itoa(nt) // ' of ' // &
                 itoa(ndraw) // ' draws accepted), zeta = ' // num(damping_ratio) // ' (c = ' // num(cd, '.6g') // &
                 ' 1/s)' // roll // ', noise ' // num(opts%noise) // ' cm, pixel ' // num(opts%pixel) // ' cm (' // &
                 num(wall() - t0, '.2f') // ' s)')
    ! frames as flat columns, by track, then by time (the CSV's track,t,x,y)
    call rec%int('tracks', 'track', [((j - 1, k = 1, ns), j = 1, nt)], [n])
    call rec%real('tracks', 't', [((t(k), k = 1, ns), j = 1, nt)], [n])
    call rec%real('tracks', 'x', reshape(meas(1, :, :), [n]), [n])
    call rec%real('tracks', 'y', reshape(meas(2, :, :), [n]), [n])
    call rec%attr_real('tracks', 'camera_rate', opts%camera_rate)
    call rec%attr_real('tracks', 'pixel', opts%pixel)
    call rec%attr_real('tracks', 'noise', opts%noise)
    call rec%attr_real('tracks', 'damping_ratio', damping_ratio)
    call rec%attr_real('tracks', 'damping_rate', cd)
    if (rolling_resistance > 0) call rec%attr_real('tracks', 'rolling_resistance', rolling_resistance)
    call rec%attr_int('tracks', 'seed', int(opts%seed))
    call rec%attr_int('tracks', 'n_tracks', nt)
    call rec%attr_int('tracks', 'n_samples', ns)
    call rec%attr_real('tracks', 'duration', opts%duration)
    call rec%attr_real('tracks', 'de_min', opts%de_min)
    call rec%attr_real('tracks', 'de_max', opts%de_max)
    call rec%attr_real('tracks', 'E_e', ee)
    call rec%attr_string('tracks', 'saddle', saddle)
    call rec%attr_real('tracks', 'box', opts%box)
    call rec%attr_string('tracks', 'method', method)
    call rec%attr_real('tracks', 'rtol', opts%rtol)
    call rec%attr_int('tracks', 'n_draws', ndraw)
    call rec%attr_int('tracks', 'status', stat)
    ! the truth: states, energies, the noise before the pixels, the releases
    call rec%real('tracks/truth', 'state', reshape(state, [4*n]), [n, 4], 'cm, cm, cm/s, cm/s')
    call rec%real('tracks/truth', 'energy', reshape(energy, [n]), [n])
    call rec%real('tracks/truth', 'dE', reshape(energy, [n]) - ee, [n])
    call rec%real('tracks/truth', 'noisy', reshape(noisy, [2*n]), [n, 2])
    call rec%real('tracks/truth', 'release', reshape(rel(1:2, :), [2*nt]), [nt, 2])
    call rec%real('tracks/truth', 'release_dE', rel(3, :), [nt])
  end subroutine experiment_scene_body
end module tubes_scene_synthetic_experiment
