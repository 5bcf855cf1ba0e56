!> The orbits scene (docs/orbits.md, docs/output.md /orbits) as one procedure of the core: the
!> saddle's family at the requested excess energies (or at those of &orbits jacobi or periods,
!> tubes_orbit_parameter), its table, why energies have no orbit (the family's end and stopping
!> rules, a guess that did not converge, a family by name the saddle's modes do not define), the
!> integration's own accuracy (tubes_verdicts orbit_coarse), the Floquet indices and the
!> bifurcations between the orbits. It returns a result record (tubes_record) that the program's
!> driver writes (src/io/tubes_record_write.c) and Python's orbit_family reads: the scene's rules
!> and messages are here once. The lines that announce its long steps stay live on stderr
!> (progress_line), the record holds the results.
module tubes_scene_orbits
  use, intrinsic :: iso_c_binding, only: c_char, c_int
  use tubes_kinds, only: wp
  use tubes_status, only: TUBES_OK, TUBES_EINPUT, status_message
  use tubes_cstrings, only: num
  use tubes_record, only: record_t, EXIT_BADINPUT, EXIT_NUMERIC, EXIT_PARTIAL
  use tubes_hamiltonian, only: hamiltonian_t, jacobi_of_energy
  use tubes_equilibria, only: equilibrium_t
  use tubes_models, only: MAX_DOF, make_model
  use tubes_orbits, only: orbit_t, orbit_opts_t, END_NONE, END_PERIOD, END_NOBRANCH, END_NOGUESS, END_NOTBRANCH, &
                          END_NOMODE, FAMILY_BRANCH_PLUS, FAMILY_BRANCH_MINUS, FAMILY_VERTICAL, FAMILY_PLANAR, &
                          FAMILY_AXIAL
  use tubes_study, only: study_t, seed_stores_t, study_family, family_table, bifurcation_table, BIF_TOL
  use tubes_orbit_parameter, only: family_parameter_des, PARAM_JACOBI, PARAM_PERIOD, PARAM_NOT_REACHED, &
                                   PARAM_NOCONV, PARAM_NOJACOBI
  use tubes_verdicts, only: orbit_coarse
  use tubes_scene_text, only: wall, ls, rs, progress_line
  use tubes_config, only: tubes_config_t
  use tubes_settings, only: settings_study, settings_orbit_opts, settings_text
  implicit none
  private

  public :: scene_orbits

  integer, parameter :: MAXBIF = 64       !! bifurcations kept (more: the first MAXBIF, exit 4)
  integer, parameter :: MD2 = 2*MAX_DOF   !! state rows of the tables
  integer, parameter :: FAM_BRANCH = -100   !! &orbits family = 'branch:K': FAM_BRANCH - K

contains

  !> The scene for the study st (model, box, saddle, integrator) and the orbit options opts (as the
  !> C API builds them: a guess and 'branch:K' in opts%guess and opts%branch); family: &orbits
  !> family as given (its code, for the names); pkind: 0 values are the dE, PARAM_JACOBI Jacobi
  !> constants, PARAM_PERIOD periods; sysname: the system as the input names it; dimensioned: the
  !> model's units are the ball's (cm, s); dissipative: the run's model dissipates (the orbits are
  !> the conservative model's); stores: the run's kept results (or null). rec: the scene's record.
  !> The scene on the run's settings cfg (&orbits: de, or jacobi, or periods; the family, a guess),
  !> the saddle and the method the run chose; dimensioned: the ball's units; dissipative: the run's
  !> model dissipates (its orbits are the conservative model's).
  subroutine scene_orbits(cfg, saddle, method, dimensioned, dissipative, stores, rec)
    type(tubes_config_t), intent(in) :: cfg
    character(*), intent(in) :: saddle
    integer, intent(in) :: method
    logical, intent(in) :: dimensioned, dissipative
    type(seed_stores_t), pointer, intent(in) :: stores
    type(record_t), intent(inout) :: rec
    if (cfg%orb_njacobi > 0) then
      call orbits_scene_body(settings_study(cfg, saddle, method), settings_orbit_opts(cfg, method), cfg%orb_family, &
                             PARAM_JACOBI, cfg%orb_jacobi(1:cfg%orb_njacobi), settings_text(cfg%system), dimensioned, &
                             dissipative, stores, rec)
    else if (cfg%orb_nperiods > 0) then
      call orbits_scene_body(settings_study(cfg, saddle, method), settings_orbit_opts(cfg, method), cfg%orb_family, &
                             PARAM_PERIOD, cfg%orb_periods(1:cfg%orb_nperiods), settings_text(cfg%system), dimensioned, &
                             dissipative, stores, rec)
    else
      call orbits_scene_body(settings_study(cfg, saddle, method), settings_orbit_opts(cfg, method), cfg%orb_family, &
                             0, cfg%orb_de(1:cfg%orb_nde), settings_text(cfg%system), dimensioned, dissipative, stores, &
                             rec)
    end if
  end subroutine scene_orbits

  subroutine orbits_scene_body(st, opts, family, pkind, values, sysname, dimensioned, dissipative, stores, rec)
    type(study_t), intent(in) :: st
    type(orbit_opts_t), intent(in) :: opts
    integer, intent(in) :: family, pkind
    real(wp), intent(in) :: values(:)
    character(*), intent(in) :: sysname
    logical, intent(in) :: dimensioned, dissipative
    type(seed_stores_t), pointer, intent(in) :: stores
    type(record_t), intent(inout) :: rec
    class(hamiltonian_t), allocatable :: model
    type(equilibrium_t), allocatable :: eqs(:)
    type(orbit_t), allocatable :: orbs(:)
    real(wp), allocatable :: des(:), e(:), per(:), act(:), s0(:, :), mu(:), ms(:), mt(:, :), stab(:), res(:), &
                             clo(:), md(:), mono(:, :), ts(:, :), xs(:, :, :), hist(:, :), jac(:), nu(:, :), &
                             monot(:, :, :)
    integer, allocatable :: it(:), conv(:)
    real(wp) :: end_de, t0, tb, scale, bde(MAXBIF), bwid(MAXBIF), ben(MAXBIF), bper(MAXBIF), &
                bnu(2*MAX_DOF - 2, MAXBIF), bx0(MD2, MAXBIF), btan(MD2, MAXBIF)
    integer :: n, ns, mi, nseg, stat, isad, reason, k, j, i, nfail, nbif, np, n2, nd, code, nguess, &
               bkind(MAXBIF), bafter(MAXBIF), bconv(MAXBIF)
    logical :: guessed, has_jacobi
    character(:), allocatable :: famname, line, units_e, kinds
    character(1024) :: m
    character(*), parameter :: BIF_NAME(0:4) = [character(15) :: '', 'branch_point', 'period_doubling', &
                                                'krein_collision', 'fold']
    ! the orbits asked for by Jacobi constant or period: their dE, the scene's as with de
    if (pkind == PARAM_JACOBI .or. pkind == PARAM_PERIOD) then
      call parameter_des(st, opts, pkind, values, sysname, stores, des, rec)
      if (rec%code /= 0) return
    else
      des = values
    end if
    n = size(des)
    ns = opts%n_samples
    mi = opts%max_iter
    nseg = opts%n_segments
    nguess = 0
    if (allocated(opts%guess)) nguess = size(opts%guess)
    units_e = trim(merge(' (cm/s)^2', '         ', dimensioned))
    ! the Jacobi constant of each orbit, for a model that defines one (the CR3BP)
    call make_model(trim(st%system), st%params, model, stat)
    has_jacobi = stat == TUBES_OK
    if (has_jacobi) has_jacobi = model%jacobi_factor() /= 0
    deallocate (model)
    allocate (e(n), per(n), act(n), s0(MD2, n), mu(n), ms(n), mt(4, n), stab(n), res(n), clo(n), md(n), &
              mono(MD2*MD2, n), ts(ns, n), xs(MD2, ns, n), hist(mi, n), it(n), conv(n), jac(n), orbs(n))
    e = 0; per = 0; act = 0; s0 = 0; mu = 0; ms = 0; mt = 0; stab = 0; res = 0; clo = 0; md = 0; mono = 0
    ts = 0; xs = 0; hist = 0; it = 0; conv = 0; jac = 0
    t0 = wall()
    call say('orbits: continuing the ' // trim(st%saddle) // ' family to dE = ' // num(des(n)) // ' (' // &
             trim(merge('multiple', 'single  ', nseg > 1)) // ' shooting)...')
    call study_family(st, des, opts, model, eqs, isad, orbs, end_de, reason, stat, stores)
    if (stat < 0) then
      call rec%verdict(EXIT_NUMERIC, 'tubes: orbits: failed: ' // status_message(stat) // ' (status ' // &
                       inum(stat) // ')')
      return
    end if
    call family_table(orbs, eqs(isad)%energy, des, model%dim(), e, per, act, s0, mu, ms, mt, stab, res, clo, it, &
                      conv, md, mono, ts, xs, hist)
    nd = model%ndof()
    n2 = 2*nd
    famname = 'Lyapunov'
    if (family == FAMILY_BRANCH_PLUS) famname = 'halo_north'
    if (family == FAMILY_BRANCH_MINUS) famname = 'halo_south'
    if (family == FAMILY_VERTICAL) famname = 'vertical'
    if (family == FAMILY_PLANAR) famname = 'lyapunov'
    if (family == FAMILY_AXIAL) famname = 'axial'
    ! a guess's family or a branch by the general arc ('branch:K', 'axial'): any dE
    guessed = nguess > 0 .or. family <= FAM_BRANCH - 1 .or. family == FAMILY_AXIAL
    if (family <= FAM_BRANCH - 1) then
      famname = 'branch:' // inum(FAM_BRANCH - family)
    else if (nguess > 0) then
      famname = 'guess'
    end if
    line = 'orbits: ' // trim(st%saddle) // ' ' // famname // ' family, ' // &
           trim(merge('multiple', 'single  ', nseg > 1)) // ' shooting'
    if (guessed) then
      line = line // ' (no symmetry assumed; continued in arclength)'
    else if (nseg == 1 .and. model%is_natural()) then
      line = line // ' (brake orbit)'
    else if (nseg == 1) then
      line = line // ' (symmetric orbit)'
    end if
    if (dissipative) line = line // ', of the conservative model (a dissipative model has no periodic orbits: ' // &
                            'they are the limit the damped model''s transition regions start from)'
    call rec%out(line // ' (' // num(wall() - t0, '.2f') // ' s)')
    if (has_jacobi) then                     ! C of E = E_e + dE
      do k = 1, n
        jac(k) = jacobi_of_energy(model, e(k))
      end do
    end if
    line = '          dE ' // trim(merge('  period [s]', '      period', dimensioned)) // &
           '         action    mu_unstable    residual   closure  iter'
    if (has_jacobi) line = line // '        C (Jacobi)'
    call rec%out(line)
    nfail = 0
    do k = 1, n
      if (conv(k) /= 0) then
        line = '  ' // num(des(k), '10.4g') // ' ' // num(per(k), '12.9f') // ' ' // num(act(k), '14.8g') // ' ' // &
               num(mu(k), '14.8g') // ' ' // num(res(k), '11.2e') // ' ' // num(clo(k), '9.1e') // ' ' // &
               inum(it(k), '5.0f')
        if (has_jacobi) line = line // ' ' // num(jac(k), '17.12f')
        call rec%out(line)
      else
        nfail = nfail + 1
        if (.not. guessed .and. end_de > 0 .and. des(k) >= end_de*(1 - 1e-6_wp)) then
          call rec%out('  ' // num(des(k), '10.4g') // '   refused: past the end of the family (dE ~ ' // &
                       num(end_de, '.6g') // ')')
        else if (orbs(k)%off_branch) then
          call rec%out('  ' // num(des(k), '10.4g') // '   off the branch (not returned)')
          call rec%err('tubes: orbits: dE = ' // num(des(k)) // ': no ' // famname // ' orbit: the corrector ' // &
                       'at this energy, started on the branch''s arc, converged off the branch (to ' // &
                       'the parent family''s orbit or the mirror branch''s, period ' // num(orbs(k)%period, '.10g') // &
                       '); not returned (docs/orbits.md, "Branch switching")')
        else if (guessed .and. it(k) == 0) then
          call rec%out('  ' // num(des(k), '10.4g') // '   not reached (the family stop below)')
        else
          call rec%out('  ' // num(des(k), '10.4g') // '   not converged')
        end if
      end if
    end do
    if (guessed) then
      ! a guess's family or a branch (docs/orbits.md, "Orbits from a guess"): the arc's stopping rule
      if (reason == END_NOGUESS) then
        line = 'tubes: orbits: &orbits guess = ('
        do i = 1, nguess
          if (i > 1) line = line // ', '
          line = line // num(opts%guess(i), '.10g')
        end do
        call rec%verdict(EXIT_BADINPUT, line // '), period = ' // num(opts%guess_period) // ': the guess did ' // &
                         'not converge to a periodic orbit (multiple shooting at the guess''s own energy, ' // &
                         inum(nseg) // ' segment' // trim(merge('s', ' ', nseg > 1)) // '); no orbit computed: ' // &
                         'give a state and period closer to a periodic orbit')
      else if (reason == END_NOBRANCH .and. family == FAMILY_AXIAL) then
        call rec%err('tubes: orbits: family = ''axial'': the ' // trim(st%saddle) // '''s planar Lyapunov ' // &
                     'family (''lyapunov'') has no branch point with a tangent odd under the reversor (the ' // &
                     'axial one) below dE = ' // num(des(n)) // '; not computed')
      else if (reason == END_NOBRANCH) then
        call rec%err('tubes: orbits: family = ''' // famname // ''': the parent family has no branch point ' // &
                     'or period doubling as its bifurcation ' // inum(FAM_BRANCH - family) // ' between the ' // &
                     'requested energies (/orbits/bifurcations of the run without it); not computed')
      end if
      line = '  family stop: ' // end_reason_text(reason)
      if (reason /= 0 .and. reason /= END_NOBRANCH .and. reason /= END_NOGUESS .and. reason /= END_NOMODE) &
        line = line // ' (at dE = ' // num(end_de, '.10g') // ')'
      call rec%out(line)
      do k = 1, n
        if (conv(k) /= 0 .or. orbs(k)%off_branch .or. reason == END_NOGUESS .or. reason == END_NOBRANCH .or. &
            reason == END_NOMODE) cycle
        if (reason == END_NOTBRANCH .or. reason == END_NONE) then
          call rec%err('tubes: orbits: dE = ' // num(des(k)) // ': no ' // famname // ' orbit: not on this ' // &
                       'side of the start (each energy is taken where the continuation first crosses it)')
        else
          call rec%err('tubes: orbits: dE = ' // num(des(k)) // ': no ' // famname // ' orbit: ' // &
                       end_reason_text(reason))
        end if
      end do
    else if (reason == END_NOMODE) then
      continue                               ! said below with the axial family's
    else if (family < 0 .and. reason == END_NOBRANCH) then
      call rec%out('  no ' // famname // ' family: ' // end_reason_text(reason) // ' (dE = ' // num(des(n)) // ')')
      call rec%err('tubes: orbits: no ' // famname // ' orbits: the ' // trim(st%saddle) // '''s family ' // &
                   inum(nd - 1) // ' (its planar Lyapunov family in the CR3BP) has no branch point below dE = ' // &
                   num(des(n)) // '; not computed')
    else if (family < 0 .and. nfail > 0 .and. end_de <= 0) then
      do k = 1, n
        if (conv(k) == 0 .and. .not. orbs(k)%off_branch) &
          call rec%err('tubes: orbits: dE = ' // num(des(k)) // ': no ' // famname // ' orbit: ' // &
                       'below the branch point (the branch starts at the energy of the planar ' // &
                       'family''s first branch point, /orbits/bifurcations of that family)')
      end do
    else if (end_de > 0) then
      call rec%out('  family end: dE ~ ' // num(end_de, '.8g') // units_e // ': ' // end_reason_text(reason))
      do k = 1, n
        if (conv(k) == 0 .and. .not. orbs(k)%off_branch) &
          call rec%err('tubes: orbits: ' // family_stop_text(st%saddle, des(k), end_de, reason, units_e) // &
                       '; not computed')
      end do
    else
      do k = 1, n
        if (conv(k) /= 0 .or. orbs(k)%off_branch) cycle
        line = 'tubes: orbits: dE = ' // num(des(k)) // ': the correction did not converge; residual history:'
        do j = 1, min(it(k), mi)
          line = line // ' ' // num(hist(j, k), '.2e')
        end do
        call rec%err(line)
      end do
    end if
    if (reason == END_NOMODE) then           ! 'vertical', 'lyapunov' or 'axial' where the modes do not define it
      call rec%verdict(EXIT_BADINPUT, 'tubes: orbits: family = ''' // famname // ''': no centre mode of the ' // &
                       trim(st%saddle) // ' of system ''' // sysname // ''' lies out of the plane (an ' // &
                       'eigenvector with all its weight on q' // inum(nd) // ', p' // inum(nd) // ') beside a ' // &
                       'planar one, so the ' // famname // ' family is not defined here (allowed: family = 1 .. ' // &
                       inum(max(nd - 1, 1)) // ' by number, docs/orbits.md "Branch switching")')
    end if
    ! the integration's own accuracy (tubes_verdicts orbit_coarse)
    do k = 1, n
      if (conv(k) == 0) cycle
      scale = maxval(abs(s0(1:n2, k)))
      code = orbit_coarse(des(k), clo(k), mu(k), scale, m)
      if (code /= 0) call rec%verdict(EXIT_NUMERIC, trim(m))
    end do
    ! bifurcation monitoring (docs/orbits.md, "Bifurcations"): the Floquet indices of each orbit and
    ! the bifurcations located between them, on the family the run's stores hold
    allocate (nu(2*MAX_DOF - 2, n))
    tb = wall()
    call bifurcation_table(st, des, opts, nu, nbif, bkind, bafter, bconv, bde, bwid, ben, bper, bnu, bx0, btan, &
                           stat, stores)
    if (stat < 0) then
      call rec%verdict(EXIT_NUMERIC, 'tubes: orbits: bifurcation monitoring failed: ' // status_message(stat) // &
                       ' (status ' // inum(stat) // ')')
      return
    end if
    if (nbif > MAXBIF) then
      call rec%err('tubes: orbits: ' // inum(nbif) // ' bifurcations between the requested energies; the first ' // &
                   inum(MAXBIF) // ' are kept: ask for fewer dE at a time')
      nbif = MAXBIF
      if (rec%code == 0) rec%code = EXIT_PARTIAL
    end if
    np = nd - 1
    if (family < 0 .and. family /= FAMILY_VERTICAL .and. family /= FAMILY_PLANAR) then
      call rec%out('  bifurcations: not located along a branch family (its orbits'' Floquet indices are written)')
    else if (nbif == 0) then
      call rec%out('  bifurcations: none between the requested energies (Floquet indices: ' // inum(np) // &
                   ' pair' // trim(merge('s', ' ', np > 1)) // ')')
    else
      call rec%out('  bifurcations (located by bisection to a bracket of ' // num(BIF_TOL, '.0e') // ' dE; ' // &
                   num(wall() - tb, '.2f') // ' s):')
      call rec%out('  ' // ls('kind', 16) // ' ' // rs('dE', 18) // ' ' // rs('bracket', 11) // ' ' // &
                   rs('energy', 18) // ' ' // rs('period', 14) // '  Floquet indices (nu)')
      do j = 1, nbif
        if (bconv(j) == 0) then
          call rec%out('  ' // ls(trim(BIF_NAME(bkind(j))), 16) // ' ' // num(bde(j), '18.12g') // ' ' // &
                       num(bwid(j), '11.2e') // '   the corrector failed inside the bracket')
          call rec%err('tubes: orbits: the ' // trim(BIF_NAME(bkind(j))) // ' between dE = ' // &
                       num(des(bafter(j) + 1)) // ' and ' // num(des(bafter(j) + 2)) // ': the corrector ' // &
                       'failed inside the bisection''s bracket [' // num(bde(j), '.12g') // ' +- ' // &
                       num(bwid(j)/2, '.2g') // ']; not located further')
          if (rec%code == 0) rec%code = EXIT_PARTIAL
          cycle
        end if
        line = '  ' // ls(trim(BIF_NAME(bkind(j))), 16) // ' ' // num(bde(j), '18.12g') // ' ' // &
               num(bwid(j), '11.2e') // ' ' // num(ben(j), '18.12f') // ' ' // num(bper(j), '14.10f') // ' '
        do i = 1, np
          line = line // ' ' // num(bnu(i, j), '.10g')
          if (bnu(MAX_DOF - 1 + i, j) /= 0) line = line // signed(bnu(MAX_DOF - 1 + i, j)) // 'i'
        end do
        call rec%out(line)
      end do
    end if
    ! /orbits
    allocate (monot(n2, n2, n))
    do k = 1, n
      monot(:, :, k) = transpose(reshape(mono(1:n2*n2, k), [n2, n2]))   ! row i = component i (C order)
    end do
    call rec%real('orbits', 'dE', des, [n])
    call rec%real('orbits', 'energy', e, [n])
    if (has_jacobi) call rec%real('orbits', 'jacobi', jac, [n])
    if (pkind == PARAM_JACOBI) then
      call rec%attr_string('orbits', 'parameter', 'jacobi')
      call rec%real('orbits', 'requested_jacobi', values, [n])
    else if (pkind == PARAM_PERIOD) then
      call rec%attr_string('orbits', 'parameter', 'periods')
      call rec%real('orbits', 'requested_period', values, [n])
    end if
    call rec%real('orbits', 'period', per, [n])
    call rec%real('orbits', 'action', act, [n])
    call rec%real('orbits', 'mu_unstable', mu, [n])
    call rec%real('orbits', 'mu_stable', ms, [n])
    call rec%real('orbits', 'mu_trivial', reshape(mt([1, 3], :), [2*n]), [n, 2])
    call rec%real('orbits', 'mu_trivial_imag', reshape(mt([2, 4], :), [2*n]), [n, 2])
    call rec%real('orbits', 'stability_index', stab, [n])
    call rec%real('orbits', 'state0', reshape(s0(1:n2, :), [n*n2]), [n, n2], state_units(n2))
    call rec%int('orbits', 'converged', conv, [n])
    call rec%real('orbits', 'residual', res, [n])
    call rec%real('orbits', 'closure', clo, [n])
    call rec%int('orbits', 'iterations', it, [n])
    call rec%real('orbits', 'min_eq_distance', md, [n])
    call rec%real('orbits', 'monodromy', reshape(monot, [n*n2*n2]), [n, n2, n2])
    call rec%attr_string('orbits', 'saddle', trim(st%saddle))
    call rec%attr_string('orbits', 'method', trim(merge('multiple', 'single  ', nseg > 1)))
    call rec%attr_int('orbits', 'n_segments', nseg)
    call rec%attr_real('orbits', 'tol', opts%tol)
    call rec%attr_int('orbits', 'family', family)
    if (family == FAMILY_BRANCH_PLUS .or. family == FAMILY_BRANCH_MINUS .or. family == FAMILY_VERTICAL .or. guessed) then
      call rec%attr_string('orbits', 'family_name', famname)
    else
      call rec%attr_string('orbits', 'family_name', 'lyapunov')
    end if
    if (guessed) then
      call rec%attr_string('orbits', 'family_end_reason', end_reason_text(reason))
      if (reason /= 0 .and. reason /= END_NOBRANCH .and. reason /= END_NOGUESS) &
        call rec%attr_real('orbits', 'family_end_dE', end_de)
      if (nguess > 0) then
        call rec%real('orbits', 'guess', opts%guess, [nguess], 'state units')
        call rec%attr_real('orbits', 'guess_period', opts%guess_period)
      end if
    end if
    if (dissipative) call rec%attr_string('orbits', 'model', 'conservative')
    if (end_de > 0 .and. .not. guessed) then
      call rec%attr_real('orbits', 'family_end_dE', end_de)
      call rec%attr_string('orbits', 'family_end_reason', end_reason_text(reason))
    end if
    call rec%real('orbits', 'floquet_index', reshape(nu(1:np, :), [n*np]), [n, np])
    call rec%real('orbits', 'floquet_index_imag', reshape(nu(MAX_DOF:MAX_DOF + np - 1, :), [n*np]), [n, np])
    call rec%int('orbits/bifurcations', 'kind', bkind(1:nbif), [nbif])
    call rec%int('orbits/bifurcations', 'after', bafter(1:nbif), [nbif])
    call rec%int('orbits/bifurcations', 'converged', bconv(1:nbif), [nbif])
    call rec%real('orbits/bifurcations', 'dE', bde(1:nbif), [nbif])
    call rec%real('orbits/bifurcations', 'bracket', bwid(1:nbif), [nbif])
    call rec%real('orbits/bifurcations', 'energy', ben(1:nbif), [nbif])
    call rec%real('orbits/bifurcations', 'period', bper(1:nbif), [nbif])
    call rec%real('orbits/bifurcations', 'floquet_index', reshape(bnu(1:np, 1:nbif), [nbif*np]), [nbif, np])
    call rec%real('orbits/bifurcations', 'floquet_index_imag', &
                  reshape(bnu(MAX_DOF:MAX_DOF + np - 1, 1:nbif), [nbif*np]), [nbif, np])
    call rec%real('orbits/bifurcations', 'state0', reshape(bx0(1:n2, 1:nbif), [nbif*n2]), [nbif, n2], &
                  state_units(n2))
    call rec%real('orbits/bifurcations', 'tangent', reshape(btan(1:n2, 1:nbif), [nbif*n2]), [nbif, n2])
    kinds = '1 branch_point (an index crosses +1), 2 period_doubling (-1), 3 krein_collision (a pair of ' // &
            'indices turns complex or real)'
    if (guessed) kinds = kinds // ', 4 fold (the energy along a guess''s family turns back)'
    call rec%attr_string('orbits/bifurcations', 'kinds', kinds)
    call rec%attr_real('orbits/bifurcations', 'tol', BIF_TOL)
    do k = 1, n
      line = 'orbits/orbit_' // num(real(k - 1, wp), '03.0f')
      call rec%attr_real(line, 'dE', des(k))
      call rec%attr_int(line, 'converged', conv(k))
      if (min(it(k), mi) > 0) call rec%real(line, 'history', hist(1:min(it(k), mi), k), [min(it(k), mi)])
      if (conv(k) /= 0) then
        call rec%real(line, 't', ts(:, k), [ns])
        call rec%real(line, 'state', reshape(xs(1:n2, :, k), [ns*n2]), [ns, n2], state_units(n2))
      end if
    end do
    if (nfail > 0 .and. rec%code == 0) rec%code = EXIT_PARTIAL
  end subroutine orbits_scene_body

  !> The dE of the orbits asked for by &orbits jacobi (pkind PARAM_JACOBI) or periods (PARAM_PERIOD)
  !> (docs/orbits.md, "Orbits by Jacobi constant or period"; family_parameter_des), their lines, or
  !> the verdict: EXIT_BADINPUT for a value with no orbit of the family by its nature (C at or above
  !> the saddle's, dE not increasing along the list), EXIT_PARTIAL for a period the family does not
  !> reach or one the root finder could not locate, EXIT_NUMERIC when the family could not be set up.
  subroutine parameter_des(st, opts, pkind, values, sysname, stores, des, rec)
    type(study_t), intent(in) :: st
    type(orbit_opts_t), intent(in) :: opts
    integer, intent(in) :: pkind
    real(wp), intent(in) :: values(:)
    character(*), intent(in) :: sysname
    type(seed_stores_t), pointer, intent(in) :: stores
    real(wp), allocatable, intent(out) :: des(:)
    type(record_t), intent(inout) :: rec
    class(hamiltonian_t), allocatable :: model
    character(:), allocatable :: name, line
    integer :: found(size(values)), n, k, stat, n_again(size(values))
    real(wp) :: t_po, t_reach, de_reach, e_sad, c_sad, t0, de_again(size(values)), span(4)
    logical :: guessed, away
    n = size(values)
    name = trim(merge('jacobi ', 'periods', pkind == PARAM_JACOBI))
    allocate (des(n))
    t0 = wall()
    ! a family that starts away from the saddle (a guess's, a halo, the axial family): T(dE) probed
    ! along its own continuation (tubes_orbit_parameter period_de_away)
    away = allocated(opts%guess) .or. opts%family == FAMILY_BRANCH_PLUS .or. opts%family == FAMILY_BRANCH_MINUS .or. &
           opts%family == FAMILY_AXIAL
    if (pkind == PARAM_PERIOD) call say('orbits: locating the ' // trim(st%saddle) // ' family''s orbits of the ' // &
                                        inum(n) // ' period' // trim(merge('s', ' ', n > 1)) // ' (Brent on T(dE))...')
    call family_parameter_des(st, opts, pkind, values, des, found, t_po, t_reach, de_reach, e_sad, stat, stores, &
                              n_again, de_again, span)
    if (stat < 0 .and. pkind == PARAM_PERIOD .and. opts%branch > 0 .and. stat == TUBES_EINPUT) then
      call rec%verdict(EXIT_BADINPUT, 'tubes: orbits: &orbits periods: not for family = ''branch:' // &
                       inum(opts%branch) // ''': its K counts the parent family''s bifurcations between the ' // &
                       'requested energies, which periods do not give (ask for the branch by de or jacobi)')
      return
    end if
    if (stat < 0) then
      call rec%verdict(merge(EXIT_BADINPUT, EXIT_NUMERIC, stat == TUBES_EINPUT), 'tubes: orbits: &orbits ' // &
                       name // ': the family''s orbits could not be located: ' // status_message(stat) // &
                       ' (status ' // inum(stat) // ')')
      return
    end if
    guessed = allocated(opts%guess) .or. opts%branch > 0    ! a guess's family or a branch: any dE
    c_sad = 0                                               ! the saddle's Jacobi constant (the model's)
    if (pkind == PARAM_JACOBI) then
      call make_model(trim(st%system), st%params, model, stat)
      if (stat == TUBES_OK) then
        if (model%jacobi_factor() /= 0) c_sad = jacobi_of_energy(model, e_sad)
      end if
    end if
    do k = 1, n
      if (found(k) == PARAM_NOJACOBI) then
        call rec%verdict(EXIT_BADINPUT, 'tubes: orbits: &orbits jacobi: system ''' // sysname // ''' has no ' // &
                         'Jacobi constant (give de)')
      else if (found(k) == PARAM_NOT_REACHED .and. away .and. span(2) > 0) then
        call rec%verdict(EXIT_PARTIAL, 'tubes: orbits: &orbits periods(' // inum(k) // ') = ' // &
                         num(values(k), '.12g') // ': not reached: the ' // trim(st%saddle) // ' family''s ' // &
                         'orbits probed along its continuation, from dE = ' // num(span(1), '.10g') // ' to ' // &
                         num(span(2), '.10g') // ' (its ends closed in on), have periods from ' // &
                         num(span(3), '.12g') // ' to ' // num(span(4), '.12g') // ' without taking this value; ' // &
                         'no orbit computed')
      else if (found(k) == PARAM_NOT_REACHED .and. away) then
        call rec%verdict(EXIT_PARTIAL, 'tubes: orbits: &orbits periods(' // inum(k) // ') = ' // &
                         num(values(k), '.12g') // ': not reached: the family has no orbit where it was probed ' // &
                         '(a guess that did not converge, or no branch point: ask for it by de to see why); no ' // &
                         'orbit computed')
      else if (found(k) == PARAM_NOT_REACHED) then
        call rec%verdict(EXIT_PARTIAL, 'tubes: orbits: &orbits periods(' // inum(k) // ') = ' // &
                         num(values(k), '.12g') // ': not reached: the ' // trim(st%saddle) // ' family''s ' // &
                         'period runs from T_po = 2 pi/omega = ' // num(t_po, '.12g') // ' at the saddle to ' // &
                         num(t_reach, '.12g') // ' (at dE = ' // num(de_reach, '.10g') // ', where the search ' // &
                         'along the family ended) without taking this value; no orbit computed')
      else if (found(k) == PARAM_NOCONV) then
        call rec%verdict(EXIT_PARTIAL, 'tubes: orbits: &orbits periods(' // inum(k) // ') = ' // &
                         num(values(k), '.12g') // ': the root finder on T(dE) did not locate it to 1e-12 of ' // &
                         'the period (the orbits inside the bracket did not converge); no orbit computed')
      else if (.not. guessed .and. .not. des(k) > 0) then
        call rec%verdict(EXIT_BADINPUT, 'tubes: orbits: &orbits jacobi(' // inum(k) // ') = ' // &
                         num(values(k), '.12g') // ' is not below the saddle ' // trim(st%saddle) // '''s C = ' // &
                         num(c_sad, '.12g') // ': no orbit of its Lyapunov family there (allowed: C < ' // &
                         num(c_sad, '.12g') // ': the orbits'' dE = E(C) - E_e > 0)')
      else if (k > 1) then
        if (.not. des(k) > des(k - 1)) &
          call rec%verdict(EXIT_BADINPUT, 'tubes: orbits: &orbits ' // name // '(' // inum(k) // ') = ' // &
                           num(values(k), '.12g') // ': its orbit (dE = ' // num(des(k), '.12g') // ') lies ' // &
                           'below the previous one''s (dE = ' // num(des(k - 1), '.12g') // '): give the ' // &
                           name // ' in the order the family reaches them (dE increasing)')
      end if
      if (rec%code /= 0) return
    end do
    if (pkind == PARAM_PERIOD .and. away) then
      call rec%out('orbits: by period along the family''s own continuation: ' // inum(size(values)) // &
                   ' period' // trim(merge('s', ' ', n > 1)) // ' on T(dE) probed from dE = ' // num(span(1), '.10g') // &
                   ' to ' // num(span(2), '.10g') // ' (T from ' // num(span(3), '.12g') // ' to ' // &
                   num(span(4), '.12g') // '), each the crossing nearest the family''s start, Brent on T(dE) ' // &
                   'to |T - T*| <= 1e-12 T* (' // num(wall() - t0, '.2f') // ' s)')
      do k = 1, n
        line = '  period ' // num(values(k), '.12g') // ' -> dE = ' // num(des(k), '.15g')
        if (n_again(k) > 0) then
          line = line // ' (a fold in T(dE): ' // inum(n_again(k)) // ' more crossing' // &
                 trim(merge('s', ' ', n_again(k) > 1)) // ', the nearest near dE ~ ' // num(de_again(k), '.6g') // ')'
          call rec%err('tubes: orbits: &orbits periods(' // inum(k) // ') = ' // num(values(k), '.12g') // &
                       ': more than one orbit of the family has this period (T(dE) turns back along it: a fold ' // &
                       'in T): taken the one nearest the family''s start, dE = ' // num(des(k), '.12g') // &
                       '; ' // inum(n_again(k)) // ' more among the probes, the nearest near dE ~ ' // &
                       num(de_again(k), '.6g') // ' (ask for it by de)')
        end if
        call rec%out(line)
      end do
    else if (pkind == PARAM_PERIOD) then
      call rec%out('orbits: by period: T_po = 2 pi/omega = ' // num(t_po, '.12g') // ' at the saddle; the first ' // &
                   'crossing of each period from the saddle, Brent on T(dE) to |T - T*| <= 1e-12 T* (' // &
                   num(wall() - t0, '.2f') // ' s)')
      do k = 1, n
        call rec%out('  period ' // num(values(k), '.12g') // ' -> dE = ' // num(des(k), '.15g'))
      end do
    else
      call rec%out('orbits: by Jacobi constant (saddle ' // trim(st%saddle) // ': C = ' // num(c_sad, '.12g') // ')')
      do k = 1, n
        call rec%out('  C = ' // num(values(k), '.12g') // ' -> dE = ' // num(des(k), '.15g'))
      end do
    end if
  end subroutine parameter_des

  !> The family's stopping rule in words (tubes_orbits END_*; /orbits@family_end_reason).
  function end_reason_text(r) result(s)
    integer, intent(in) :: r
    character(:), allocatable :: s
    select case (r)
    case (1); s = 'the orbits run into another equilibrium'
    case (2); s = 'the period grows without bound'
    case (3); s = 'the correction fails for ever smaller steps'
    case (4); s = 'the branch''s energy turns back (a fold)'
    case (5); s = 'the family has no branch point below the largest dE'
    case (6); s = 'the continuation took its 2000 steps'
    case (7); s = 'past a fold the energy returned to the start''s'
    case (8); s = 'the guess did not converge'
    case (9); s = 'no requested energy lies on the branch''s side of the bifurcation'
    case (10); s = 'the arc closed into a loop (a fold at its start''s energy; the energies not taken are not on it)'
    case (11); s = 'the saddle''s centre modes do not define the family by this name'
    case default; s = 'none'
    end select
  end function end_reason_text

  !> Why the family has no orbit at de (the continuation ended, at end_de if > 0, for reason): past
  !> the family's end, or short of its extrapolated end (the continuation stopped before de).
  function family_stop_text(saddle, de, end_de, reason, units_e) result(s)
    character(*), intent(in) :: saddle, units_e
    real(wp), intent(in) :: de, end_de
    integer, intent(in) :: reason
    character(:), allocatable :: s
    if (end_de > 0 .and. de >= end_de*(1 - 1e-6_wp)) then
      s = 'dE = ' // num(de) // ' is past the end of the ' // trim(saddle) // ' family, which ends at dE ~ ' // &
          num(end_de, '.8g') // units_e // ' (' // end_reason_text(reason) // '): no orbit there'
    else if (end_de > 0) then
      s = 'dE = ' // num(de) // ' was not reached: the continuation of the ' // trim(saddle) // ' family stopped ' // &
          'before it (' // end_reason_text(reason)
      if (reason == END_PERIOD) s = s // ': it passed the continuation''s limit on the period'
      s = s // '); the family''s end, extrapolated from its last orbits, is at dE ~ ' // num(end_de, '.8g') // &
          units_e // ', beyond this dE: an orbit may exist there that the continuation does not reach'
    else
      s = 'dE = ' // num(de) // ' is past the end of the ' // trim(saddle) // ' family: no orbit there'
    end if
  end function family_stop_text

  !> The units of a state: the ball's by component, else the table's word.
  function state_units(n2) result(s)
    integer, intent(in) :: n2
    character(:), allocatable :: s
    s = 'state units'
    if (n2 == 4) s = 'cm, cm, cm/s, cm/s'
  end function state_units

  !> A progress line of the scene's long steps, as it comes.
  subroutine say(text)
    character(*), intent(in) :: text
    call progress_line(text, .false.)
  end subroutine say

  !> An integer as C's %d (or by a spec of num: '5.0f' for %5d).
  function inum(i, spec) result(s)
    integer, intent(in) :: i
    character(*), intent(in), optional :: spec
    character(:), allocatable :: s
    if (present(spec)) then
      s = num(real(i, wp), spec)
    else
      s = num(real(i, wp), '.0f')
    end if
  end function inum

  !> v as C's %+.3g: its sign always.
  function signed(v) result(s)
    real(wp), intent(in) :: v
    character(:), allocatable :: s
    s = num(v, '.3g')
    if (s(1:1) /= '-') s = '+' // s
  end function signed
end module tubes_scene_orbits
