!> The tubes scene (docs/tubes.md, docs/output.md /section and /tubes) as one procedure of the
!> core: the cuts of the saddle's stable and unstable tubes with the section at each energy, each
!> repeated with eps/10 (the check that the start's distance from the orbit does not matter); for
!> a dissipative model also its transition regions (the cut of the damped saddle's stable
!> manifold). Its console table, its messages and verdicts. It returns a result record
!> (tubes_record) that the program's driver writes (src/io/tubes_record_write.c) and Python reads
!> (tubes.tube_cut).
module tubes_scene_tubes
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
  use tubes_kinds, only: wp
  use tubes_status, only: TUBES_EPASTEND
  use tubes_cstrings, only: num
  use tubes_record, only: record_t, EXIT_PARTIAL
  use tubes_region, only: region_opts_t, region_t
  use tubes_setup, only: dissipation_t, scene_dissipation, dissipation_attrs
  use tubes_study, only: study_t, section_choice_t, seed_stores_t, region_at, region_numbers, region_outputs, region_info_t
  use tubes_scene_section, only: scene_section
  use tubes_scene_transition, only: transition_opts_t, transition_opts_of, region_text, cut_message, take_cut, scene_cut_t
  use tubes_scene_text, only: itoa, rs, wall, progress_line
  use tubes_config, only: tubes_config_t
  use tubes_settings, only: settings_study, settings_section, settings_text
  implicit none
  private

  public :: scene_tubes

  integer, parameter :: REGION_NOUT = 4096, REGION_CURVE = 4096

contains

  !> The scene at the energies des (st, sec, o as the transition scene's; o%area_tol &tubes'):
  !> kinds 'stable', 'unstable' or 'both'; length: the coordinates' units in words; dissip: the
  !> dissipation in words ('' conservative); check_eps: repeat each cut with eps/10 (the program
  !> does); written: /section is in the output already; stores: the run's kept results (or null).
  !> The scene on the run's settings cfg (&tubes de, kind, area_tol), the saddle and the method the
  !> run chose; units: the messages carry the ball's units; the rest as tubes_scene_body's.
  subroutine scene_tubes(cfg, saddle, method, units, length, dissip, check_eps, written, stores, rec)
    type(tubes_config_t), intent(in) :: cfg
    character(*), intent(in) :: saddle, length, dissip
    integer, intent(in) :: method
    logical, intent(in) :: units, check_eps, written
    type(seed_stores_t), pointer, intent(in) :: stores
    type(record_t), intent(inout) :: rec
    call tubes_scene_body(settings_study(cfg, saddle, method), settings_section(cfg), cfg%tub_de(1:cfg%tub_nde), &
                          settings_text(cfg%tub_kind), transition_opts_of(cfg, cfg%tub_area_tol, units), length, dissip, &
                          check_eps, written, stores, rec)
  end subroutine scene_tubes

  subroutine tubes_scene_body(st, sec, des, kinds, o, length, dissip, check_eps, written, stores, rec)
    type(study_t), intent(in) :: st
    type(section_choice_t), intent(in) :: sec
    real(wp), intent(in) :: des(:)
    character(*), intent(in) :: kinds, length, dissip
    type(transition_opts_t), intent(in) :: o
    logical, intent(in) :: check_eps, written
    type(seed_stores_t), pointer, intent(in) :: stores
    type(record_t), intent(inout) :: rec
    real(wp) :: a0, tau, tpo, a, a10, act, per, t0, de, nan
    integer :: k, kind, stat, nd
    logical :: ok, wrote
    character(:), allocatable :: name, kname, line
    call scene_section(st, sec, o%angle_deg, written, stores, rec, a0, tau, tpo, ok, nd)
    if (.not. ok) return
    nan = ieee_value(1.0_wp, ieee_quiet_nan)
    line = 'tubes: ' // kinds // ' manifold cuts on the section (eps = ' // num(o%eps) // ' ' // length // &
           ', area_tol = ' // num(o%area_tol) // ')'
    if (len(dissip) > 0) line = line // ": the conservative model's Lyapunov orbits and tubes (a damped model " // &
                                'has neither)'
    call rec%out(line)
    call rec%out('  ' // rs('dE', 10) // ' ' // rs('kind', 8) // ' ' // rs('area', 16) // ' ' // rs('action', 16) // &
                 ' ' // rs('area/action-1', 11) // ' ' // rs('eps/10 chg', 11) // ' ' // rs('s', 8))
    do k = 1, size(des)
      do kind = -1, 1, 2
        if (kind < 0 .and. kinds == 'unstable') cycle
        if (kind > 0 .and. kinds == 'stable') cycle
        t0 = wall()
        de = des(k)
        kname = trim(merge('stable  ', 'unstable', kind < 0))
        call progress_line('tubes: dE = ' // num(de) // ', ' // kname // ' manifold (' // itoa(k) // ' of ' // &
                           itoa(size(des)) // ')...', .true.)
        name = kname // '_' // zeros3(k - 1)
        call cut_to(st, sec, de, kind, o%eps, o, nd, 'tubes/' // name, stores, rec, a, act, per, stat, wrote)
        if (stat == TUBES_EPASTEND) then
          call rec%out('  ' // num(de, '10.4g') // ' ' // rs(kname, 8) // &
                       '   refused: past the end of the family (no orbit at this energy)')
          cycle
        end if
        ! the eps/10 repetition of a cut that failed would only fail again (and say so twice)
        a10 = nan
        if (stat >= 0 .and. check_eps) call cut_to(st, sec, de, kind, o%eps/10, o, nd, '', stores, rec, a10, act, &
                                                   per, stat, ok)
        if (wrote) then
          call rec%attr_real('tubes/' // name, 'area_eps10', a10)
          call rec%attr_real('tubes/' // name, 'area_eps_change', abs(a - a10))
        end if
        call rec%out('  ' // num(de, '10.4g') // ' ' // rs(kname, 8) // ' ' // num(a, '16.12g') // ' ' // &
                     num(act, '16.12g') // ' ' // num(a/act - 1, '11.2e') // ' ' // num(abs(a - a10), '11.2e') // &
                     ' ' // num(wall() - t0, '8.2f'))
      end do
    end do
    if (len(dissip) > 0) call regions(st, sec, des, o, dissip, stores, rec)
  end subroutine tubes_scene_body

  !> k as C's %03d.
  pure function zeros3(k) result(u)
    integer, intent(in) :: k
    character(:), allocatable :: u
    u = itoa(k)
    if (len(u) < 3) u = repeat('0', 3 - len(u)) // u
  end function zeros3

  !> One tube cut at de (kind -1 stable, +1 unstable, step-off eps) into group path (none if ''),
  !> by all ranks together; a failure is a verdict (EXIT_PARTIAL) with its message. area (NaN
  !> where it failed), action, period, the status; wrote: the group was recorded.
  subroutine cut_to(st, sec, de, kind, eps, o, nd, path, stores, rec, area, action, period, stat, wrote)
    type(study_t), intent(in) :: st
    type(section_choice_t), intent(in) :: sec
    real(wp), intent(in) :: de, eps
    integer, intent(in) :: kind, nd      !! nd: the model's degrees of freedom
    type(transition_opts_t), intent(in) :: o
    character(*), intent(in) :: path
    type(seed_stores_t), pointer, intent(in) :: stores
    type(record_t), intent(inout) :: rec
    real(wp), intent(out) :: area, action, period
    integer, intent(out) :: stat
    logical, intent(out) :: wrote
    type(scene_cut_t) :: x
    real(wp), allocatable :: sc(:, :)
    integer :: n, j, l, i
    character(:), allocatable :: msg, axes
    call take_cut(st, sec, de, kind, eps, o, .false., o%n_max, stores, x)
    stat = x%stat
    n = x%n
    action = x%action
    period = x%period
    msg = cut_message(st, sec, de, kind, o, stat, period, x%n_failed, x%fail_tau, x%hist_n(1:x%nhist), &
                      x%hist_area(1:x%nhist), nd, .false., stores)
    if (len(msg) > 0) call rec%verdict(EXIT_PARTIAL, msg)
    wrote = len(path) > 0 .and. n > 0
    if (wrote) then
      call rec%real(path, 'r', x%r(1:n), [n])
      call rec%real(path, 'p_r', x%pr(1:n), [n])
      call rec%real(path, 'time', x%time(1:n), [n])
      call rec%real(path, 'tau', x%tau(1:n), [n])
      if (nd == 2) then
        call rec%real(path, 'state', reshape(x%x(:, 1:n), [2*nd*n]), [n, 2*nd], 'cm, cm, cm/s, cm/s')
      else
        call rec%real(path, 'state', reshape(x%x(:, 1:n), [2*nd*n]), [n, 2*nd])
      end if
      if (nd > 2) then   ! the plane's pairs (q_j, p_j), j != index: the cut is a closed curve in them
        allocate (sc(2*(nd - 1), n))
        axes = ''
        l = 0
        do j = 1, nd
          if (j == sec%index) cycle
          do i = 1, n
            sc(l + 1, i) = x%x(j, i)
            sc(l + 2, i) = x%x(nd + j, i)
          end do
          l = l + 2
          if (len(axes) > 0) axes = axes // ' '
          axes = axes // 'q' // itoa(j) // ' p' // itoa(j)
        end do
        call rec%real(path, 'section', reshape(sc, [2*(nd - 1)*n]), [n, 2*(nd - 1)])
        call rec%attr_string(path, 'axes', axes)
        call rec%attr_int(path, 'section_index', sec%index)
        call rec%attr_real(path, 'section_value', sec%level)
        call rec%attr_int(path, 'section_direction', sec%dir)
      end if
      if (x%nhist > 0) then
        call rec%int(path, 'history_n', x%hist_n(1:x%nhist), [x%nhist])
        call rec%real(path, 'history_area', x%hist_area(1:x%nhist), [x%nhist])
      end if
      call rec%attr_real(path, 'dE', de)
      call rec%attr_string(path, 'kind', trim(merge('stable  ', 'unstable', kind < 0)))
      call rec%attr_real(path, 'area', x%area)
      call rec%attr_real(path, 'area_polygon', x%area_polygon)
      call rec%attr_real(path, 'action', action)
      call rec%attr_real(path, 'period', period)
      call rec%attr_real(path, 'eps', eps)
      call rec%attr_int(path, 'converged', merge(1, 0, stat >= 0))
      if (nd > 2) then   ! (2 DOF: the Lyapunov family alone, the paper's cuts as they were)
        call rec%attr_int(path, 'family', st%family)
        if (allocated(x%floquet)) then
          call rec%real(path, 'floquet_vector', x%floquet, [2*nd])
        else
          call rec%real(path, 'floquet_vector', [(0.0_wp, i=1, 2*nd)], [2*nd])
        end if
        call rec%attr_real(path, 'sigma', x%sigma)
      end if
    end if
    area = x%area
    if (stat < 0) area = ieee_value(1.0_wp, ieee_quiet_nan)
  end subroutine cut_to

  !> The damped model's transition regions at the energies des, into /tubes/region_<k>.
  subroutine regions(st, sec, des, o, dissip, stores, rec)
    type(study_t), intent(in) :: st
    type(section_choice_t), intent(in) :: sec
    real(wp), intent(in) :: des(:)
    type(transition_opts_t), intent(in) :: o
    character(*), intent(in) :: dissip
    type(seed_stores_t), pointer, intent(in) :: stores
    type(record_t), intent(inout) :: rec
    type(study_t) :: rst
    type(region_t) :: reg
    type(region_info_t) :: info
    type(region_opts_t) :: ro
    type(dissipation_t) :: d
    real(wp) :: de, t0, res(12), area, ae
    real(wp), allocatable :: phi(:), rho(:), s(:), p(:), t_in(:), cs(:), cp(:)
    integer :: k, stat, counts(8), n, m, empty
    character(:), allocatable :: g, line
    allocate (phi(REGION_NOUT), rho(REGION_NOUT), s(REGION_NOUT), p(REGION_NOUT), t_in(REGION_NOUT), &
              cs(REGION_CURVE), cp(REGION_CURVE))
    rst = study_t(system=st%system, params=st%params, lo=st%lo, hi=st%hi, n_grid=st%n_grid, saddle=st%saddle, &
                  integ=st%integ)
    d = scene_dissipation(trim(st%system), st%params)
    call rec%out('tubes: the dissipative model (' // dissip // "): its transition regions, the section points that " // &
                 "pass the saddle's gate (the cut of the damped saddle's stable manifold; area_tol " // &
                 num(o%area_tol) // ')')
    call rec%out('  ' // rs('dE', 10) // ' ' // rs('area', 16) // ' ' // rs('p_trans', 12) // ' ' // rs('rays', 6) // &
                 ' ' // rs('scan', 10) // ' ' // rs('s', 8))
    do k = 1, size(des)
      de = des(k)
      t0 = wall()
      call progress_line('tubes: the damped region at dE = ' // num(de) // ' (' // itoa(k) // ' of ' // &
                         itoa(size(des)) // ')...', .true.)
      ro = region_opts_t(area_tol=o%area_tol, t_max=o%mc_t_max, local=.false.)
      ro%n_max = min(ro%n_max, REGION_NOUT)
      call region_at(rst, sec, de, o%gate, ro, reg, info, stat, stores, .false.)
      call region_numbers(reg, info, res, counts)
      n = 0
      m = 0
      if (stat < 0) then
        call rec%verdict(EXIT_PARTIAL, region_text(st, o, de, stat, counts))
        call rec%out('  ' // num(de, '10.4g') // '   failed (status ' // itoa(stat) // ')')
        cycle
      end if
      call region_outputs(reg, n, phi, rho, s, p, t_in, m, cs, cp)
      empty = counts(7)
      area = res(1)
      if (empty /= 0) area = 0
      ae = res(8)
      if (empty /= 0) then
        line = '  ' // num(de, '10.4g') // ' ' // num(0.0_wp, '16.12g') // ' ' // num(0.0_wp, '12.6g') // ' ' // &
               rs('-', 6) // ' ' // rs(itoa(counts(2)), 4) // '/' // ls5(itoa(counts(1))) // ' ' // &
               num(wall() - t0, '8.2f') // '   no point transits (none at dE <= ' // num(res(9), '.8g') // ')'
      else
        line = '  ' // num(de, '10.4g') // ' ' // num(area, '16.12g') // ' ' // num(area/ae, '12.6g') // ' ' // &
               rs(itoa(n), 6) // ' ' // rs(itoa(counts(2)), 4) // '/' // ls5(itoa(counts(1))) // ' ' // &
               num(wall() - t0, '8.2f')
      end if
      call rec%out(line)
      g = 'tubes/region_' // zeros3(k - 1)
      if (n > 0) then
        call rec%real(g, 'r', s(1:n), [n])
        call rec%real(g, 'p_r', p(1:n), [n])
        call rec%real(g, 'phi', phi(1:n), [n])
        call rec%real(g, 'rho', rho(1:n), [n])
        call rec%real(g, 't_in', t_in(1:n), [n])
        call rec%real(g, 'curve_r', cs(1:m), [m])
        call rec%real(g, 'curve_p_r', cp(1:m), [m])
      end if
      call rec%attr_real(g, 'dE', de)
      call rec%attr_real(g, 'area', area)
      call rec%attr_real(g, 'area_polygon', res(2))
      call rec%attr_real(g, 'A_E', ae)
      call rec%attr_real(g, 'p_trans', area/ae)
      call rec%attr_int(g, 'empty', empty)
      call rec%attr_real(g, 'dE_threshold_lo', res(9))
      call rec%attr_real(g, 'dE_threshold_hi', res(10))
      call rec%real(g, 'centre', res(3:4), [2])
      call rec%real(g, 'scale', res(5:6), [2])
      call rec%attr_int(g, 'n_scan', counts(1))
      call rec%attr_int(g, 'n_scan_transit', counts(2))
      call rec%attr_int(g, 'n_inconsistent', counts(4))
      call dissipation_attrs(d, g, rec)
    end do
  contains
    pure function ls5(t) result(u)
      character(*), intent(in) :: t
      character(:), allocatable :: u
      u = t // repeat(' ', max(0, 5 - len(t)))
    end function ls5
  end subroutine regions
end module tubes_scene_tubes
