!> The montecarlo scene (docs/tubes.md "Monte Carlo check", docs/output.md /section and
!> /montecarlo) as one procedure of the core: n points uniform on the section's energy surface at
!> dE, each integrated until it passes the saddle's gate or returns, counted against the tube's
!> p_trans = A_tube / A_E (a dissipative model: its transition region's; a noisy one: the fraction
!> under noise beside the noise-free region's); its console line, its messages and verdicts. It
!> returns a result record (tubes_record) that the program's driver writes
!> (src/io/tubes_record_write.c) and Python reads (tubes.monte_carlo).
module tubes_scene_montecarlo
  use, intrinsic :: iso_c_binding, only: c_long
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
  use tubes_kinds, only: wp
  use tubes_status, only: TUBES_OK, TUBES_EINPUT, TUBES_EPASTEND, TUBES_ENARROW, TUBES_EINTERRUPT, status_message
  use tubes_cstrings, only: num
  use tubes_record, only: record_t, EXIT_PARTIAL, EXIT_NUMERIC
  use tubes_region, only: region_opts_t, region_t
  use tubes_verdicts, only: mc_check
  use tubes_setup, only: scene_dissipation, dissipation_attrs
  use tubes_study, only: study_t, section_choice_t, seed_stores_t, section_info, &
                         region_at, region_numbers, region_outputs, region_info_t, check_at, gate_reach
  use tubes_scene_section, only: scene_section
  use tubes_scene_transition, only: transition_opts_t, transition_opts_of, past_end_message, region_text, take_cut, scene_cut_t
  use tubes_scene_text, only: itoa, wall, progress_line
  use tubes_config, only: tubes_config_t
  use tubes_settings, only: settings_study, settings_section
  implicit none
  private

  public :: scene_montecarlo

  integer, parameter :: REGION_NOUT = 4096, REGION_CURVE = 4096

contains

  !> The scene at de with n points from seed (st: model, box, saddle, orbit options and
  !> integrator; sec the section; o: &tubes' cut settings, area_tol &montecarlo's, gate and t_max
  !> the transit test's); dissip: the dissipation in words ('' conservative); noisy: the model
  !> carries noise; gate_at: the head of a message about &montecarlo gate ("FILE:LINE: "); written:
  !> /section is in the output already; stores: the run's kept results (or null).
  !> The scene on the run's settings cfg (&montecarlo de, n_samples, seed, area_tol), the saddle and
  !> the method the run chose; units: the messages carry the ball's units; the rest as
  !> montecarlo_scene_body's.
  subroutine scene_montecarlo(cfg, saddle, method, units, dissip, noisy, gate_at, written, stores, rec)
    type(tubes_config_t), intent(in) :: cfg
    character(*), intent(in) :: saddle, dissip, gate_at
    integer, intent(in) :: method
    logical, intent(in) :: units, noisy, written
    type(seed_stores_t), pointer, intent(in) :: stores
    type(record_t), intent(inout) :: rec
    call montecarlo_scene_body(settings_study(cfg, saddle, method), settings_section(cfg), cfg%mc_de, cfg%mc_n_samples, &
                               cfg%mc_seed, transition_opts_of(cfg, cfg%mc_area_tol, units), dissip, noisy, gate_at, &
                               written, stores, rec)
  end subroutine scene_montecarlo

  subroutine montecarlo_scene_body(st, sec, de, n, seed, o, dissip, noisy, gate_at, written, stores, rec)
    type(study_t), intent(in) :: st
    type(section_choice_t), intent(in) :: sec
    real(wp), intent(in) :: de
    integer, intent(in) :: n, seed
    type(transition_opts_t), intent(in) :: o
    character(*), intent(in) :: dissip, gate_at
    logical, intent(in) :: noisy, written
    type(seed_stores_t), pointer, intent(in) :: stores
    type(record_t), intent(inout) :: rec
    type(study_t) :: plain, mcst
    type(scene_cut_t) :: x
    type(region_t) :: reg
    type(region_info_t) :: info
    type(region_opts_t) :: ro
    real(wp), allocatable :: cr(:), cp(:), r(:), pr(:), phi(:), rho(:), s(:), p(:), &
                             t_in(:), cs(:), cpp(:)
    integer, allocatable :: outc(:), ins(:)
    logical, allocatable :: inl(:)
    real(wp) :: a0, tau, tpo, t0, ar, rmin, rmax, ae, darea, p_cons, reach, res(12), f, se, &
                pt, nsig, dev
    integer :: nout, nc, nfail, stat, counts(8), nn, m, k, nt, nu, in_nt, out_t, nin, nesc, ntrap, &
               nbad, first, code
    logical :: ok, damped, mc_ran, agrees
    character(1024) :: verdict
    character(:), allocatable :: line
    call scene_section(st, sec, o%angle_deg, written, stores, rec, a0, tau, tpo, ok)
    if (.not. ok) return
    t0 = wall()
    nout = o%n_max
    damped = len_trim(dissip) > 0
    p_cons = ieee_value(1.0_wp, ieee_quiet_nan)
    allocate (r(n), pr(n), outc(n), ins(n), inl(n))
    plain = study_t(system=st%system, params=st%params, lo=st%lo, hi=st%hi, n_grid=st%n_grid, saddle=st%saddle)
    mcst = plain
    mcst%integ = st%integ
    call progress_line('montecarlo: the tube cut at dE = ' // num(de) // '...', .false.)
    call take_cut(st, sec, de, -1, o%eps, o, .false., nout, stores, x)
    stat = x%stat
    nc = x%n
    ar = x%area
    nfail = x%n_failed
    cr = x%r
    cp = x%pr
    if (stat < 0 .and. nfail > 0) &
      call rec%err('tubes: montecarlo: the tube cut at dE = ' // num(de) // ': ' // itoa(nfail) // &
                   ' seed(s) failed, the first at orbit phase tau = ' // num(x%fail_tau, '.10g') // ' s')
    if (stat >= 0) call section_info(plain, sec, de, rmin, rmax, ae, darea, stat, stores)
    if (stat >= 0 .and. damped) then
      ! the dissipative model's prediction: its transition region (the conservative tube's
      ! fraction beside it); the points are sorted by the region's boundary
      p_cons = ar/ae
      call progress_line("montecarlo: the damped model's transition region at dE = " // num(de) // '...', .false.)
      ro = region_opts_t(area_tol=o%area_tol, t_max=o%mc_t_max, local=.false.)
      ro%n_max = min(ro%n_max, REGION_NOUT)
      call region_at(mcst, sec, de, o%gate, ro, reg, info, stat, stores, .true.)
      call region_numbers(reg, info, res, counts)
      if (stat < 0) then
        call rec%err(region_text(st, o, de, stat, counts))
      else
        allocate (phi(REGION_NOUT), rho(REGION_NOUT), s(REGION_NOUT), p(REGION_NOUT), t_in(REGION_NOUT), &
                  cs(REGION_CURVE), cpp(REGION_CURVE))
        call region_outputs(reg, nn, phi, rho, s, p, t_in, m, cs, cpp)
        ar = res(1)
        if (counts(7) /= 0) ar = 0
        nc = m
        if (counts(7) /= 0) nc = 0
        nc = min(nc, nout)
        cr(1:nc) = cs(1:nc)
        cp(1:nc) = cpp(1:nc)
      end if
    end if
    mc_ran = .false.
    if (stat >= 0) then
      mc_ran = .true.
      call progress_line('montecarlo: integrating ' // itoa(n) // ' points...', .false.)
      call check_at(mcst, sec, de, n, int(seed, c_long), o%mc_t_max, o%gate, cr(1:nc), cp(1:nc), r, pr, outc, &
                    inl, stat, stores)
      ins = merge(1, 0, inl)
    end if
    if (stat < 0) then
      code = merge(EXIT_PARTIAL, EXIT_NUMERIC, stat == TUBES_EPASTEND)
      if (stat == TUBES_EPASTEND) then
        call rec%verdict(code, past_end_message(st, de, o, .false., stores))
      else
        reach = 0
        k = TUBES_EINPUT
        if (stat == TUBES_ENARROW) call gate_reach(plain, de, reach, k, stores)
        if (stat == TUBES_ENARROW .and. k == TUBES_OK) then     ! refused before any sample was integrated
          mc_ran = .false.
          call rec%verdict(code, gate_at // '&montecarlo: gate = ' // num(o%gate) // trim(o%gate_units) // &
                           ' lies within twice the reach of the NHIM (the Lyapunov orbits) across saddle ' // &
                           trim(st%saddle) // "'s neck at dE = " // num(de) // ' (' // num(reach, '.3g') // &
                           trim(o%gate_units) // '): orbits near it swing past the gate and back and would count ' // &
                           'as transits; allowed: gate > ' // num(2*reach, '.3g') // trim(o%gate_units) // &
                           ' (docs/input.md)')
        else
          call rec%verdict(code, 'tubes: montecarlo: failed: ' // status_message(stat) // ' (status ' // &
                           itoa(stat) // ')')
        end if
      end if
      if (stat == TUBES_EINTERRUPT) mc_ran = .false.   ! stopped: the samples not drawn did not fail
      nbad = 0
      first = 0
      if (mc_ran) then
        nbad = count(outc < 0)
        if (nbad > 0) first = findloc(outc < 0, .true., 1)
      end if
      if (first > 0) call rec%err('tubes: montecarlo: ' // itoa(nbad) // ' of ' // itoa(n) // &
                                  ' samples failed; the first, sample ' // itoa(first) // ' at (r, p_r) = (' // &
                                  num(r(first), '.10g') // trim(o%gate_units) // ', ' // num(pr(first), '.10g') // &
                                  trim(o%speed_units) // '): ' // status_message(outc(first)) // ' (status ' // &
                                  itoa(outc(first)) // ')')
      ! the failure is recorded in the file (docs/output.md): the scene's status, no fraction
      call group(stat, mc_ran)
      call rec%attr_string('montecarlo', 'status_message', status_message(stat))
      call rec%attr_int('montecarlo', 'agrees', 0)
      return
    end if
    nt = count(outc == 1)
    nu = count(outc == 2)
    nesc = count(outc == 3)      ! left for good through another exit: no transition
    ntrap = count(outc == 4)     ! fell below the saddle's energy (dissipative): no transition
    nin = count(inl)
    in_nt = count(inl .and. outc /= 1)
    out_t = count(.not. inl .and. outc == 1)
    ! the two answers must agree (tubes_verdicts mc_check): the direct count within MC_SIGMA
    ! standard errors of the tube's p_trans, few misclassified, few undecided; else exit 2
    f = real(nt, wp)/n
    se = sqrt(f*(1 - f)/n)
    pt = ar/ae
    code = mc_check(de, n, nt, nu, in_nt + out_t, pt, noisy, trim(st%saddle), nsig, agrees, verdict)
    dev = 0
    if (se > 0) dev = (f - pt)/se
    if (noisy) then    ! no deterministic prediction: the fraction under noise, beside the noise-free region's
      line = 'montecarlo: the noisy model (' // dissip // '), dE = ' // num(de) // ', ' // itoa(n) // &
             ' points: transition fraction ' // num(f, '.5f') // ' +- ' // num(se, '.5f') // &
             " under noise (the noise-free region's p_trans = " // num(pt, '.5f') // ', ' // &
             signed(dev) // ' standard errors from it; conservative ' // &
             'A_tube/A_E = ' // num(p_cons, '.5f') // '); ' // itoa(in_nt + out_t) // &
             ' points end otherwise than the noise-free region says; ' // itoa(nu) // ' undecided'
    else if (damped) then
      line = 'montecarlo: the dissipative model (' // dissip // '), dE = ' // num(de) // ', ' // itoa(n) // &
             ' points: transition fraction ' // num(f, '.5f') // ' +- ' // num(se, '.5f') // &
             ' (p_trans = A_region/A_E = ' // num(pt, '.5f') // ', ' // num(nsig, '.1f') // &
             ' standard errors; conservative A_tube/A_E = ' // num(p_cons, '.5f') // '); ' // itoa(nin) // &
             ' inside the region; misclassified ' // itoa(in_nt) // ' (inside, no transit) + ' // itoa(out_t) // &
             ' (outside, transit); ' // itoa(ntrap) // ' fell below E_e; ' // itoa(nu) // ' undecided'
    else
      line = 'montecarlo: dE = ' // num(de) // ', ' // itoa(n) // ' points: transition fraction ' // &
             num(f, '.5f') // ' +- ' // num(se, '.5f') // ' (p_trans = ' // num(pt, '.5f') // ', ' // &
             num(nsig, '.1f') // ' standard errors); ' // itoa(nin) // ' inside the tube; misclassified ' // &
             itoa(in_nt) // ' (inside, no transit) + ' // itoa(out_t) // ' (outside, transit); ' // itoa(nu) // &
             ' undecided'
    end if
    if (nesc > 0) line = line // ', ' // itoa(nesc) // ' escaped (through another exit)'
    call rec%out(line // ' (' // num(wall() - t0, '.1f') // ' s)')
    call group(0, .true.)
    if (damped) then
      call rec%attr_real('montecarlo', 'p_trans_conservative', p_cons)
      if (noisy) then
        call rec%attr_string('montecarlo', 'predicted_by', "none (noise): p_trans is the noise-free region's")
      else
        call rec%attr_string('montecarlo', 'predicted_by', 'region')
      end if
    end if
    call rec%attr_real('montecarlo', 'fraction', f)
    call rec%attr_real('montecarlo', 'std_error', se)
    call rec%attr_real('montecarlo', 'p_trans', pt)
    call rec%attr_int('montecarlo', 'misclassified', in_nt + out_t)
    call rec%attr_int('montecarlo', 'misclassified_inside_no_transit', in_nt)
    call rec%attr_int('montecarlo', 'misclassified_outside_transit', out_t)
    call rec%attr_int('montecarlo', 'undecided', nu)
    call rec%attr_int('montecarlo', 'escaped', nesc)
    if (damped) call rec%attr_int('montecarlo', 'trapped', ntrap)
    call rec%int('montecarlo', 'inside', ins, [n])
    call rec%attr_int('montecarlo', 'agrees', merge(1, 0, agrees))
    if (.not. agrees) call rec%verdict(EXIT_NUMERIC, trim(verdict))
    if (damped) call dissipation_attrs(scene_dissipation(trim(st%system), st%params), 'montecarlo', rec, 'fraction')
  contains
    !> v as C's %+.1f.
    function signed(v) result(t)
      real(wp), intent(in) :: v
      character(:), allocatable :: t
      t = num(v, '.1f')
      if (t(1:1) /= '-') t = '+' // t
    end function signed

    !> /montecarlo with what every outcome records: dE, n_samples, seed, status, and the points
    !> (r, p_r, transit) when they were integrated.
    subroutine group(status, points)
      integer, intent(in) :: status
      logical, intent(in) :: points
      call rec%attr_real('montecarlo', 'dE', de)
      call rec%attr_int('montecarlo', 'n_samples', n)
      call rec%attr_int('montecarlo', 'seed', seed)
      call rec%attr_int('montecarlo', 'status', status)
      if (points) then
        call rec%real('montecarlo', 'r', r, [n])
        call rec%real('montecarlo', 'p_r', pr, [n])
        call rec%int('montecarlo', 'transit', outc, [n])
      end if
    end subroutine group
  end subroutine montecarlo_scene_body
end module tubes_scene_montecarlo
