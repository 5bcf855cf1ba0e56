!> The flux scene (docs/flux.md, docs/output.md /flux) as one procedure of the core: the flux
!> through a rank-1 saddle's bottleneck on the &flux energies, sampled on the dividing surface
!> beside the leading order; with &flux order the Birkhoff normal form's flux at orders K and
!> K - 2; with a plane section in 3 degrees of freedom the transition fraction on it (Monte Carlo
!> against flux / volume) and, with &flux n_cut, the stable tube's cut with it. Its console
!> tables, its verdicts (tubes_verdicts: the one definition of the flux checks) and its datasets
!> go into a result record (tubes_record) that the program's driver writes
!> (src/io/tubes_record_write.c) and Python reads (tubes.flux): the scene's rules are here once.
module tubes_scene_flux
  use, intrinsic :: iso_c_binding, only: c_int, c_double, c_char, c_ptr, c_null_char, c_f_pointer, c_associated
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan, ieee_is_finite, ieee_is_nan
  use omp_lib, only: omp_get_wtime
  use tubes_kinds, only: wp
  use tubes_status, only: TUBES_OK, TUBES_EINPUT, TUBES_EOUTSIDE, TUBES_ENOCROSS, TUBES_EPASTEND, status_message
  use tubes_cstrings, only: num, c_to_f, f_to_c
  use tubes_record, only: record_t, EXIT_BADINPUT, EXIT_NUMERIC, EXIT_PARTIAL
  use tubes_hamiltonian, only: hamiltonian_t
  use tubes_equilibria, only: equilibrium_t
  use tubes_models, only: MAX_DOF, LEN_SYSTEM, make_model
  use tubes_methods, only: integ_choice_t
  use tubes_study, only: seed_stores_t, setup_model, model_equilibria, equilibria_table
  use tubes_flux, only: flux_result_t, flux_leading_order, flux_sampled
  use tubes_normal_form, only: nf_result_t, normal_form_flux, NF_NPTS
  use tubes_cut3, only: cut3_t, CUT3_NDIAG
  use tubes_flux3, only: cut3_study
  use tubes_scene_text, only: progress_line
  use tubes_config, only: tubes_config_t
  use tubes_settings, only: settings_integ, settings_text
  use tubes_verdicts, only: flux_too_small, flux_undecided, flux_normal_form_check, section_check, cut3_check
  implicit none
  private

  public :: scene_flux, flux_opts_t, flux_opts_of

  !> The scene's settings (&flux, &section; docs/input.md).
  type, public :: flux_opts_t
    real(wp), allocatable :: de(:)         !! the excess energies
    integer :: n_samples = 0, seed = 0, order = 0, n_cut = 0
    real(wp) :: t_max = 0, gate = 0, tol = 0, cut_eps = 0
    logical :: plane = .false.             !! &section kind = 'plane'
    integer :: sec_index = 0, sec_dir = 0
    real(wp) :: sec_value = 0
    type(integ_choice_t) :: integ
  end type flux_opts_t

  integer, parameter :: MAX_NF = 4096      !! the normal form's terms kept (/flux/normal_form)
  integer, parameter :: LMSG = 512         !! a message of the normal form (the attribute's C buffer)

  !> The normal form's results for /flux.
  type :: nf_out_t
    logical :: done = .false.              !! the normal form of order K was computed
    integer :: stat = 0, n_nf = 0, ndof = 0, nt = 0
    real(wp) :: lambda = 0, omegas(MAX_DOF - 1) = 0, diag(4) = 0, z(2*MAX_DOF) = 0
    real(wp), allocatable :: flux(:), change(:), coef(:), round_trip(:), energy_err(:), nhim(:, :, :)
    integer, allocatable :: pw(:, :)       !! (3, n_nf) the powers of I_1, J_2, J_3
    integer, allocatable :: ex(:, :)       !! (2N, nt) the Taylor expansion the normal form came from
    real(wp), allocatable :: cf(:)
    character(LMSG) :: msg = ''
  end type nf_out_t

  !> The section's Monte Carlo (3 DOF, a plane) and the tube's cut per energy.
  type :: sec_out_t
    real(wp), allocatable :: sv(:), sve(:), sf(:), sfe(:), pth(:), sx(:, :, :), sw(:, :)
    integer, allocatable :: counts(:, :), scls(:, :)
    logical :: cut = .false.               !! the tube's cut was computed (/flux/tube_cut)
    integer :: ns = 0, nodes = 0, axes(4) = 0
    real(wp), allocatable :: x(:, :, :), t(:, :), diag(:, :), ptrans(:), vex(:)
    integer, allocatable :: st(:, :), inside(:, :), inside_pl(:, :), mis(:), mis_pl(:), unres(:)
  end type sec_out_t

  interface
    !> The Taylor expansion of a model written as a formula at z (src/io/tubes_expr.c): n terms,
    !> expo(2N, n) and coef malloc'ed (freed with c_free).
    integer(c_int) function expr_taylor(key, z, order, n, expo, coef, msg, lmsg) bind(C, name='tubes_expr_taylor')
      import :: c_int, c_double, c_char, c_ptr
      character(kind=c_char), intent(in) :: key(*)
      real(c_double), intent(in) :: z(*)
      integer(c_int), value :: order, lmsg
      integer(c_int), intent(out) :: n
      type(c_ptr), intent(out) :: expo, coef
      character(kind=c_char), intent(out) :: msg(*)
    end function expr_taylor
    subroutine c_free(p) bind(C, name='free')
      import :: c_ptr
      type(c_ptr), value :: p
    end subroutine c_free
  end interface

contains

  !> The scene for system (params) at its saddle (the equilibria in [lo, hi], n_grid starts per
  !> axis); who: the input file for messages ('tubes' without one); sysname: &model system, as
  !> messages name it; opts: &flux and &section; stores: the run's kept results (or null). rec:
  !> the scene's record. Its exit code keeps the program's precedence: a numerical failure (2)
  !> overrides an energy past the bottleneck (4); a refused request (1) of the normal form
  !> overrides both.
  !> The scene's settings from the run's (&flux, &section, &integrator with the run's method).
  function flux_opts_of(cfg, method) result(o)
    type(tubes_config_t), intent(in) :: cfg
    integer, intent(in) :: method
    type(flux_opts_t) :: o
    allocate (o%de(cfg%flux_nde))   ! (not by assignment: gfortran 12 warns of the result's unset bounds)
    o%de(:) = cfg%flux_de(1:cfg%flux_nde)
    o%n_samples = cfg%flux_n_samples
    o%seed = cfg%flux_seed
    o%order = cfg%flux_order
    o%n_cut = cfg%flux_n_cut
    o%t_max = cfg%flux_t_max
    o%gate = cfg%flux_gate
    o%tol = cfg%flux_tol
    o%cut_eps = cfg%flux_cut_eps
    o%plane = settings_text(cfg%sec_kind) == 'plane'
    o%sec_index = cfg%sec_index
    o%sec_dir = cfg%sec_direction
    o%sec_value = cfg%sec_value
    o%integ = settings_integ(cfg, method)
  end function flux_opts_of

  !> The scene on the run's settings cfg, the saddle and the method the run chose (tubes_setup
  !> run_saddle, method_resolved); who names the input in messages.
  subroutine scene_flux(cfg, saddle, method, who, stores, rec)
    type(tubes_config_t), intent(in) :: cfg
    character(*), intent(in) :: saddle, who
    integer, intent(in) :: method
    type(seed_stores_t), pointer, intent(in) :: stores
    type(record_t), intent(inout) :: rec
    call flux_scene_body(settings_text(cfg%model), cfg%params, cfg%box_lo, cfg%box_hi, cfg%n_grid, saddle, who, &
                         settings_text(cfg%system), flux_opts_of(cfg, method), stores, rec)
  end subroutine scene_flux

  subroutine flux_scene_body(system, params, lo, hi, n_grid, saddle, who, sysname, opts, stores, rec)
    character(*), intent(in) :: system, saddle, who, sysname
    real(wp), intent(in) :: params(:), lo(:), hi(:)
    integer, intent(in) :: n_grid
    type(flux_opts_t), intent(in) :: opts
    type(seed_stores_t), pointer, intent(in) :: stores
    type(record_t), intent(inout) :: rec
    class(hamiltonian_t), allocatable :: model
    real(wp), allocatable :: fl(:), fe(:), lead(:)
    integer, allocatable :: cnt(:, :), stat(:)
    type(nf_out_t) :: nfo
    type(sec_out_t) :: so
    character(1024) :: vm
    real(wp) :: de, t0, box(2, MAX_DOF - 1)
    integer :: n, nd, k, st, rc, r2, ns
    logical :: natural, sampled, sec, cut_only, cutok
    n = size(opts%de)
    ns = opts%n_samples
    rc = 0
    nd = 0
    natural = .false.
    call make_model(system, params, model, st)
    if (st == TUBES_OK) then
      nd = model%ndof()
      natural = model%is_natural()
    end if
    allocate (fl(n), fe(n), lead(n), cnt(4, n), stat(n))
    fl = 0; fe = 0; lead = 0; cnt = 0; stat = 0
    call rec%out('flux: through the bottleneck of ' // trim(saddle) // ', N = ' // inum(nd) // &
                 ': sampled on the dividing surface (' // inum(ns) // ' points, slab half-width ' // num(opts%gate) // &
                 ', tol ' // num(opts%tol) // '), beside the leading order (2 pi)^(N-1) dE^(N-1) / ((N-1)! prod omega)')
    call rec%out('  ' // rs('dE', 10) // ' ' // rs('flux', 16) // ' ' // rs('+-', 12) // ' ' // rs('leading', 16) // &
                 ' ' // rs('flux/lead', 9) // ' ' // rs('reacting', 9) // ' ' // rs('recross', 9) // ' ' // &
                 rs('undecided', 9))
    sampled = .true.      ! H quadratic in the momenta (natural or gyroscopic): else the normal form alone
    do k = 1, n
      de = opts%de(k)
      t0 = omp_get_wtime()
      call progress('flux: dE = ' // num(de) // ' (' // inum(k) // ' of ' // inum(n) // ')...')
      call flux_sample(de, fl(k), fe(k), lead(k), cnt(:, k), box, st)
      stat(k) = st
      if (st == TUBES_EINPUT .and. .not. natural) then
        call rec%out('  (not sampled: H is not quadratic in the momenta, or has no reversor to pair each crossing ' // &
                     'with its time-reverse; the normal form''s flux only)')
        fl = nan(); fe = nan(); lead = nan()
        sampled = .false.
        if (opts%order == 0) then
          call rec%verdict(EXIT_NUMERIC, "tubes: flux: the Hamiltonian of '" // trim(sysname) // "' is not " // &
                           'quadratic in the momenta or has no reversor (a time-reversal symmetry): the dividing ' // &
                           'surface cannot be sampled; give &flux order (the normal form''s flux, for a model ' // &
                           'written as a formula)')
          rc = EXIT_NUMERIC
        end if
        exit
      end if
      if (st < 0) then
        fl(k) = nan(); fe(k) = nan()
        if (st == TUBES_EPASTEND) then    ! the dividing surface passes over a ridge: no single bottleneck
          call rec%verdict(EXIT_PARTIAL, 'tubes: flux: dE = ' // num(de) // ' is past the bottleneck of ' // &
                           trim(saddle) // ": the dividing surface's {V <= E} runs over a ridge into another " // &
                           'well or neck (the energy is above a maximum of V beside the saddle, where its orbit ' // &
                           'family ends), so its flux is not the bottleneck''s; NaN there')
          if (rc == 0) rc = EXIT_PARTIAL
          cycle
        end if
        call rec%verdict(EXIT_NUMERIC, 'tubes: flux: dE = ' // num(de) // ' failed: ' // status_message(st) // &
                         ' (status ' // inum(st) // ')')
        rc = EXIT_NUMERIC
        cycle
      end if
      if (flux_too_small(de, nd, lead(k), vm) /= 0) then      ! below the smallest double
        call rec%verdict(EXIT_NUMERIC, trim(vm))
        fl(k) = nan(); fe(k) = nan()
        rc = EXIT_NUMERIC
        cycle
      end if
      call rec%out('  ' // num(de, '10.4g') // ' ' // num(fl(k), '16.10g') // ' ' // num(fe(k), '12.4g') // ' ' // &
                   num(lead(k), '16.10g') // ' ' // num(fl(k)/lead(k), '9.6f') // ' ' // inum(cnt(2, k), 9) // &
                   ' ' // inum(cnt(3, k), 9) // ' ' // inum(cnt(4, k), 9) // '   (' // &
                   num(omp_get_wtime() - t0, '.1f') // ' s)')
      if (flux_undecided(de, cnt(:, k), opts%gate, opts%t_max, vm) /= 0) then
        call rec%verdict(EXIT_NUMERIC, trim(vm))
        rc = EXIT_NUMERIC
      end if
    end do
    ! the normal form (&flux order > 0): its flux at order K and K - 2 (the change: its own error
    ! estimate), and the check against the sampled flux
    allocate (nfo%flux(n), nfo%change(n), nfo%round_trip(n), nfo%energy_err(n), nfo%nhim(2*nd, NF_NPTS, n))
    nfo%flux = nan(); nfo%change = nan(); nfo%round_trip = nan(); nfo%energy_err = nan(); nfo%nhim = 0
    if (opts%order > 0) then
      call flux_normal_form(r2)
      if (r2 /= 0 .and. (rc == 0 .or. r2 == EXIT_BADINPUT)) rc = r2
    end if
    ! the transition fraction on a plane section (3 DOF; 2 DOF: the transition scene): Monte Carlo
    ! against flux / volume; a model not quadratic in the momenta: the tube's cut without it
    sec = sampled .and. nd == 3 .and. opts%plane
    cut_only = .not. sampled .and. nd == 3 .and. opts%plane
    so%ns = ns
    allocate (so%sv(n), so%sve(n), so%sf(n), so%sfe(n), so%pth(n), so%counts(4, n))
    so%sv = 0; so%sve = 0; so%sf = 0; so%sfe = 0; so%pth = 0; so%counts = 0
    if (sec) then
      allocate (so%sx(2*MAX_DOF, ns, n), so%sw(ns, n), so%scls(ns, n))
      call section_fraction(r2)
      if (r2 /= 0 .and. rc == 0) rc = r2
      ! the tube's cut: a normal form (its coordinates seed the tube) with every energy's flux
      cutok = opts%n_cut > 0 .and. nfo%done .and. nfo%stat == 0
      if (cutok) cutok = all(ieee_is_finite(nfo%flux)) .and. all(ieee_is_finite(so%sv))
      if (cutok) then
        call tube_cut3(r2)
        if (r2 /= 0 .and. rc == 0) rc = r2
      else if (opts%n_cut > 0) then
        call rec%out('  (no tube cut: it is seeded from the normal form, which needs &flux order and a flux at ' // &
                     'every dE)')
      end if
    else if (cut_only .and. opts%n_cut > 0) then
      cutok = nfo%done .and. nfo%stat == 0
      if (cutok) cutok = all(ieee_is_finite(nfo%flux))
      so%ns = 0
      allocate (so%sx(2*MAX_DOF, 0, n), so%sw(0, n), so%scls(0, n))
      if (cutok) then
        so%sv = nan()
        call rec%out("  (the section's Monte Carlo needs H quadratic in the momenta: the tube's cut alone)")
        call tube_cut3(r2)
        if (r2 /= 0 .and. rc == 0) rc = r2
      else
        call rec%out('  (no tube cut: it is seeded from the normal form, which needs &flux order and a flux at ' // &
                     'every dE)')
      end if
    end if
    call write_flux()
    rec%code = rc

  contains

    !> vm, a failed check's message (tubes_verdicts), as a verdict: exit 2.
    subroutine failed(code)
      integer, intent(inout) :: code
      call rec%verdict(EXIT_NUMERIC, trim(vm))
      code = EXIT_NUMERIC
    end subroutine failed

    !> The flux sampled at de (src/transport/tubes_flux.f90) and its leading order; counts: inside
    !> the shell, reacting, recrossing, undecided.
    subroutine flux_sample(de, flux, err, leading, counts, box, stat)
      real(wp), intent(in) :: de
      real(wp), intent(out) :: flux, err, leading, box(:, :)
      integer, intent(out) :: counts(4), stat
      class(hamiltonian_t), allocatable :: mdl
      type(equilibrium_t), allocatable :: eqs(:)
      type(flux_result_t) :: res
      integer :: isad, m
      flux = 0; err = 0; leading = 0; counts = 0; box = 0
      call setup_model(system, params, lo, hi, n_grid, saddle, mdl, eqs, isad, stat, degenerate_ok=.true., &
                       des=[de], conservative=.true.)
      if (stat /= TUBES_OK) return
      m = mdl%ndof()
      leading = flux_leading_order(eqs(isad)%omegas, de)
      call flux_sampled(mdl, eqs(isad), de, ns, opts%seed, opts%t_max, opts%tol, opts%gate, &
                        maxval(hi(1:m) - lo(1:m)), opts%integ, res, stat)
      flux = res%flux
      err = res%err
      counts = [res%n_inside, res%n_reactive, res%n_recrossing, res%n_undecided]
      box(:, 1:m - 1) = res%box(:, 1:m - 1)
    end subroutine flux_sample

    !> The Birkhoff normal form of the formula model at the saddle (&flux order K;
    !> src/orbits/tubes_normal_form.f90) and its flux on the energies at orders K and K - 2,
    !> against the sampled flux fl +- fe: a refusal (not a formula model: exit 1; degenerate,
    !> resonant: exit 2, the sampled flux still written) or a disagreement beyond 5 combined
    !> standard errors (exit 2) is reported.
    subroutine flux_normal_form(code)
      integer, intent(out) :: code
      type(equilibrium_t), allocatable :: eqs(:)
      class(hamiltonian_t), allocatable :: mdl
      real(wp), allocatable :: q(:, :), p(:, :), hgt(:), en(:), gn(:), lam(:), om(:, :), ev(:, :), f2(:)
      integer, allocatable :: morse(:), rank1(:), fst(:)
      type(nf_result_t) :: res
      real(wp) :: t0, worst, x(2*MAX_DOF), e, zk
      integer :: kk, ks, i, j, ne, nt, st2, kord
      type(c_ptr) :: pex, pcf
      integer(c_int), pointer :: ex(:, :)
      real(c_double), pointer :: cf(:)
      character(kind=c_char) :: cmsg(LMSG), key(LEN_SYSTEM + 1)
      character(:), allocatable :: line
      code = 0
      kord = opts%order
      if (nd == 3 .and. kord > 10) then
        call rec%verdict(EXIT_BADINPUT, who // ': &flux: order = ' // inum(kord) // ': at most 10 in 3 degrees ' // &
                         'of freedom (the monomials grow as K^6)')
        code = EXIT_BADINPUT
        return
      end if
      call model_equilibria(system, params, lo, hi, n_grid, stores, mdl, eqs, st2)
      ks = 0
      if (st2 == TUBES_OK) then
        ne = size(eqs)
        do kk = 1, ne
          if (eqs(kk)%name == saddle) then
            ks = kk
            exit
          end if
        end do
      end if
      if (ks == 0) then
        call rec%verdict(EXIT_NUMERIC, 'tubes: flux: normal form: the saddle ' // trim(saddle) // &
                         ' was not found again')
        code = EXIT_NUMERIC
        return
      end if
      allocate (q(MAX_DOF, ne), p(MAX_DOF, ne), hgt(ne), en(ne), gn(ne), lam(ne), om(MAX_DOF - 1, ne), &
                ev(4*MAX_DOF*MAX_DOF, ne), morse(ne), rank1(ne))
      q = 0; p = 0; om = 0; ev = 0
      call equilibria_table(eqs, nd, q, p, hgt, en, gn, morse, rank1, lam, om, ev)
      nfo%z(1:nd) = q(1:nd, ks)
      nfo%z(nd + 1:2*nd) = p(1:nd, ks)
      t0 = omp_get_wtime()
      call f_to_c(system, key)
      st2 = expr_taylor(key, nfo%z, kord, nt, pex, pcf, cmsg, LMSG)
      nfo%msg = c_to_f(cmsg)
      if (st2 /= 0) then
        call rec%verdict(EXIT_BADINPUT, who // ': &flux: order = ' // inum(kord) // ': ' // trim(nfo%msg))
        code = EXIT_BADINPUT
        return
      end if
      nfo%nt = nt
      allocate (nfo%ex(2*nd, nt), nfo%cf(nt))
      if (nt > 0) then
        call c_f_pointer(pex, ex, [2*nd, nt])
        call c_f_pointer(pcf, cf, [nt])
        nfo%ex = ex
        nfo%cf = cf
      end if
      if (c_associated(pex)) call c_free(pex)
      if (c_associated(pcf)) call c_free(pcf)
      nfo%ndof = nd
      allocate (fst(n), f2(n), nfo%coef(MAX_NF), nfo%pw(3, MAX_NF))
      nfo%coef = 0; nfo%pw = 0
      call normal_form_flux(nd, kord, nfo%ex, nfo%cf, opts%de, res, nfo%flux, fst, nfo%stat)
      nfo%msg = res%message
      nfo%done = .true.
      if (nfo%stat /= TUBES_OK) then
        call rec%verdict(EXIT_NUMERIC, 'tubes: flux: ' // trim(nfo%msg) // ' (status ' // inum(nfo%stat) // &
                         '); the sampled flux is written')
        code = EXIT_NUMERIC
        return
      end if
      nfo%lambda = res%lambda
      nfo%omegas(1:nd - 1) = res%omegas(1:nd - 1)
      nfo%diag = [res%symplectic_error, res%residual, res%imaginary, res%smallest_divisor]
      nfo%n_nf = min(res%nterms, MAX_NF)
      do kk = 1, nfo%n_nf
        nfo%pw(1:nd, kk) = res%expo(:, kk)
        nfo%coef(kk) = res%coef(kk)
      end do
      nfo%nhim = nan()
      if (allocated(res%nhim)) then
        nfo%nhim = res%nhim
        nfo%round_trip = res%round_trip
      end if
      if (kord >= 4) then
        call normal_form_flux(nd, kord - 2, nfo%ex, nfo%cf, opts%de, res, f2, fst, st2)
        if (st2 == TUBES_OK) nfo%change = abs(nfo%flux - f2)
      end if
      ! the NHIM's points mapped to the model's coordinates: their energy by the model itself
      do kk = 1, n
        worst = 0
        do j = 1, NF_NPTS
          x(1:2*nd) = nfo%z(1:2*nd) + nfo%nhim(:, j, kk)
          nfo%nhim(:, j, kk) = x(1:2*nd)          ! stored as z itself
          e = mdl%energy(x(1:2*nd))
          if (.not. ieee_is_finite(e)) then
            worst = nan()
            exit
          end if
          e = abs(e - en(ks) - opts%de(kk))/opts%de(kk)
          if (e > worst) worst = e
        end do
        if (ieee_is_finite(nfo%flux(kk))) nfo%energy_err(kk) = worst
      end do
      line = 'flux: Birkhoff normal form of order ' // inum(kord) // ' at ' // trim(saddle) // ' (' // &
             num(omp_get_wtime() - t0, '.2f') // ' s): lambda = ' // num(nfo%lambda, '.10g') // ', omega = ' // &
             num(nfo%omegas(1), '.10g')
      if (nd == 3) line = line // ', ' // num(nfo%omegas(2), '.10g')
      call rec%out(line // '; checks: symplectic ' // num(nfo%diag(1), '.1e') // ', non-normal terms left ' // &
                   num(nfo%diag(2), '.1e') // ', imaginary ' // num(nfo%diag(3), '.1e') // ', smallest divisor ' // &
                   num(nfo%diag(4), '.4g'))
      call rec%out('  ' // rs('dE', 10) // ' ' // rs('normal form', 18) // ' ' // rs('change K-2', 12) // ' ' // &
                   rs('sampled', 16) // ' ' // rs('+-', 12) // ' ' // rs('diff/sd', 9) // ' ' // &
                   rs('NHIM dE err', 12) // ' ' // rs('round trip', 12))
      do kk = 1, n
        i = flux_normal_form_check(opts%de(kk), kord, nfo%flux(kk), nfo%change(kk), fl(kk), fe(kk), zk, vm)
        call rec%out('  ' // num(opts%de(kk), '10.4g') // ' ' // num(nfo%flux(kk), '18.12g') // ' ' // &
                     num(nfo%change(kk), '12.3g') // ' ' // num(fl(kk), '16.10g') // ' ' // num(fe(kk), '12.4g') // &
                     ' ' // num(zk, '9.2f') // ' ' // num(nfo%energy_err(kk), '12.3g') // ' ' // &
                     num(nfo%round_trip(kk), '12.3g'))
        if (i /= 0) call failed(code)
      end do
    end subroutine flux_normal_form

    !> The &section plane q_k = c: the energy surface's volume on it (sampled as the flux) and the
    !> fraction of it that transits before returning, against flux / volume (the normal form's
    !> flux when there is one, else the sampled). More than 1 % undecided, or the two more than 5
    !> combined standard errors apart: reported, exit 2.
    subroutine section_fraction(code)
      integer, intent(out) :: code
      class(hamiltonian_t), allocatable :: mdl
      type(equilibrium_t), allocatable :: eqs(:)
      type(flux_result_t) :: res
      real(wp) :: z, t0
      integer :: kk, st2, isad, m, v
      logical :: use_nf
      character(:), allocatable :: pcol, zcol
      code = 0
      call rec%out('flux: the transition fraction on the section q' // inum(opts%sec_index) // ' = ' // &
                   num(opts%sec_value) // ' (dq' // inum(opts%sec_index) // '/dt ' // &
                   merge('>', '<', opts%sec_dir > 0) // ' 0): Monte Carlo (' // inum(ns) // &
                   ' points) against flux / volume')
      call rec%out('  ' // rs('dE', 10) // ' ' // rs('volume', 14) // ' ' // rs('+-', 10) // ' ' // &
                   rs('flux/volume', 12) // ' ' // rs('Monte Carlo', 12) // ' ' // rs('+-', 10) // ' ' // &
                   rs('diff/sd', 9) // ' ' // rs('transits', 9) // ' ' // rs('returns', 9) // ' ' // &
                   rs('undecided', 9))
      do kk = 1, n
        t0 = omp_get_wtime()
        ! the section's volume and transition fraction at dE (flux_sampled's section mode)
        so%sv(kk) = 0; so%sve(kk) = 0; so%sf(kk) = 0; so%sfe(kk) = 0; so%counts(:, kk) = 0
        so%sx(:, :, kk) = nan()
        so%sw(:, kk) = 0
        so%scls(:, kk) = 3
        call setup_model(system, params, lo, hi, n_grid, saddle, mdl, eqs, isad, st2, degenerate_ok=.true., &
                         des=[opts%de(kk)], conservative=.true.)
        if (st2 == TUBES_OK) then
          m = mdl%ndof()
          call flux_sampled(mdl, eqs(isad), opts%de(kk), ns, opts%seed, opts%t_max, opts%tol, opts%gate, &
                            maxval(hi(1:m) - lo(1:m)), opts%integ, res, st2, [opts%sec_index, opts%sec_dir], &
                            opts%sec_value)
          so%sv(kk) = res%volume
          so%sve(kk) = res%volume_err
          so%sf(kk) = res%fraction
          so%sfe(kk) = res%fraction_err
          so%counts(:, kk) = [res%n_inside, res%n_transit, res%n_return, res%n_undecided]
          if (st2 == TUBES_OK .and. allocated(res%x)) then
            so%sx(1:2*m, :, kk) = res%x
            so%sw(:, kk) = res%w
            so%scls(:, kk) = res%cls
          end if
        end if
        if (st2 < 0) then
          vm = ''
          if (st2 == TUBES_EOUTSIDE) vm = ": the section's point nearest the saddle lies outside the energy " // &
                                          'surface (a section the tube cannot reach there: move it)'
          call rec%verdict(EXIT_NUMERIC, 'tubes: flux: the section q' // inum(opts%sec_index) // ' = ' // &
                           num(opts%sec_value) // ' at dE = ' // num(opts%de(kk)) // ': ' // status_message(st2) // &
                           ' (status ' // inum(st2) // ')' // trim(vm))
          so%sv(kk) = nan(); so%sve(kk) = nan(); so%sf(kk) = nan(); so%sfe(kk) = nan(); so%pth(kk) = nan()
          code = EXIT_NUMERIC
          cycle
        end if
        ! flux / volume, the normal form's flux where its own error (the change from order K - 2)
        ! is within 10 % of it, beyond its reach the sampled flux; against the Monte Carlo fraction
        v = section_check(opts%de(kk), nfo%flux(kk), nfo%change(kk), fl(kk), fe(kk), so%sv(kk), so%sve(kk), &
                          so%sf(kk), so%sfe(kk), so%sw(:, kk), so%counts(:, kk), opts%t_max, use_nf, so%pth(kk), z, vm)
        if (ieee_is_finite(nfo%flux(kk)) .and. .not. use_nf .and. ieee_is_finite(fl(kk))) &
          call rec%out('  (dE = ' // num(opts%de(kk)) // ': flux / volume from the sampled flux: the normal ' // &
                       'form''s change from order K - 2, ' // num(nfo%change(kk), '.3g') // ', exceeds 10 % of ' // &
                       'its flux ' // num(nfo%flux(kk), '.6g') // ')')
        pcol = rs('-', 12)            ! no flux there (failed, past the bottleneck, or too small)
        zcol = rs('-', 9)
        if (.not. ieee_is_nan(so%pth(kk))) then
          pcol = num(so%pth(kk), '12.6f')
          zcol = num(z, '9.2f')
        end if
        call rec%out('  ' // num(opts%de(kk), '10.4g') // ' ' // num(so%sv(kk), '14.8g') // ' ' // &
                     num(so%sve(kk), '10.3g') // ' ' // pcol // ' ' // num(so%sf(kk), '12.6f') // ' ' // &
                     num(so%sfe(kk), '10.2g') // ' ' // zcol // ' ' // counts3(so%counts(:, kk)) // &
                     '   (' // num(omp_get_wtime() - t0, '.1f') // ' s)')
        if (ieee_is_nan(so%pth(kk))) cycle
        if (v /= 0) call failed(code)
      end do
    end subroutine section_fraction

    !> The cut of the stable tube with the section q_k = c (src/workflow/tubes_flux3.f90): its
    !> 4-volume against the flux, and the Monte Carlo points of section_fraction inside it against
    !> their fate. The cut on every other node gives a second volume V_h: the discretisation is
    !> second order, so V_x = V + (V - V_h) / 3 is the extrapolated volume. The piecewise-linear
    !> cut lacks about |V_x - V|: the decided points in that shell, mu = n_decided |V_x - V| /
    !> (the section's volume), are those its resolution may misclassify. Reported with exit 2: a
    !> seed that never reaches the section; V_x further from the flux than a quarter of |V - V_h|
    !> (plus 1e-6 relative); more misclassified points (by the smooth cut) than mu + 5 sqrt(mu) + 2.
    subroutine tube_cut3(code)
      integer, intent(out) :: code
      type(cut3_t) :: cut
      character(256) :: msg
      real(wp) :: t0, f
      integer :: kk, m, k3, a, b, st2, nf3(3), j, s, nc
      code = 0
      nc = opts%n_cut
      m = (nc + 1)*4*nc*nc
      k3 = opts%sec_index
      a = merge(2, 1, k3 == 1)
      b = 6 - k3 - a
      so%axes = [a, 3 + a, b, 3 + b]
      so%nodes = m
      so%cut = .true.
      allocate (so%x(6, m, n), so%t(m, n), so%st(m, n), so%diag(CUT3_NDIAG, n), so%ptrans(n), so%vex(n), &
                so%inside(so%ns, n), so%inside_pl(so%ns, n), so%mis(n), so%mis_pl(n), so%unres(n))
      call rec%out("flux: the stable tube's cut with the section q" // inum(k3) // ' = ' // num(opts%sec_value) // &
                   ': a 3-sphere from ' // inum(m) // ' NHIM seeds (' // inum(nc + 1) // ' rings of ' // &
                   inum(2*nc) // ' x ' // inum(2*nc) // ', step-off ' // num(opts%cut_eps) // '); its 4-volume ' // &
                   'against the flux, the Monte Carlo points inside it against their fate')
      call rec%out('  ' // rs('dE', 10) // ' ' // rs('cut volume', 13) // ' ' // rs('extrapolated', 13) // ' ' // &
                   rs('flux', 13) // ' ' // rs('extrap/f-1', 11) // ' ' // rs('seed dE err', 11) // ' ' // &
                   rs('p_trans tube', 12) // ' ' // rs('Monte Carlo', 12) // ' ' // rs('inside', 8) // ' ' // &
                   rs('decided', 8) // ' ' // rs('misclass PL', 11) // ' ' // rs('misclass', 9) // ' ' // &
                   rs('unresolved', 10))
      do kk = 1, n
        t0 = omp_get_wtime()
        so%mis(kk) = -1; so%mis_pl(kk) = -1; so%unres(kk) = -1
        so%ptrans(kk) = nan(); so%vex(kk) = nan()
        call progress("flux: the tube's cut at dE = " // num(opts%de(kk)) // ' (' // inum(kk) // ' of ' // &
                      inum(n) // ')...')
        so%st(:, kk) = TUBES_EINPUT
        so%x(:, :, kk) = nan()
        so%t(:, kk) = nan()
        call cut3_study(system, params, lo, hi, n_grid, saddle, opts%order, nfo%ex, nfo%cf, nfo%z, opts%de(kk), &
                        k3, opts%sec_value, opts%sec_dir, nc, opts%cut_eps, opts%t_max, opts%tol, opts%integ, &
                        so%sx(1:6, 1:so%ns, kk), so%sw(1:so%ns, kk), so%scls(1:so%ns, kk), so%inside(:, kk), &
                        so%inside_pl(:, kk), cut, so%diag(:, kk), msg, st2)
        if (allocated(cut%x)) then
          so%x(:, :, kk) = cut%x
          so%t(:, kk) = cut%t
          so%st(:, kk) = cut%st
        end if
        if (st2 < 0) then
          nf3 = 0
          do j = 1, m
            s = so%st(j, kk)
            if (s == 0) cycle
            if (s == 1) then
              nf3(1) = nf3(1) + 1
            else if (s == 2) then
              nf3(2) = nf3(2) + 1
            else
              nf3(3) = nf3(3) + 1
            end if
          end do
          if (st2 == TUBES_ENOCROSS .and. nf3(2) == m) then
            call rec%verdict(EXIT_NUMERIC, "tubes: flux: the tube's cut at dE = " // num(opts%de(kk)) // &
                             ': the stable tube reaches the section q' // inum(k3) // ' = ' // num(opts%sec_value) // &
                             ' with dq' // inum(k3) // '/dt ' // merge('<', '>', opts%sec_dir > 0) // &
                             ' 0, and &section direction = ' // inum(opts%sec_dir) // &
                             ' asks for the other way: set direction = ' // inum(-opts%sec_dir))
          else if (st2 == TUBES_ENOCROSS) then
            call rec%verdict(EXIT_NUMERIC, "tubes: flux: the tube's cut at dE = " // num(opts%de(kk)) // ': of ' // &
                             inum(m) // ' seeds, ' // inum(nf3(1)) // ' did not reach the section q' // inum(k3) // &
                             ' = ' // num(opts%sec_value) // ' within t_max = ' // num(opts%t_max) // ', ' // &
                             inum(nf3(2)) // ' crossed it the other way first, ' // inum(nf3(3)) // ' failed: ' // &
                             'the tube does not reach this section as a whole (move it nearer the saddle, or ' // &
                             'raise &flux t_max)')
          else
            if (len_trim(msg) == 0) msg = 'failed'
            call rec%verdict(EXIT_NUMERIC, "tubes: flux: the tube's cut at dE = " // num(opts%de(kk)) // ': ' // &
                             trim(msg) // ' (status ' // inum(st2) // ')')
          end if
          code = EXIT_NUMERIC
          cycle
        end if
        ! diag: seed error, V, failed, V_h, V_x, unresolved, misclassified, by the linear cut,
        ! decided, inside, p_trans of the tube, of the Monte Carlo
        associate (d => so%diag(:, kk))
          f = nfo%flux(kk)
          so%mis(kk) = int(d(7))
          so%mis_pl(kk) = int(d(8))
          so%unres(kk) = int(d(6))
          so%ptrans(kk) = d(11)
          so%vex(kk) = d(5)
          call rec%out('  ' // num(opts%de(kk), '10.4g') // ' ' // num(d(2), '13.8g') // ' ' // &
                       num(so%vex(kk), '13.8g') // ' ' // num(f, '13.8g') // ' ' // num(so%vex(kk)/f - 1, '11.2e') // &
                       ' ' // num(d(1), '11.2e') // ' ' // num(so%ptrans(kk), '12.6f') // ' ' // num(d(12), '12.6f') // &
                       ' ' // inum(int(d(10)), 8) // ' ' // inum(int(d(9)), 8) // ' ' // &
                       inum(so%mis_pl(kk), 11) // ' ' // inum(so%mis(kk), 9) // ' ' // &
                       inum(so%unres(kk), 10) // '   (' // num(omp_get_wtime() - t0, '.1f') // ' s)')
          if (cut3_check(opts%de(kk), d(2), d(4), so%vex(kk), f, so%sv(kk), int(d(9)), so%mis(kk), vm) /= 0) call failed(code)
        end associate
      end do
    end subroutine tube_cut3

    !> /flux, its normal form, section and tube cut (docs/output.md), as the scene found them.
    subroutine write_flux()
      character(*), parameter :: pw_names(3) = ['power_I1', 'power_J2', 'power_J3']
      integer :: j, nc, m
      call rec%real('flux', 'dE', opts%de, [n])
      call rec%real('flux', 'flux_sampled', fl, [n])
      call rec%real('flux', 'flux_sampled_err', fe, [n])
      call rec%real('flux', 'flux_leading_order', lead, [n])
      call rec%int('flux', 'n_inside', cnt(1, :), [n])
      call rec%int('flux', 'n_reacting', cnt(2, :), [n])
      call rec%int('flux', 'n_recrossing', cnt(3, :), [n])
      call rec%int('flux', 'n_undecided', cnt(4, :), [n])
      call rec%int('flux', 'status', stat, [n])
      call rec%attr_int('flux', 'n_samples', ns)
      call rec%attr_int('flux', 'seed', opts%seed)
      call rec%attr_real('flux', 't_max', opts%t_max)
      call rec%attr_real('flux', 'gate', opts%gate)
      call rec%attr_real('flux', 'tol', opts%tol)
      call rec%attr_string('flux', 'saddle', trim(saddle))
      call rec%attr_int('flux', 'order', opts%order)
      if (opts%order > 0) then
        call rec%real('flux', 'flux_normal_form', nfo%flux, [n])
        call rec%real('flux', 'flux_normal_form_change', nfo%change, [n])
        call rec%real('flux', 'nhim_energy_error', nfo%energy_err, [n])
        call rec%real('flux', 'round_trip_error', nfo%round_trip, [n])
        call rec%attr_int('flux', 'normal_form_status', nfo%stat)
        call rec%attr_string('flux', 'normal_form_message', trim(nfo%msg(1:LMSG - 1)))
        if (nfo%done .and. nfo%stat == 0) then
          call rec%attr_real('flux/normal_form', 'lambda', nfo%lambda)
          call rec%real('flux/normal_form', 'omegas', nfo%omegas(1:nd - 1), [nd - 1])
          call rec%attr_real('flux/normal_form', 'symplectic_error', nfo%diag(1))
          call rec%attr_real('flux/normal_form', 'residual', nfo%diag(2))
          call rec%attr_real('flux/normal_form', 'imaginary', nfo%diag(3))
          call rec%attr_real('flux/normal_form', 'smallest_divisor', nfo%diag(4))
          call rec%real('flux/normal_form', 'coefficients', nfo%coef(1:nfo%n_nf), [nfo%n_nf])
          call rec%real('flux/normal_form', 'nhim_points', reshape(nfo%nhim, [size(nfo%nhim)]), &
                        [n, NF_NPTS, 2*nd], 'state units')
          do j = 1, nd
            call rec%int('flux/normal_form', trim(pw_names(j)), nfo%pw(j, 1:nfo%n_nf), [nfo%n_nf])
          end do
        end if
      end if
      if (sec) then        ! the transition fraction on the 4-D section
        call rec%real('flux/section', 'volume', so%sv, [n])
        call rec%real('flux/section', 'volume_err', so%sve, [n])
        call rec%real('flux/section', 'p_trans', so%sf, [n])
        call rec%real('flux/section', 'p_trans_err', so%sfe, [n])
        call rec%real('flux/section', 'p_trans_theory', so%pth, [n])
        call rec%int('flux/section', 'n_inside', so%counts(1, :), [n])
        call rec%int('flux/section', 'n_transit', so%counts(2, :), [n])
        call rec%int('flux/section', 'n_return', so%counts(3, :), [n])
        call rec%int('flux/section', 'n_undecided', so%counts(4, :), [n])
        call rec%attr_int('flux/section', 'index', opts%sec_index)
        call rec%attr_real('flux/section', 'value', opts%sec_value)
        call rec%attr_int('flux/section', 'direction', opts%sec_dir)
      end if
      if (.not. so%cut) return
      nc = opts%n_cut
      m = so%nodes
      call rec%real('flux/tube_cut', 'states', reshape(so%x, [6*m*n]), [n, nc + 1, 2*nc, 2*nc, 6], 'state units')
      call rec%real('flux/tube_cut', 'section', reshape(so%x(so%axes, :, :), [4*m*n]), &
                    [n, nc + 1, 2*nc, 2*nc, 4], 'state units')
      call rec%real('flux/tube_cut', 'time', reshape(so%t, [m*n]), [n, nc + 1, 2*nc, 2*nc])
      call rec%int('flux/tube_cut', 'status', reshape(so%st, [m*n]), [n, nc + 1, 2*nc, 2*nc])
      call rec%real('flux/tube_cut', 'volume', so%diag(2, :), [n])
      call rec%real('flux/tube_cut', 'volume_half', so%diag(4, :), [n])
      call rec%real('flux/tube_cut', 'seed_energy_error', so%diag(1, :), [n])
      call rec%real('flux/tube_cut', 'p_trans_tube', so%ptrans, [n])
      call rec%int('flux/tube_cut', 'misclassified', so%mis, [n])
      call rec%int('flux/tube_cut', 'misclassified_pl', so%mis_pl, [n])
      call rec%int('flux/tube_cut', 'unresolved', so%unres, [n])
      call rec%real('flux/tube_cut', 'volume_extrapolated', so%vex, [n])
      if (so%ns > 0) then     ! the section's Monte Carlo points (natural models)
        call rec%real('flux/tube_cut', 'points', reshape(so%sx(1:6, :, :), [6*so%ns*n]), [n, so%ns, 6], &
                      'state units')
        call rec%real('flux/tube_cut', 'weight', reshape(so%sw, [so%ns*n]), [n, so%ns])
        call rec%int('flux/tube_cut', 'outcome', reshape(so%scls, [so%ns*n]), [n, so%ns])
        call rec%int('flux/tube_cut', 'inside', reshape(so%inside, [so%ns*n]), [n, so%ns])
        call rec%int('flux/tube_cut', 'inside_pl', reshape(so%inside_pl, [so%ns*n]), [n, so%ns])
      end if
      call rec%attr_int('flux/tube_cut', 'section_index', opts%sec_index)
      call rec%attr_real('flux/tube_cut', 'section_value', opts%sec_value)
      call rec%attr_int('flux/tube_cut', 'section_direction', opts%sec_dir)
      call rec%attr_real('flux/tube_cut', 'cut_eps', opts%cut_eps)
      call rec%attr_string('flux/tube_cut', 'axes', 'q' // inum(so%axes(1)) // ' p' // inum(so%axes(1)) // ' q' // &
                           inum(so%axes(3)) // ' p' // inum(so%axes(3)))
      call rec%attr_int('flux/tube_cut', 'n_cut', nc)
    end subroutine write_flux
  end subroutine flux_scene_body

  !> The transits, returns and undecided of a section's counts, as the table's last columns.
  function counts3(c) result(s)
    integer, intent(in) :: c(4)
    character(:), allocatable :: s
    s = inum(c(2), 9) // ' ' // inum(c(3), 9) // ' ' // inum(c(4), 9)
  end function counts3

  subroutine progress(text)
    character(*), intent(in) :: text
    call progress_line(text, .true.)
  end subroutine progress

  real(wp) function nan()
    nan = ieee_value(1.0_wp, ieee_quiet_nan)
  end function nan

  !> i as C's %wd (no w: %d), by the one formatter (tubes_cstrings num).
  function inum(i, w) result(s)
    integer, intent(in) :: i
    integer, intent(in), optional :: w
    character(:), allocatable :: s
    character(8) :: spec
    spec = '.0f'
    if (present(w)) write (spec, '(i0,a)') w, '.0f'
    s = num(real(i, wp), trim(spec))
  end function inum

  !> s right-justified in a field of w (C's %ws).
  pure function rs(s, w) result(r)
    character(*), intent(in) :: s
    integer, intent(in) :: w
    character(max(w, len(s))) :: r
    r = s
    r = adjustr(r)
  end function rs
end module tubes_scene_flux
