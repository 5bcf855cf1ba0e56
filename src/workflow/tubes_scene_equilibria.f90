!> The equilibria scene (docs/usage.md, docs/output.md /equilibria and /saddle) as one procedure
!> of the core: the model's equilibria in the search box, their centre frequencies and linear
!> stability, what the box may hide, the chosen saddle's data and, with dissipation, its damped
!> spectrum; its console table and its verdicts. It returns a result record (tubes_record) that
!> the program's driver writes (src/io/tubes_record_write.c) and Python reads: the scene's rules and
!> messages are here once.
module tubes_scene_equilibria
  use tubes_kinds, only: wp, PI
  use tubes_status, only: TUBES_OK, TUBES_ENOCONV, status_message
  use tubes_cstrings, only: num
  use tubes_scene_text, only: itoa, ls, rs, wall
  use tubes_config, only: tubes_config_t
  use tubes_settings, only: settings_text
  use tubes_record, only: record_t, EXIT_NUMERIC
  use tubes_hamiltonian, only: hamiltonian_t
  use tubes_equilibria, only: equilibrium_t
  use tubes_models, only: MAX_DOF
  use tubes_setup, only: scene_dissipation, dissipation_attrs
  use tubes_study, only: study_t, seed_stores_t, model_equilibria, equilibria_table, centres_of, box_note, &
                         damped_spectrum
  implicit none
  private

  public :: scene_equilibria

