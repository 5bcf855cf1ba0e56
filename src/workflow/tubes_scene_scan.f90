!> The scan scene (docs/scan.md, docs/output.md /scan) as one procedure of the core: continuation
!> in a model parameter (tubes_scan scan_table), its console table, its folds, with p_trans the
!> transition fraction per step and dE, and its verdicts. It returns a result record (tubes_record)
!> that the program's driver writes (src/io/tubes_record_write.c) and Python reads (tubes.scan).
module tubes_scene_scan
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan, ieee_is_nan
  use tubes_kinds, only: wp
  use tubes_status, only: TUBES_EINPUT, status_message
  use tubes_cstrings, only: num
  use tubes_scene_text, only: itoa, rs, wall, progress_line
  use tubes_record, only: record_t, EXIT_BADINPUT, EXIT_NUMERIC, EXIT_PARTIAL
  use tubes_models, only: MAX_DOF, system_info_t, system_info
  use tubes_orbits, only: orbit_opts_t
  use tubes_manifold, only: tube_opts_t
  use tubes_study, only: study_t, section_choice_t
  use tubes_config, only: tubes_config_t
  use tubes_settings, only: settings_study, settings_section, settings_integ, settings_n_segments
  use tubes_scan, only: scan_table, scan_start, SCAN_MAXEQ, SCAN_MAXFOLD, SCAN_FOLD_TOL, SCAN_CONSTANT
  implicit none
  private

  public :: scene_scan

