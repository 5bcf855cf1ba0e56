!> The transition scene (docs/usage.md, docs/output.md /section and /transition) as one procedure
!> of the core: p_trans(dE) = A_tube / A_E at each energy (the tube's cut with the section and the
!> energy surface's area there), beside it the leading order (T_po/A0) dE (1 - tau dE/A0); for a
!> dissipative model the transition region's A_region / A_E, the conservative model's numbers
!> beside it and the region's threshold. Its console table, its messages and verdicts. The energies
!> are dealt out over the MPI ranks (tubes_par: energy k on rank mod(k - 1, nranks)), each computed
!> by its rank alone and then shared, so the record is the same on every rank for any number of
!> ranks. It returns a result record (tubes_record) that the program's driver writes
!> (src/io/tubes_record_write.c) and Python reads (tubes.transition).
module tubes_scene_transition
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan, ieee_is_nan
  use tubes_kinds, only: wp
  use tubes_status, only: TUBES_EPASTEND, TUBES_ENOCONV, TUBES_EINPUT, TUBES_ENOCROSS, TUBES_ENARROW, &
                          status_message
  use tubes_cstrings, only: num
  use tubes_record, only: record_t, EXIT_PARTIAL
  use tubes_hamiltonian, only: hamiltonian_t
  use tubes_equilibria, only: equilibrium_t
  use tubes_methods, only: integ_choice_t
  use tubes_orbits, only: orbit_t, orbit_opts_t
  use tubes_manifold, only: tube_opts_t, tube_cut_t
  use tubes_region, only: region_opts_t, region_t
  use tubes_par, only: par_t, par_here, par_share
  use tubes_setup, only: scene_dissipation, dissipation_attrs
  use tubes_study, only: study_t, section_choice_t, seed_stores_t, cut_at, cut_outputs, section_info, &
                         region_at, region_numbers, region_info_t, study_family, p_trans_leading
  use tubes_scene_section, only: scene_section, SEC_KIND_RAY
  use tubes_scene_text, only: itoa, rs, wall, progress_line
  use tubes_config, only: tubes_config_t
  use tubes_settings, only: settings_study, settings_section
  implicit none
  private

  public :: scene_transition, transition_opts_of, family_stop_text, past_end_message, region_text, cut_message, take_cut

  !> The scene's settings beyond the study's (&tubes, &transition, &orbits, &montecarlo).
  type, public :: transition_opts_t
    real(wp) :: eps = 1.0e-6_wp        !! &tubes eps: the tube's step-off
    real(wp) :: area_tol = 1.0e-10_wp  !! &transition area_tol
    real(wp) :: t_max = 30             !! &tubes t_max
    integer :: n_init = 64, n_max = 4096   !! &tubes n_init, n_max
    integer :: orb_max_iter = 25, orb_n_samples = 201   !! &orbits max_iter, n_samples
    real(wp) :: gate = 0, mc_t_max = 20    !! &montecarlo gate, t_max: the region's transit test
    real(wp) :: angle_deg = 0          !! &section angle [deg] (the ray's, as given)
    character(16) :: gate_units = ''   !! ' cm' (the ball's), or '' for a dimensionless model
    character(16) :: energy_units = '' !! ' (cm/s)^2', or ''
    character(16) :: speed_units = ''  !! ' cm/s', or ''
  end type transition_opts_t

  !> A tube cut as the scenes take it (take_cut): its first n points, its numbers, its status.
  type, public :: scene_cut_t
    integer :: stat = 0, n = 0, n_failed = 0, nhist = 0, hist_n(64) = 0
    real(wp), allocatable :: tau(:), r(:), pr(:), time(:), x(:, :)   !! x: the states (2N, n)
    real(wp) :: area = 0, area_polygon = 0, action = 0, period = 0, hist_area(64) = 0, fail_tau = 0, sigma = 0
    real(wp), allocatable :: floquet(:)
  end type scene_cut_t

  !> The leading-order p_trans is flagged where |tau dE/A0| exceeds this.
  real(wp), parameter :: LEADING_RANGE = 0.3_wp
  integer, parameter :: LERR = 2048     ! an energy's messages (as the C driver's buffer)
  integer, parameter :: REGION_NOUT = 4096
  integer, parameter :: NR = 10, NI = 5  ! an energy's shared reals and integers

contains

  !> The scene at the energies des of the study's saddle (st: model, box, saddle, orbit options and
  !> integrator) with section sec; o: the other settings; dissip: the dissipation in words ('' for
  !> a conservative model); written: /section is in the output already; stores: the run's kept
  !> results (or null). rec: the scene's record.
  !> The tube-dynamics scenes' shared settings from the run's (&tubes, &orbits, &montecarlo gate and
  !> t_max, &section angle), with area_tol the scene's own; units: the messages carry the ball's units.
  function transition_opts_of(cfg, area_tol, units) result(o)
    type(tubes_config_t), intent(in) :: cfg
    real(wp), intent(in) :: area_tol
    logical, intent(in) :: units
    type(transition_opts_t) :: o
    o%eps = cfg%tub_eps
    o%area_tol = area_tol
    o%t_max = cfg%tub_t_max
    o%n_init = cfg%tub_n_init
    o%n_max = cfg%tub_n_max
    o%orb_max_iter = cfg%orb_max_iter
    o%orb_n_samples = cfg%orb_n_samples
    o%gate = cfg%mc_gate
    o%mc_t_max = cfg%mc_t_max
    o%angle_deg = cfg%sec_angle
    if (units) then
      o%gate_units = ' cm'
      o%energy_units = ' (cm/s)^2'
      o%speed_units = ' cm/s'
    end if
  end function transition_opts_of

  !> The scene on the run's settings cfg (&transition de and area_tol), the saddle and the method the
  !> run chose; units, dissip, written, stores as transition_scene_body's.
  subroutine scene_transition(cfg, saddle, method, units, dissip, written, stores, rec)
    type(tubes_config_t), intent(in) :: cfg
    character(*), intent(in) :: saddle, dissip
    integer, intent(in) :: method
    logical, intent(in) :: units, written
    type(seed_stores_t), pointer, intent(in) :: stores
    type(record_t), intent(inout) :: rec
    call transition_scene_body(settings_study(cfg, saddle, method), settings_section(cfg), cfg%tra_de(1:cfg%tra_nde), &
                               transition_opts_of(cfg, cfg%tra_area_tol, units), dissip, written, stores, rec)
  end subroutine scene_transition

  subroutine transition_scene_body(st, sec, des, o, dissip, written, stores, rec)
    type(study_t), intent(in) :: st
    type(section_choice_t), intent(in) :: sec
    real(wp), intent(in) :: des(:)
    type(transition_opts_t), intent(in) :: o
    character(*), intent(in) :: dissip
    logical, intent(in) :: written
    type(seed_stores_t), pointer, intent(in) :: stores
    type(record_t), intent(inout) :: rec
    real(wp) :: a0, tau, tpo, th_lo, th_hi, th_area, de
    real(wp), allocatable :: rv(:, :), pl(:), sel(:)
    integer, allocatable :: iv(:, :), ev(:, :)
    character(:), allocatable :: cons, err
    logical :: ok, damped, out
    integer :: n, k, beyond, i, j
    type(par_t) :: par
    call scene_section(st, sec, o%angle_deg, written, stores, rec, a0, tau, tpo, ok)
    if (.not. ok) return
    n = size(des)
    damped = len_trim(dissip) > 0
    par = par_here()
    if (par%nranks > 1) call progress_line('transition: ' // itoa(n) // ' energies dealt out to ' // &
                                           itoa(par%nranks) // ' MPI ranks', .false.)
    ! per energy: reals A_tube, action, A_E, p_trans, seconds, A_region, p_trans (damped), the
    ! threshold's lo, hi and area there; integers rc, status, region status, empty, rays; messages
    allocate (rv(NR, n), iv(NI, n), ev(LERR, n), pl(n))
    rv = 0; iv = 0; ev = 0
    do k = 1, n
      if (.not. par%mine(k)) cycle
      call energy(k, rv(:, k), iv(:, k), ev(:, k))
    end do
    call par_share(rv, par)
    call par_share(iv, par)
    call par_share(ev, par)
    if (damped) then
      call rec%out('transition: the dissipative model (' // dissip // '): p_trans(dE) = A_region / A_E on ' // &
                   itoa(n) // " energies, A_region the section points that pass the saddle's gate (area_tol " // &
                   num(o%area_tol) // "); beside it the conservative model's A_tube / A_E")
      call rec%out('  ' // rs('dE', 10) // ' ' // rs('A_region', 14) // ' ' // rs('A_tube', 14) // ' ' // &
                   rs('A_E', 14) // ' ' // rs('p_trans', 12) // ' ' // rs('conservative', 12) // ' ' // rs('rays', 6))
    else
      call rec%out('transition: p_trans(dE) = A_tube / A_E on ' // itoa(n) // ' energies (area_tol ' // &
                   num(o%area_tol) // ')')
      call rec%out('  ' // rs('dE', 10) // ' ' // rs('A_tube', 14) // ' ' // rs('action', 14) // ' ' // &
                   rs('A_E', 14) // ' ' // rs('p_trans', 12) // ' ' // rs('leading', 12))
    end if
    beyond = 0
    th_lo = ieee_value(1.0_wp, ieee_quiet_nan)
    th_hi = th_lo
    th_area = th_lo
    do k = 1, n
      de = des(k)
      pl(k) = p_trans_leading(tpo, a0, tau, de)
      ! the energy's messages, line by line (the first a verdict where the energy failed)
      err = text_of(ev(:, k))
      i = 1
      do while (len(err) > 0 .and. i <= len(err))
        j = index(err(i:), new_line('a'))
        if (j == 0) j = len(err) - i + 2
        if (i == 1 .and. iv(1, k) /= 0) then
          call rec%verdict(EXIT_PARTIAL, err(i:i + j - 2))
        else
          call rec%err(err(i:i + j - 2))
        end if
        i = i + j
      end do
      if (len(err) == 0 .and. iv(1, k) /= 0) rec%code = max(rec%code, EXIT_PARTIAL)
      if (damped) then
        if (iv(4, k) /= 0 .and. .not. ieee_is_nan(rv(8, k))) then
          if (ieee_is_nan(th_lo) .or. rv(8, k) > th_lo) then
            th_lo = rv(8, k)
            th_hi = rv(9, k)
            th_area = rv(10, k)
          end if
        end if
        if (iv(2, k) == TUBES_EPASTEND) then
          cons = rs('past end', 12)
        else
          cons = num(rv(4, k), '12.6g')
        end if
        if (iv(3, k) < 0) then
          call rec%out('  ' // num(de, '10.4g') // '   failed (status ' // itoa(iv(3, k)) // ', stderr says why)' // &
                       repeat(' ', 25) // ' ' // cons // '  (' // num(rv(5, k), '.1f') // ' s)')
        else if (iv(4, k) /= 0) then
          call rec%out('  ' // num(de, '10.4g') // ' ' // num(0.0_wp, '14.8g') // ' ' // num(rv(1, k), '14.8g') // ' ' // &
                       num(rv(3, k), '14.8g') // ' ' // num(rv(7, k), '12.6g') // ' ' // cons // ' ' // rs('-', 6) // &
                       '  (' // num(rv(5, k), '.1f') // ' s)')
        else
          call rec%out('  ' // num(de, '10.4g') // ' ' // num(rv(6, k), '14.8g') // ' ' // num(rv(1, k), '14.8g') // &
                       ' ' // num(rv(3, k), '14.8g') // ' ' // num(rv(7, k), '12.6g') // ' ' // cons // ' ' // &
                       rs(itoa(iv(5, k)), 6) // '  (' // num(rv(5, k), '.1f') // ' s)')
        end if
      else if (iv(2, k) == TUBES_EPASTEND) then
        call rec%out('  ' // num(de, '10.4g') // '   refused: past the end of the family (no orbit at this energy)')
      else
        out = abs(tau/a0*de) > LEADING_RANGE
        if (out) beyond = beyond + 1
        call rec%out('  ' // num(de, '10.4g') // ' ' // num(rv(1, k), '14.8g') // ' ' // num(rv(2, k), '14.8g') // ' ' // &
                     num(rv(3, k), '14.8g') // ' ' // num(rv(4, k), '12.6g') // ' ' // num(pl(k), '12.6g') // &
                     merge('*', ' ', out) // '  (' // num(rv(5, k), '.1f') // ' s)')
      end if
    end do
    if (damped .and. .not. ieee_is_nan(th_lo)) then
      if (ieee_is_nan(th_hi)) then
        call rec%out('  no point of the section found to transit at dE <= ' // num(th_lo) // &
                     ' (the scan and the search up to there)')
      else if (th_area > 0) then
        call rec%out('  the region closes between dE = ' // num(th_lo, '.8g') // ' and ' // num(th_hi, '.8g') // &
                     ' (area ' // num(th_area, '.3g') // ' at the upper end): the search from its centre finds no ' // &
                     'point that transits at dE <= ' // num(th_lo, '.8g'))
      else     ! the upper end's region: a point that transits, too small or ragged to trace
        call rec%out('  the region closes between dE = ' // num(th_lo, '.8g') // ' and ' // num(th_hi, '.8g') // &
                     ' (at the upper end a point transits, its region too small to trace): the search from its ' // &
                     'centre finds no point that transits at dE <= ' // num(th_lo, '.8g'))
      end if
    end if
    if (beyond > 0) call rec%out('  * the leading order (T_po/A0) dE (1 - tau dE/A0) is outside its range there: ' // &
                                 'tau dE/A0 > ' // num(LEADING_RANGE) // ' (p_trans is A_tube/A_E, computed)')
    call rec%real('transition', 'dE', des, [n])
    call rec%real('transition', 'A_tube', rv(1, :), [n])
    call rec%real('transition', 'action', rv(2, :), [n])
    call rec%real('transition', 'A_E', rv(3, :), [n])
    sel = rv(4, :)
    if (damped) sel = rv(7, :)
    call rec%real('transition', 'p_trans', sel, [n])
    call rec%real('transition', 'p_trans_leading', pl, [n])
    if (damped) then
      call rec%int('transition', 'status', iv(3, :), [n])
      call rec%real('transition', 'A_region', rv(6, :), [n])
      call rec%real('transition', 'p_trans_conservative', rv(4, :), [n])
      call rec%int('transition', 'status_conservative', iv(2, :), [n])
      call rec%int('transition', 'region_rays', iv(5, :), [n])
      call rec%attr_real('transition', 'dE_threshold_lo', th_lo)
      call rec%attr_real('transition', 'dE_threshold_hi', th_hi)
    else
      call rec%int('transition', 'status', iv(2, :), [n])
    end if
    if (damped) call dissipation_attrs(scene_dissipation(trim(st%system), st%params), 'transition', rec, '')

  contains
    !> Energy k on this rank: its numbers x, its codes c and its messages e (character codes, 0 ended).
    subroutine energy(k, x, c, e)
      integer, intent(in) :: k
      real(wp), intent(out) :: x(NR)
      integer, intent(out) :: c(NI), e(LERR)
      real(wp) :: de, t0, at, act, per, ae, rmin, rmax, darea, res(12), nan
      integer :: stat, sst, rcode, counts(8), l
      character(:), allocatable :: msg, m
      type(study_t) :: plain
      type(region_t) :: reg
      type(region_info_t) :: info
      type(region_opts_t) :: ro
      nan = ieee_value(1.0_wp, ieee_quiet_nan)
      de = des(k)
      t0 = wall()
      call progress_line('transition: dE = ' // num(de) // ' (' // itoa(k) // ' of ' // itoa(n) // ')...', .true.)
      call cut(st, sec, de, -1, o, stores, at, act, per, stat, msg)
      plain = study_t(system=st%system, params=st%params, lo=st%lo, hi=st%hi, n_grid=st%n_grid, saddle=st%saddle)
      call section_info(plain, sec, de, rmin, rmax, ae, darea, sst, stores)
      if (sst < 0) then
        m = 'tubes: transition: the energy surface on the section at dE = ' // num(de) // ': ' // &
            status_message(sst) // ' (status ' // itoa(sst) // ')'
        if (len(msg) > 0) m = new_line('a') // m
        msg = msg // m
      end if
      rcode = merge(EXIT_PARTIAL, 0, stat < 0 .or. sst < 0)
      if (stat >= 0 .and. sst < 0) stat = sst
      if (sst < 0) ae = nan                  ! the failed call's area is no number of the program's
      if (stat < 0 .and. act == 0) act = nan   ! no orbit (past the family's end): no action
      x = nan
      x(1:3) = [at, act, ae]
      if (sst >= 0) x(4) = at/ae
      c = [rcode, stat, 0, 0, 0]
      if (damped) then        ! the dissipative model's region: p_trans is its fraction
        plain%integ = st%integ
        ro = region_opts_t(area_tol=o%area_tol, t_max=o%mc_t_max, local=.true.)
        ro%n_max = min(ro%n_max, REGION_NOUT)
        call region_at(plain, sec, de, o%gate, ro, reg, info, stat, stores, .false.)
        call region_numbers(reg, info, res, counts)
        c(3) = stat
        c(4) = counts(7)
        c(5) = 0
        if (.not. (reg%empty .or. reg%n == 0)) c(5) = min(reg%n, REGION_NOUT)
        x(8:10) = res(9:11)
        if (stat >= 0) then
          x(6) = merge(0.0_wp, res(1), counts(7) /= 0)
          if (sst >= 0) x(7) = x(6)/ae
        else
          m = region_text(st, o, de, stat, counts)
          if (len(msg) > 0) m = new_line('a') // m
          msg = msg // m
          c(1) = EXIT_PARTIAL
        end if
      end if
      x(5) = wall() - t0
      e = 0
      l = min(len(msg), LERR - 1)
      do i = 1, l
        e(i) = ichar(msg(i:i))
      end do
    end subroutine energy

  end subroutine transition_scene_body

  !> The transition region's failure at de in words (region_numbers' counts).
  function region_text(st, o, de, stat, counts) result(m)
    type(study_t), intent(in) :: st
    type(transition_opts_t), intent(in) :: o
    real(wp), intent(in) :: de
    integer, intent(in) :: stat, counts(8)
    character(:), allocatable :: m
    if (stat == TUBES_ENARROW) then
      m = 'tubes: the transition region at dE = ' // num(de) // ': &montecarlo gate = ' // num(o%gate) // &
          trim(o%gate_units) // " lies within twice the reach of the NHIM across saddle " // trim(st%saddle) // &
          "'s neck (raise gate; docs/input.md)"
    else if (counts(1) == 0) then
      m = 'tubes: the transition region at dE = ' // num(de) // ' failed: ' // status_message(stat) // &
          ' (status ' // itoa(stat) // ')'
    else
      m = 'tubes: the transition region at dE = ' // num(de) // ' failed: ' // status_message(stat) // &
          ' (status ' // itoa(stat) // '); ' // itoa(counts(1)) // ' scan points, ' // itoa(counts(2)) // &
          ' transit, ' // itoa(counts(3)) // ' undecided, ' // itoa(counts(4)) // &
          ' on the wrong side of the traced boundary'
    end if
  end function region_text

  !> The tube's cut at de (kind -1 stable, +1 unstable) on this rank alone, as the scenes take it:
  !> its area (NaN where it failed), the orbit's action and period, the status, and where it
  !> failed the message (else '').
  subroutine cut(st, sec, de, kind, o, stores, area, action, period, stat, msg)
    type(study_t), intent(in) :: st
    type(section_choice_t), intent(in) :: sec
    real(wp), intent(in) :: de
    integer, intent(in) :: kind
    type(transition_opts_t), intent(in) :: o
    type(seed_stores_t), pointer, intent(in) :: stores
    real(wp), intent(out) :: area, action, period
    integer, intent(out) :: stat
    character(:), allocatable, intent(out) :: msg
    type(scene_cut_t) :: x
    call take_cut(st, sec, de, kind, o%eps, o, .true., 0, stores, x)
    stat = x%stat
    action = x%action
    period = x%period
    msg = cut_message(st, sec, de, kind, o, stat, period, x%n_failed, x%fail_tau, x%hist_n(1:x%nhist), &
                      x%hist_area(1:x%nhist), 2, .true., stores)
    area = x%area
    if (stat < 0) area = ieee_value(1.0_wp, ieee_quiet_nan)
  end subroutine cut

  !> The tube's cut at de (kind -1 stable, +1 unstable; step-off eps; o: the other &tubes
  !> settings; on this rank alone if local) with its first nout points (tubes_study cut_at and
  !> cut_outputs, as the C API's tubes_tube_cut).
  subroutine take_cut(st, sec, de, kind, eps, o, local, nout, stores, x)
    type(study_t), intent(in) :: st
    type(section_choice_t), intent(in) :: sec
    real(wp), intent(in) :: de, eps
    integer, intent(in) :: kind, nout
    type(transition_opts_t), intent(in) :: o
    logical, intent(in) :: local
    type(seed_stores_t), pointer, intent(in) :: stores
    type(scene_cut_t), intent(out) :: x
    type(tube_cut_t) :: c
    type(orbit_t) :: orb
    call cut_at(st, sec, de, tube_opts_t(kind=kind, eps=eps, area_tol=o%area_tol, t_max=o%t_max, n_init=o%n_init, &
                                         n_max=o%n_max, local=local), c, orb, x%stat, stores)
    allocate (x%tau(nout), x%r(nout), x%pr(nout), x%time(nout))
    if (allocated(c%x)) then
      allocate (x%x(size(c%x, 1), nout))
    else
      allocate (x%x(4, nout))
    end if
    call cut_outputs(c, orb, x%n, x%tau, x%r, x%pr, x%time, x%x, x%area, x%area_polygon, x%action, x%period, &
                     x%n_failed, x%nhist, x%hist_n, x%hist_area)
    x%fail_tau = c%fail_tau
    x%sigma = c%sigma
    if (allocated(c%floquet)) x%floquet = c%floquet
  end subroutine take_cut

  !> A tube cut's failure at de in words ('' where it worked: stat >= 0): past the family's end
  !> (the family's continuation on this rank alone if local), or the cut's status with what it
  !> means here; nfail seeds failed, the first at fail_tau; hn, ha its area after each round; nd
  !> the model's degrees of freedom.
  function cut_message(st, sec, de, kind, o, stat, period, nfail, fail_tau, hn, ha, nd, local, stores) result(msg)
    type(study_t), intent(in) :: st
    type(section_choice_t), intent(in) :: sec
    real(wp), intent(in) :: de, period, fail_tau, ha(:)
    integer, intent(in) :: kind, stat, nfail, hn(:), nd
    type(transition_opts_t), intent(in) :: o
    logical, intent(in) :: local
    type(seed_stores_t), pointer, intent(in) :: stores
    character(:), allocatable :: msg, fam
    integer :: k
    msg = ''
    if (stat == TUBES_EPASTEND) then
      msg = past_end_message(st, de, o, local, stores)
    else if (stat < 0) then
      msg = 'tubes: the cut at dE = ' // num(de) // ' failed: ' // status_message(stat) // ' (status ' // &
            itoa(stat) // ')'
      if (stat == TUBES_ENOCONV .and. ieee_is_nan(period)) then   ! the orbit, not the cut, failed
        fam = "saddle's"
        if (st%family == -1) fam = 'halo_north'
        if (st%family == -2) fam = 'halo_south'
        msg = msg // ': no orbit of the ' // fam // ' family at this dE'
        if (st%family < 0) msg = msg // ' (below the branch point of the planar family, where the halo branch ' // &
                                 'starts: the orbits scene locates it, /orbits/bifurcations; or beyond the ' // &
                                 "branch's continuation)"
      end if
      if (stat == TUBES_EINPUT .and. nd > 2) msg = msg // ': the plane q' // itoa(sec%index) // ' = ' // &
        num(sec%level) // ' passes through the saddle ' // trim(st%saddle) // " (no side for the manifold's " // &
        'branch to go to), or the orbit has no hyperbolic multiplier (no stable and unstable manifolds)'
      if (stat == TUBES_ENOCROSS .and. sec%kind /= SEC_KIND_RAY) msg = msg // ': the ' // &
        trim(merge('stable  ', 'unstable', kind < 0)) // " manifold's branch towards the plane q" // &
        itoa(sec%index) // ' = ' // num(sec%level) // ' does not reach it (crossing it with dq' // itoa(sec%index) // &
        '/dt ' // merge('>', '<', sec%dir > 0) // ' 0) within &tubes t_max = ' // num(o%t_max) // &
        '; raise t_max or choose another plane or direction'
      if (nfail > 0) msg = msg // '; ' // itoa(nfail) // ' seed(s) failed, the first at orbit phase tau = ' // &
                           num(fail_tau, '.10g') // ' s of T = ' // num(period, '.10g') // ' s'
      if (size(hn) > 0) then
        msg = msg // '; area after each round:'
        do k = 1, size(hn)
          msg = msg // ' ' // itoa(hn(k)) // ':' // num(ha(k), '.12g')
        end do
      end if
    end if
  end function cut_message

  !> Why the saddle's family has no orbit at de, for a cut asked past it: where the family ends
  !> and why, as the orbits scene says.
  function past_end_message(st, de, o, local, stores) result(m)
    type(study_t), intent(in) :: st
    real(wp), intent(in) :: de
    type(transition_opts_t), intent(in) :: o
    logical, intent(in) :: local           !! the continuation on this rank alone
    type(seed_stores_t), pointer, intent(in) :: stores
    character(:), allocatable :: m
    type(study_t) :: plain
    type(orbit_opts_t) :: oo
    type(orbit_t), allocatable :: orbs(:)   ! (a local array: gfortran 12 -O1 -fcheck=all warned on its initialiser)
    class(hamiltonian_t), allocatable :: model
    type(equilibrium_t), allocatable :: eqs(:)
    real(wp) :: end_de
    integer :: isad, reason, stat
    plain = study_t(system=st%system, params=st%params, lo=st%lo, hi=st%hi, n_grid=st%n_grid, saddle=st%saddle, &
                    integ=st%integ)
    oo = orbit_opts_t(n_segments=st%n_segments, tol=st%orb_tol, rtol=st%orb_rtol, atol=st%orb_atol, &
                      max_iter=o%orb_max_iter, n_samples=o%orb_n_samples, family=st%family, local=local, &
                      integ=st%integ)
    allocate (orbs(1))
    call study_family(plain, [de], oo, model, eqs, isad, orbs, end_de, reason, stat, stores)
    if (stat < 0) then
      end_de = -1
      reason = 0
    end if
    m = 'tubes: ' // family_stop_text(trim(st%saddle), de, end_de, reason, trim(o%energy_units)) // ' (and no tube)'
  end function past_end_message

  !> Why the family has no orbit at de (its continuation ended at end_de, if > 0, for reason):
  !> past the family's end, or short of its extrapolated end. units: ' (cm/s)^2' or ''.
  function family_stop_text(saddle, de, end_de, reason, units) result(m)
    character(*), intent(in) :: saddle, units
    real(wp), intent(in) :: de, end_de
    integer, intent(in) :: reason
    character(:), allocatable :: m
    if (end_de > 0 .and. de >= end_de*(1 - 1.0e-6_wp)) then
      m = 'dE = ' // num(de) // ' is past the end of the ' // saddle // ' family, which ends at dE ~ ' // &
          num(end_de, '.8g') // units // ' (' // end_reason_text(reason) // '): no orbit there'
    else if (end_de > 0) then
      m = 'dE = ' // num(de) // ' was not reached: the continuation of the ' // saddle // &
          ' family stopped before it (' // end_reason_text(reason)
      if (reason == 2) m = m // ": it passed the continuation's limit on the period"
      m = m // "); the family's end, extrapolated from its last orbits, is at dE ~ " // num(end_de, '.8g') // units // &
          ', beyond this dE: an orbit may exist there that the continuation does not reach'
    else
      m = 'dE = ' // num(de) // ' is past the end of the ' // saddle // ' family: no orbit there'
    end if
  end function family_stop_text

  pure function end_reason_text(r) result(t)
    integer, intent(in) :: r
    character(:), allocatable :: t
    select case (r)
    case (1); t = 'the orbits run into another equilibrium'
    case (2); t = 'the period grows without bound'
    case (3); t = 'the correction fails for ever smaller steps'
    case (4); t = "the branch's energy turns back (a fold)"
    case (5); t = 'the family has no branch point below the largest dE'
    case (6); t = 'the continuation took its 2000 steps'
    case (7); t = "past a fold the energy returned to the start's"
    case (8); t = 'the guess did not converge'
    case (9); t = "no requested energy lies on the branch's side of the bifurcation"
    case (10); t = "the arc closed into a loop (a fold at its start's energy; the energies not taken are not on it)"
    case (11); t = "the saddle's centre modes do not define the family by this name"
    case default; t = 'none'
    end select
  end function end_reason_text

  !> Character codes (0 ended) as text.
  pure function text_of(e) result(s)
    integer, intent(in) :: e(:)
    character(:), allocatable :: s
    integer :: k, n
    n = 0
    do k = 1, size(e)
      if (e(k) == 0) exit
      n = k
    end do
    allocate (character(n) :: s)
    do k = 1, n
      s(k:k) = achar(e(k))
    end do
  end function text_of
end module tubes_scene_transition