contains

  !> The scene on the run's settings cfg (the model, &equilibria box, box_center, n_grid); want, asked,
  !> label, dissip, stores as equilibria_scene_body's.
  subroutine scene_equilibria(cfg, want, asked, label, dissip, stores, rec)
    type(tubes_config_t), intent(in) :: cfg
    character(*), intent(in) :: want, label, dissip
    logical, intent(in) :: asked
    type(seed_stores_t), pointer, intent(in) :: stores
    type(record_t), intent(inout) :: rec
    call equilibria_scene_body(settings_text(cfg%model), cfg%params, cfg%box_lo, cfg%box_hi, cfg%n_grid, cfg%box, want, &
                               asked, label, dissip, stores, rec)
  end subroutine scene_equilibria

  !> The scene for system (params) in the box [lo, hi] (n_grid starts per axis; box: &equilibria
  !> box, the ball's half-width [cm], for its table's head and /equilibria@box); want: the saddle
  !> whose data /saddle holds (asked: the input names it; else the model's default, whose absence
  !> is said and is no failure); label: the model as messages name it; dissip: the dissipation in
  !> words ('' for a conservative model: no damped spectrum); stores: the run's kept results (or
  !> null). rec: the scene's record.
  subroutine equilibria_scene_body(system, params, lo, hi, n_grid, box, want, asked, label, dissip, stores, rec)
    character(*), intent(in) :: system, want, label, dissip
    real(wp), intent(in) :: params(:), lo(:), hi(:), box
    integer, intent(in) :: n_grid
    logical, intent(in) :: asked
    type(seed_stores_t), pointer, intent(in) :: stores
    type(record_t), intent(inout) :: rec
    class(hamiltonian_t), allocatable :: model
    type(equilibrium_t), allocatable :: eqs(:)
    real(wp), allocatable :: q(:, :), p(:, :), hgt(:), en(:), gn(:), lam(:), om(:, :), ev(:, :), fq(:, :), &
                             xs(:), ys(:), oms(:), st2(:, :), eva(:, :, :)
    integer, allocatable :: morse(:), rank1(:), stab(:)
    character(8), allocatable :: nm(:)
    character(512) :: note
    character(:), allocatable :: line, yp
    type(study_t) :: study
    real(wp) :: t0, wr(2*MAX_DOF), wi(2*MAX_DOF), cd, omk, evr(2*MAX_DOF, 2*MAX_DOF)
    integer :: stat, n, nd, n2, k, i, isad, nc
    logical :: ball
    t0 = wall()
    ball = system == 'rolling_ball'
    call model_equilibria(system, params, lo, hi, n_grid, stores, model, eqs, stat)
    if (stat /= TUBES_OK) then
      line = 'tubes: equilibria: failed: ' // status_message(stat) // ' (status ' // itoa(stat) // ')'
      if (stat == TUBES_ENOCONV) line = line // '; or the box holds more than 256 of them: a smaller box'
      call rec%verdict(EXIT_NUMERIC, line)
      return
    end if
    nd = model%ndof()
    n2 = 2*nd
    n = size(eqs)
    allocate (q(MAX_DOF, n), p(MAX_DOF, n), hgt(n), en(n), gn(n), lam(n), om(MAX_DOF - 1, n), &
              ev(4*MAX_DOF*MAX_DOF, n), morse(n), rank1(n), nm(n), fq(MAX_DOF, n), stab(n))
    q = 0; p = 0; om = 0; ev = 0
    call equilibria_table(eqs, nd, q, p, hgt, en, gn, morse, rank1, lam, om, ev)
    nm = eqs%name
    isad = 0
    do k = 1, n
      if (nm(k) == want) then
        isad = k
        exit
      end if
    end do
    if (ball) then
      call rec%out('equilibria: ' // itoa(n) // ' critical points of H in |x|, |y| <= ' // num(box) // ' cm (' // &
                   num(wall() - t0, '.3f') // ' s)')
      call rec%out('  ' // ls('name', 4) // ' ' // rs('x [cm]', 13) // ' ' // rs('y [cm]', 13) // ' ' // &
                   rs('E [(cm/s)^2]', 13) // ' ' // rs('index', 5) // ' ' // rs('lambda[1/s]', 10) // ' ' // &
                   rs('omega[1/s]', 10) // ' ' // rs('T_po [s]', 8))
    else
      line = 'equilibria of ' // trim(label) // ': ' // itoa(n) // ' in the box'
      do i = 1, nd
        line = line // trim(merge(' x', '  ', i > 1)) // ' [' // num(lo(i)) // ', ' // num(hi(i)) // ']'
      end do
      call rec%out(line // ' (' // num(wall() - t0, '.3f') // ' s)')
      line = '  ' // ls('name', 4) // ' ' // rs('q1', 13) // ' ' // rs('', 13) // ' ' // rs('E', 13) // ' ' // &
             rs('index', 5) // ' ' // rs('lambda', 10) // ' ' // rs('omega', 10) // ' ' // rs('T_po', 8)
      if (nd > 1) line(22:34) = rs('q2', 13)
      if (nd > 2) line = line // '            q3     omega2'
      call rec%out(line)
    end if
    ! every equilibrium's centre frequencies and linear stability (wells, L4/L5: all centres)
    call centres_of(system, params, lo, hi, n_grid, stores, nc, fq, stab, stat)
    if (stat < 0 .or. nc /= n) then
      call rec%verdict(EXIT_NUMERIC, 'tubes: equilibria: the centre frequencies could not be computed')
      return
    end if
    allocate (xs(n), ys(n), oms(n), st2(n2, n))
    do k = 1, n
      xs(k) = q(1, k)
      ys(k) = nan_if(nd < 2, q(min(2, MAX_DOF), k))     ! 1 DOF: no second coordinate
      oms(k) = nan_if(nd < 2, om(1, k))
      st2(1:nd, k) = q(1:nd, k)
      st2(nd + 1:n2, k) = p(1:nd, k)
      ! a coordinate that prints as zero prints as 0, not -0
      yp = ''                      ! 1 DOF: no second coordinate, an empty column
      if (nd > 1) yp = num(zero_if(abs(ys(k)) < 5e-9_wp, ys(k)), '13.8f')
      line = '  ' // ls(trim(nm(k)), 4) // ' ' // num(zero_if(abs(xs(k)) < 5e-9_wp, xs(k)), '13.8f') // ' ' // &
             rs(yp, 13) // ' ' // num(zero_if(abs(en(k)) < 5e-7_wp, en(k)), '13.6f') // ' ' // rs(itoa(morse(k)), 5)
      if (rank1(k) == 1 .and. nd < 2) then        ! 1 DOF: a saddle without a centre
        line = line // ' ' // num(lam(k), '10.6f') // ' ' // rs('-', 10) // ' ' // rs('-', 8)
      else if (rank1(k) == 1) then
        line = line // ' ' // num(lam(k), '10.6f') // ' ' // num(oms(k), '10.6f') // ' ' // num(2*PI/oms(k), '8.6f')
      else if (rank1(k) == 2) then                ! degenerate: a zero frequency, no Lyapunov orbit
        line = line // ' ' // num(lam(k), '10.6f') // ' ' // num(0.0_wp, '10.6f') // ' ' // rs('-', 8)
      else if (stab(k) /= 0) then                 ! all centres (a well, L4/L5): the lowest frequency
        line = line // ' ' // rs('-', 10) // ' ' // num(fq(1, k), '10.6f') // ' ' // rs('-', 8)
      else
        line = line // ' ' // rs('-', 10) // ' ' // rs('-', 10) // ' ' // rs('-', 8)
      end if
      if (nd > 2 .and. rank1(k) >= 1) then        ! 3 DOF: the third coordinate and the second centre
        line = line // ' ' // num(zero_if(abs(q(3, k)) < 5e-9_wp, q(3, k)), '13.8f') // ' ' // num(om(2, k), '10.6f')
      else if (nd > 2) then
        line = line // ' ' // num(zero_if(abs(q(3, k)) < 5e-9_wp, q(3, k)), '13.8f') // ' ' // rs('-', 10)
      end if
      call rec%out(line)
    end do
    ! what the box may hide: an equilibrium on its face, wells beyond it
    call box_note(model, lo(1:nd), hi(1:nd), eqs, note)
    if (len_trim(note) > 0) call rec%err('tubes: equilibria: note: ' // trim(note))
    call rec%real('equilibria', 'x', xs, [n])
    call rec%real('equilibria', 'y', ys, [n])
    call rec%real('equilibria', 'state', reshape(st2, [n*n2]), [n, n2], 'state units')
    call rec%real('equilibria', 'height', hgt, [n])
    call rec%real('equilibria', 'energy', en, [n])
    call rec%real('equilibria', 'grad_norm', gn, [n])
    call rec%int('equilibria', 'morse_index', morse, [n])
    call rec%strings('equilibria', 'name', nm)
    call rec%real('equilibria', 'lambda', lam, [n])
    call rec%real('equilibria', 'omega', oms, [n])
    if (nd > 2) call rec%real('equilibria', 'omegas', reshape(om(1:nd - 1, :), [n*(nd - 1)]), [n, nd - 1])
    call rec%real('equilibria', 'frequencies', reshape(fq(1:nd, :), [n*nd]), [n, nd])
    call rec%int('equilibria', 'stable', stab, [n])
    ! each point's kind (1 a rank-1 saddle, 2 a degenerate one, 0 else) and its eigenvectors (as
    ! /saddle's, row i = component i; zero for a point that is not a saddle)
    call rec%int('equilibria', 'rank1', rank1, [n])
    allocate (eva(n2, n2, n))
    do k = 1, n
      eva(:, :, k) = transpose(reshape(ev(1:n2*n2, k), [n2, n2]))
    end do
    call rec%real('equilibria', 'eigenvectors', reshape(eva, [n*n2*n2]), [n, n2, n2])
    call rec%attr_real('equilibria', 'box', box)
    call rec%attr_int('equilibria', 'n_grid', n_grid)
    if (len_trim(note) > 0) call rec%attr_string('equilibria', 'box_note', trim(note))
    ! the saddle
    if (isad > 0) then
      if (rank1(isad) == 2) then
        call rec%out('saddle ' // trim(nm(isad)) // ': E_e = ' // num(tiny0(en(isad)), '.10g') // ', lambda = ' // &
                     num(lam(isad), '.10g') // ', degenerate (a centre frequency is 0: a mode without quadratic ' // &
                     'term): no Lyapunov orbits, no leading-order flux; the flux scene samples it')
        return
      end if
    end if
    if (isad > 0) then
      if (rank1(isad) == 0) isad = 0
    end if
    if (isad == 0) then
      if (.not. asked) then                       ! the default saddle, not asked for: none
        call rec%out('no rank-1 saddle named ' // trim(want) // ' in the box: /saddle is not written')
      else
        line = 'tubes: equilibria: saddle ' // trim(want) // ' is not a rank-1 saddle of ' // trim(label) // &
               ' in the &equilibria box (found:'
        do k = 1, n
          if (rank1(k) == 1) line = line // ' ' // trim(nm(k))
        end do
        call rec%verdict(EXIT_NUMERIC, line // ')')
      end if
      return
    end if
    k = isad
    omk = nan_if(nd < 2, om(1, k))                ! 1 DOF: no centre, no Lyapunov orbit (not 0, inf)
    if (ball) then
      call rec%out('saddle ' // trim(nm(k)) // ': E_e = ' // num(en(k), '.10g') // ' (cm/s)^2, lambda = ' // &
                   num(lam(k), '.10g') // ' 1/s, omega = ' // num(omk, '.10g') // ' rad/s, T_po = ' // &
                   num(2*PI/omk, '.10g') // ' s')
    else if (nd < 2) then
      call rec%out('saddle ' // trim(nm(k)) // ': E_e = ' // num(tiny0(en(k)), '.10g') // ', lambda = ' // &
                   num(lam(k), '.10g') // ' (1 degree of freedom: no centre, no Lyapunov orbit)')
    else
      call rec%out('saddle ' // trim(nm(k)) // ': E_e = ' // num(tiny0(en(k)), '.10g') // ', lambda = ' // &
                   num(lam(k), '.10g') // ', omega = ' // num(omk, '.10g') // ', T_po = ' // num(2*PI/omk, '.10g'))
    end if
    ! the eigenvectors, C order: row i = component i, columns u, s, Re c, Im c
    evr(1:n2, 1:n2) = reshape(ev(1:n2*n2, k), [n2, n2])
    call rec%attr_string('saddle', 'name', trim(nm(k)))
    call rec%attr_real('saddle', 'x', q(1, k))
    call rec%attr_real('saddle', 'y', nan_if(nd < 2, q(min(2, MAX_DOF), k)))
    call rec%attr_real('saddle', 'energy', en(k))
    call rec%attr_real('saddle', 'lambda', lam(k))
    call rec%attr_real('saddle', 'omega', omk)
    call rec%attr_real('saddle', 'T_po', 2*PI/omk)
    call rec%real('saddle', 'eigenvectors', reshape(transpose(evr(1:n2, 1:n2)), [n2*n2]), [n2, n2])
    if (len_trim(dissip) > 0) call dissipation_attrs(scene_dissipation(system, params), 'saddle', rec)
    if (len_trim(dissip) > 0) then                ! the damped saddle: its own spectrum (docs/dissipation.md)
      study%system = system
      study%params = 0
      study%params(1:size(params)) = params
      study%lo = 0
      study%hi = 0
      study%lo(1:size(lo)) = lo
      study%hi(1:size(hi)) = hi
      study%n_grid = n_grid
      study%saddle = nm(k)
      if (associated(stores)) then
        call damped_spectrum(study, wr, wi, cd, stat, stores)
      else
        call damped_spectrum(study, wr, wi, cd, stat)
      end if
      if (stat < 0) then
        call rec%verdict(EXIT_NUMERIC, "tubes: equilibria: the damped saddle's eigenvalues: " // &
                         status_message(stat) // ' (status ' // itoa(stat) // ')')
        return
      end if
      line = '  with its dissipation (' // trim(dissip) // ') its eigenvalues are'
      do i = n2, 1, -1
        if (wi(i) < 0) cycle
        if (wi(i) > 0) then
          line = line // ' ' // num(wr(i), '.8g') // ' +- ' // num(wi(i), '.8g') // ' i'
        else
          line = line // ' ' // num(wr(i), '.8g')
        end if
      end do
      call rec%out(line // ' (the conservative +-lambda, +-i omega above)')
      call rec%real('saddle', 'damped_eigenvalues', reshape(transpose(reshape([wr(1:n2), wi(1:n2)], [n2, 2])), &
                                                           [2*n2]), [n2, 2])
    end if
  end subroutine equilibria_scene_body

  pure real(wp) function zero_if(c, v)
    logical, intent(in) :: c
    real(wp), intent(in) :: v
    zero_if = v
    if (c) zero_if = 0
  end function zero_if

  !> v, or 0 for |v| < 1e-300 (an energy that prints as 0, not as a denormal)
  pure real(wp) function tiny0(v)
    real(wp), intent(in) :: v
    tiny0 = zero_if(abs(v) < 1e-300_wp, v)
  end function tiny0

  real(wp) function nan_if(c, v)
    use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
    logical, intent(in) :: c
    real(wp), intent(in) :: v
    nan_if = v
    if (c) nan_if = ieee_value(1.0_wp, ieee_quiet_nan)
  end function nan_if
end module tubes_scene_equilibria