contains

  !> The scan on the run's settings cfg (&orbits' corrector, &section, &tubes and &transition area_tol
  !> for p_trans, &integrator with the method the run chose) at the saddle the run chose: parameter
  !> ipar (tubes_scan scan_index's; named parameter) to `to` in n steps, family 1's orbits at des, with
  !> p_on p_trans on the section; dissip the dissipation in words ('' conservative), input the input's
  !> name in messages.
  subroutine scene_scan(cfg, saddle, method, ipar, parameter, to, n, des, p_on, dissip, input, rec)
    type(tubes_config_t), intent(in) :: cfg
    character(*), intent(in) :: saddle, parameter, dissip, input
    integer, intent(in) :: method, ipar, n
    real(wp), intent(in) :: to, des(:)
    logical, intent(in) :: p_on
    type(record_t), intent(inout) :: rec
    type(study_t) :: st
    st = settings_study(cfg, saddle, method)
    st%family = 1
    call scan_scene_body(st, ipar, parameter, to, n, des, &
                         orbit_opts_t(n_segments=settings_n_segments(cfg), tol=cfg%orb_tol, rtol=cfg%orb_rtol, &
                                      atol=cfg%orb_atol, max_iter=cfg%orb_max_iter, n_samples=cfg%orb_n_samples, &
                                      integ=settings_integ(cfg, method)), p_on, settings_section(cfg), &
                         tube_opts_t(kind=-1, eps=cfg%tub_eps, area_tol=cfg%tra_area_tol, t_max=cfg%tub_t_max, &
                                     n_init=cfg%tub_n_init, n_max=cfg%tub_n_max, local=.true.), cfg%ndof, dissip, input, rec)
  end subroutine scene_scan

  !> The scan of parameter ipar (tubes_scan scan_index's; named parameter as the input names it)
  !> of the study st (st%saddle the run's saddle) from its value to `to` in n steps, with the
  !> Lyapunov orbits at des (opts) and, with p_on, p_trans at each step on the section sec with
  !> the stable tube's options topts. nd: the model's degrees of freedom; dissip: the dissipation
  !> in words ('' for a conservative model); input: the input's name for messages. rec: the
  !> scene's record.
  subroutine scan_scene_body(st, ipar, parameter, to, n, des, opts, p_on, sec, topts, nd, dissip, input, rec)
    type(study_t), intent(in) :: st
    integer, intent(in) :: ipar, n, nd
    character(*), intent(in) :: parameter, dissip, input
    real(wp), intent(in) :: to, des(:)
    type(orbit_opts_t), intent(in) :: opts
    logical, intent(in) :: p_on
    type(section_choice_t), intent(in) :: sec
    type(tube_opts_t), intent(in) :: topts
    type(record_t), intent(inout) :: rec
    real(wp), allocatable :: value(:), eq_q(:, :, :), eq_en(:, :), sq(:, :), sen(:), lam(:), om(:, :), per(:, :), &
                             act(:, :), stab(:, :), pat(:, :), pae(:, :), ptr(:, :)
    integer, allocatable :: neq(:), res(:), eq_ix(:, :), eq_nm(:, :, :), eq_det(:, :), sfound(:), conv(:, :), &
                            rest(:, :), pst(:, :), rows(:)
    character(9*SCAN_MAXEQ) , allocatable :: names(:)
    character(8), allocatable :: fn(:), fp(:)
    real(wp) :: fval(SCAN_MAXFOLD), fwid(SCAN_MAXFOLD), fq(MAX_DOF, SCAN_MAXFOLD), start, t0, nan
    integer :: fstep(SCAN_MAXFOLD), fkind(SCAN_MAXFOLD), fname(8, SCAN_MAXFOLD), fpart(8, SCAN_MAXFOLD)
    integer :: m, nde, nd1, nf, nfr, s, i, j, k, d, nlost
    character(:), allocatable :: pu, line, a, b
    logical :: pon
    nan = ieee_value(1.0_wp, ieee_quiet_nan)
    m = n + 1
    nde = size(des)
    nd1 = max(nde, 1)
    pon = p_on .and. nde > 0
    if (pon .and. len(dissip) > 0) then   ! the scan's model is the conservative one (scan_table)
      call rec%verdict(EXIT_BADINPUT, input // ": &scan p_trans: the scan follows the conservative model, and the " // &
                       "dissipative model's (" // dissip // ") p_trans is its transition region's: run the " // &
                       'transition scene at the values of interest')
      return
    end if
    allocate (value(m), eq_q(MAX_DOF, SCAN_MAXEQ, m), eq_en(SCAN_MAXEQ, m), sq(MAX_DOF, m), sen(m), lam(m), &
              om(MAX_DOF - 1, m), per(nd1, m), act(nd1, m), stab(nd1, m), neq(m), res(m), eq_ix(SCAN_MAXEQ, m), &
              eq_nm(8, SCAN_MAXEQ, m), eq_det(SCAN_MAXEQ, m), sfound(m), conv(nd1, m), rest(nd1, m), &
              pat(nd1, m), pae(nd1, m), ptr(nd1, m), pst(nd1, m))
    per = 0; act = 0; stab = 0; conv = 0; rest = 0
    t0 = wall()
    call scan_start(st, ipar, start, s)   ! the reader resolved ipar: it has one
    pu = param_units(st%system, ipar)
    line = 'scan: ' // parameter // ' from ' // num(start, '.10g') // ' to ' // num(to, '.10g') // ' in ' // &
           itoa(n) // ' steps (saddle ' // trim(st%saddle) // ', ' // itoa(nde) // ' orbit' // &
           trim(merge('  ', 's ', nde == 1))
    if (pon) line = line // ', p_trans: a tube cut per step and dE'
    call progress_line(line // ')...', .false.)
    nf = 0
    if (pon) then
      call scan_table(st, ipar, to, n, des, opts, value, neq, res, eq_q, eq_en, eq_ix, eq_nm, eq_det, sfound, sq, &
                      sen, lam, om, per(1:nde, :), act(1:nde, :), stab(1:nde, :), conv(1:nde, :), rest(1:nde, :), &
                      nf, fstep, fval, fwid, fkind, fq, fname, fpart, s, sec, topts, pat(1:nde, :), pae(1:nde, :), &
                      ptr(1:nde, :), pst(1:nde, :))
    else
      call scan_table(st, ipar, to, n, des, opts, value, neq, res, eq_q, eq_en, eq_ix, eq_nm, eq_det, sfound, sq, &
                      sen, lam, om, per(1:nde, :), act(1:nde, :), stab(1:nde, :), conv(1:nde, :), rest(1:nde, :), &
                      nf, fstep, fval, fwid, fkind, fq, fname, fpart, s)
    end if
    if (s < 0) then
      line = 'tubes: scan: failed: ' // status_message(s) // ' (status ' // itoa(s) // ')'
      if (s == TUBES_EINPUT .and. ipar > SCAN_CONSTANT) then
        line = line // ": the formula's library with a value of the constant between the start and `to` was not " // &
               'built (the model line of this input with that value says why), or more than 64 equilibria lie ' // &
               'in the box'
      else if (s == TUBES_EINPUT) then
        line = line // ': the model refuses a value of the parameter between the start and `to` (docs/models.md ' // &
               'gives its range), or more than 64 equilibria lie in the box'
      end if
      call rec%verdict(EXIT_NUMERIC, line)
      return
    end if
    ! the table: one row per step
    line = 'scan: ' // parameter // ' from ' // num(start, '.10g') // ' to ' // num(to, '.10g')
    if (pu /= '1') line = line // ' ' // pu
    call rec%out(line // ' in ' // itoa(n) // ' steps, saddle ' // trim(st%saddle) // ' (' // &
                 num(wall() - t0, '.2f') // ' s)')
    line = '  ' // rs(parameter, 14) // ' ' // rs('n_eq', 4) // ' ' // rs('E_saddle', 18) // ' ' // &
           rs('lambda', 14) // ' ' // rs('omega', 14)
    do i = 1, nde
      line = line // '  ' // rs('T(dE=' // num(des(i), '.4g') // ')', 15)
    end do
    do i = 1, merge(nde, 0, pon)
      line = line // '  ' // rs('p(dE=' // num(des(i), '.4g') // ')', 15)
    end do
    call rec%out(line)
    nlost = 0
    do j = 1, m
      line = '  ' // num(value(j), '14.8g') // ' ' // rs(itoa(neq(j)), 4) // merge('*', ' ', res(j) /= 0)
      if (sfound(j) /= 0) then
        line = line // num(sen(j), '17.10g') // ' ' // num(lam(j), '14.8g') // ' ' // &
               num(merge(om(1, j), nan, nd > 1), '14.8g')
      else
        line = line // rs('(no saddle)', 17) // ' ' // rs('-', 14) // ' ' // rs('-', 14)
      end if
      do i = 1, nde
        if (conv(i, j) /= 0) then
          line = line // '  ' // num(per(i, j), '15.10g')
        else
          line = line // '  ' // rs('-', 15)
        end if
        if (sfound(j) /= 0 .and. conv(i, j) == 0) nlost = nlost + 1   ! past a fold that took the saddle
      end do
      do i = 1, merge(nde, 0, pon)
        if (.not. ieee_is_nan(ptr(i, j))) then
          line = line // '  ' // num(ptr(i, j), '15.10g')
        else
          line = line // '  ' // rs('-', 15)
        end if
        if (sfound(j) /= 0 .and. pst(i, j) < 0) nlost = nlost + 1
      end do
      call rec%out(line)
    end do
    do j = 1, merge(m, 0, pon)
      do i = 1, nde
        if (sfound(j) /= 0 .and. pst(i, j) < 0) &
          call rec%err('tubes: scan: p_trans at ' // parameter // ' = ' // num(value(j), '.10g') // ', dE = ' // &
                       num(des(i)) // ' failed: ' // status_message(pst(i, j)) // ' (status ' // itoa(pst(i, j)) // &
                       '; the transition scene at that value says more)')
      end do
    end do
    if (nf == 0) call rec%out('  no fold between ' // num(start, '.10g') // ' and ' // num(to, '.10g') // &
                              ' (equilibria continued by Newton; * a new search)')
    nfr = min(nf, SCAN_MAXFOLD)
    allocate (fn(nfr), fp(nfr), rows(nfr))
    do k = 1, nfr
      fn(k) = name_of(fname(:, k))
      fp(k) = name_of(fpart(:, k))
      a = trim(fn(k))
      b = trim(fp(k))
      if (len(b) == 0) b = '(none)'
      if (fkind(k) == 3) then
        line = '  ' // parameter // ' = ' // num(fval(k), '.15g') // ' (+- ' // num(0.5_wp*fwid(k), '.1e') // &
               '): ' // a // ' leaves the search box at q = ('
      else
        line = '  fold: ' // parameter // ' = ' // num(fval(k), '.15g') // ' (+- ' // num(0.5_wp*fwid(k), '.1e') // &
               '): ' // a // ' ' // trim(merge('meets                 ', 'changes its index near', fkind(k) == 1)) // &
               ' ' // b // ' at q = ('
      end if
      do d = 1, nd
        if (d > 1) line = line // ', '
        line = line // num(fq(d, k), '.8g')
      end do
      call rec%out(line // ')')
      rows(k) = fstep(k) - 1     ! 0-based: the first row after the fold
    end do
    if (nf > SCAN_MAXFOLD) call rec%out('  ' // itoa(nf) // ' folds found, the first ' // itoa(SCAN_MAXFOLD) // &
                                        ' recorded')
    ! /scan
    call rec%real('scan', 'value', value, [m], pu)
    call rec%int('scan', 'n_equilibria', neq, [m])
    call rec%int('scan', 'researched', res, [m])
    call rec%real('scan', 'eq_q', reshape(eq_q, [size(eq_q)]), [m, SCAN_MAXEQ, MAX_DOF])
    call rec%real('scan', 'eq_energy', reshape(eq_en, [size(eq_en)]), [m, SCAN_MAXEQ])
    call rec%int('scan', 'eq_index', reshape(eq_ix, [size(eq_ix)]), [m, SCAN_MAXEQ])
    call rec%int('scan', 'eq_det', reshape(eq_det, [size(eq_det)]), [m, SCAN_MAXEQ])
    call rec%int('scan', 'saddle_found', sfound, [m])
    call rec%real('scan', 'saddle_q', reshape(sq, [size(sq)]), [m, MAX_DOF])
    call rec%real('scan', 'saddle_energy', sen, [m])
    call rec%real('scan', 'lambda', lam, [m])
    call rec%real('scan', 'omega', reshape(om, [size(om)]), [m, MAX_DOF - 1])
    allocate (names(m))
    do j = 1, m                  ! the names, "W1 S12 ..." per step
      names(j) = ''
      do k = 1, neq(j)
        if (k == 1) then
          names(j) = name_of(eq_nm(:, k, j))
        else
          names(j) = trim(names(j)) // ' ' // name_of(eq_nm(:, k, j))
        end if
      end do
    end do
    call rec%strings('scan', 'eq_names', names)
    if (nde > 0) then
      call rec%real('scan', 'dE', des, [nde])
      call rec%real('scan', 'period', reshape(per(1:nde, :), [nde*m]), [m, nde])
      call rec%real('scan', 'action', reshape(act(1:nde, :), [nde*m]), [m, nde])
      call rec%real('scan', 'stability_index', reshape(stab(1:nde, :), [nde*m]), [m, nde])
      call rec%int('scan', 'converged', reshape(conv(1:nde, :), [nde*m]), [m, nde])
      call rec%int('scan', 'restarted', reshape(rest(1:nde, :), [nde*m]), [m, nde])
      if (pon) then              ! p_trans along the scan (docs/output.md)
        call rec%real('scan', 'p_trans', reshape(ptr(1:nde, :), [nde*m]), [m, nde])
        call rec%real('scan', 'A_tube', reshape(pat(1:nde, :), [nde*m]), [m, nde])
        call rec%real('scan', 'A_E', reshape(pae(1:nde, :), [nde*m]), [m, nde])
        call rec%int('scan', 'p_trans_status', reshape(pst(1:nde, :), [nde*m]), [m, nde])
      end if
    end if
    call rec%real('scan/folds', 'value', fval(1:nfr), [nfr], pu)
    call rec%real('scan/folds', 'bracket', fwid(1:nfr), [nfr], pu)
    call rec%int('scan/folds', 'kind', fkind(1:nfr), [nfr])
    call rec%int('scan/folds', 'step', rows, [nfr])
    call rec%real('scan/folds', 'q', reshape(fq(:, 1:nfr), [MAX_DOF*nfr]), [nfr, MAX_DOF])
    if (nfr > 0) then
      call rec%strings('scan/folds', 'name', fn)
      call rec%strings('scan/folds', 'partner', fp)
    end if
    call rec%attr_int('scan/folds', 'n_found', nf)
    call rec%attr_real('scan/folds', 'tol', SCAN_FOLD_TOL)
    call rec%attr_string('scan', 'parameter', parameter)
    call rec%attr_real('scan', 'start', start)
    call rec%attr_real('scan', 'to', to)
    call rec%attr_int('scan', 'n', n)
    call rec%attr_string('scan', 'saddle', trim(st%saddle))
    call rec%attr_string('scan', 'parameter_units', pu)
    if (nlost > 0) rec%code = max(rec%code, EXIT_PARTIAL)
  end subroutine scan_scene_body

  !> The units of parameter ipar of system from the library's table ('1' if none: a formula's
  !> constant, or no such parameter).
  function param_units(system, ipar) result(u)
    character(*), intent(in) :: system
    integer, intent(in) :: ipar
    character(:), allocatable :: u
    type(system_info_t) :: info
    integer :: ist
    u = '1'
    call system_info(trim(system), info, ist)
    if (ist /= 0 .or. ipar < 1 .or. ipar > info%np) return
    u = trim(info%params(ipar)%units)
  end function param_units

  !> A name from its 8 ASCII codes (blank-padded).
  pure function name_of(codes) result(s)
    integer, intent(in) :: codes(8)
    character(8) :: s
    integer :: k
    do k = 1, 8
      s(k:k) = achar(codes(k))
    end do
  end function name_of
end module tubes_scene_scan
