!> Continuation in a model parameter (the scan scene, docs/scan.md): as one parameter of the model
!> moves from its value to `to` in n equal steps, the equilibria (continued by Newton from the
!> previous step's positions, re-searched when a fold was passed), the chosen saddle's energy,
!> lambda and centre frequencies, and its Lyapunov orbits at the requested excess energies
!> (each corrected from the previous step's orbit); folds (an equilibrium meeting another and
!> disappearing, or its Jacobian's determinant changing sign) located by bisection. One core for
!> the C API (tubes_parameter_scan, the program's scan scene) and the f2py facade (Python's Model.scan).
module tubes_scan
  use, intrinsic :: iso_c_binding, only: c_char, c_int, c_long, c_double
  use tubes_cstrings, only: c_to_f, f_to_c
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
  use tubes_kinds, only: wp
  use tubes_status, only: TUBES_OK, TUBES_EINPUT
  use tubes_hamiltonian, only: hamiltonian_t
  use tubes_models, only: make_model, system_info, system_info_t, MAX_DOF, LEN_PARAM, LEN_SYSTEM
  use tubes_equilibria, only: equilibrium_t, find_equilibria, continue_equilibria, rest_jacobian
  use tubes_orbits, only: orbit_t, orbit_opts_t, orbit_family, correct_symmetric, correct_multiple, finish_orbit
  use tubes_study, only: study_t, de_floor, section_choice_t, cut_at, section_info
  use tubes_manifold, only: tube_opts_t, tube_cut_t
  use tubes_ensemble, only: progress_begin, progress_tick
  implicit none
  private

  integer, parameter, public :: SCAN_MAXEQ = 64     !! equilibria per step at most (more: TUBES_EINPUT)
  integer, parameter, public :: SCAN_MAXFOLD = 32   !! folds recorded at most (more are counted)
  integer, parameter, public :: SCAN_MAXSTEPS = 100000  !! n at most
  integer, parameter, public :: FOLD_MEET = 1       !! two equilibria meet and disappear
  integer, parameter, public :: FOLD_INDEX = 2      !! the determinant changes sign, no partner lost
  integer, parameter, public :: FOLD_BOX = 3        !! not a fold: it leaves the search box (lost
                                                    !! within 1e-3 of the box's width of a face)
  !> the bisection's bracket: width <= SCAN_FOLD_TOL |to - from|
  real(wp), parameter, public :: SCAN_FOLD_TOL = 1.0e-13_wp
  !> a formula's constant k (the k-th given as a number) is the scan's parameter SCAN_CONSTANT + k
  integer, parameter, public :: SCAN_CONSTANT = 1000
  integer, parameter :: MAX_CONSTANTS = 64          !! constants listed at most (the reader takes fewer)

  public :: scan_table, scan_parameter, scan_index, scan_start, formula_with_constant

  ! src/io/tubes_expr.c (include/tubes.h): a formula model's constants
  interface
    integer(c_int) function expr_constant(key, name, value) bind(C, name='tubes_expr_constant')
      import :: c_int, c_char, c_double
      character(kind=c_char), intent(in) :: key(*), name(*)
      real(c_double), intent(out) :: value
    end function expr_constant
    integer(c_int) function expr_constant_names(key, buf, len) bind(C, name='tubes_expr_constant_names')
      import :: c_int, c_char
      character(kind=c_char), intent(in) :: key(*)
      character(kind=c_char), intent(out) :: buf(*)
      integer(c_int), value :: len
    end function expr_constant_names
    integer(c_int) function expr_with_constant(key, name, value, newkey, msg, lmsg) &
        bind(C, name='tubes_expr_with_constant')
      import :: c_int, c_char, c_double
      character(kind=c_char), intent(in) :: key(*), name(*)
      real(c_double), value :: value
      character(kind=c_char), intent(out) :: newkey(*), msg(*)
      integer(c_int), value :: lmsg
    end function expr_with_constant
  end interface

contains

  !> The index of parameter `name` of system in the parameter vector (table order), 0 if the
  !> system has no such parameter or it is one of dissipation (damping_ratio, rolling_resistance,
  !> noise, temperature: the scan follows the conservative model); allowed: the parameters a scan
  !> takes, blank-separated (for the message that refuses another name). A formula model's
  !> constants given as numbers are taken too (SCAN_CONSTANT + k for the k-th of them): each
  !> step's model is the library of the formula with that constant's value (docs/scan.md).
  subroutine scan_parameter(system, name, ipar, allowed)
    character(*), intent(in) :: system, name
    integer, intent(out) :: ipar
    character(*), intent(out) :: allowed
    ipar = scan_index(system, name, allowed)
  end subroutine scan_parameter

  !> scan_parameter's index (allowed: as scan_parameter's).
  integer function scan_index(system, name, allowed) result(ipar)
    character(*), intent(in) :: system, name
    character(*), intent(out) :: allowed
    type(system_info_t) :: info
    integer :: k, stat
    character(len(allowed)) :: a
    ipar = 0
    a = ''
    call system_info(system, info, stat)
    do k = 1, merge(info%np, 0, stat == TUBES_OK)
      ! dissipation: the scan's equilibria and orbits are the conservative model's
      if (any(info%params(k)%name == [character(LEN_PARAM) :: 'damping_ratio', 'rolling_resistance', 'noise', &
                                      'temperature'])) cycle
      if (info%params(k)%name == name) ipar = k
      a = trim(a) // ' ' // trim(info%params(k)%name)
    end do
    if (stat == TUBES_OK .and. system(1:min(5, len(system))) == 'expr_') then
      block
        character(len=1024) :: names
        integer :: j
        names = constant_names(system)
        do j = 1, MAX_CONSTANTS
          if (len_trim(word(names, j)) == 0) exit
          if (word(names, j) == name .and. ipar == 0) ipar = SCAN_CONSTANT + j
          a = trim(a) // ' ' // trim(word(names, j))
        end do
      end block
    end if
    allowed = adjustl(a)
  end function scan_index

  !> The names of the formula model system's constants given as numbers, blank-separated.
  function constant_names(system) result(names)
    character(*), intent(in) :: system
    character(len=1024) :: names
    character(kind=c_char) :: key(LEN_SYSTEM + 1), buf(1024)
    call f_to_c(system, key)
    names = ''
    if (expr_constant_names(key, buf, size(buf)) == TUBES_OK) names = c_to_f(buf)
  end function constant_names

  !> The j-th blank-separated word of s ('' if none).
  pure function word(s, j) result(w)
    character(*), intent(in) :: s
    integer, intent(in) :: j
    character(len=64) :: w
    integer :: i, k, b
    w = ''
    i = 1
    do k = 1, j
      do while (i <= len(s))
        if (s(i:i) /= ' ') exit
        i = i + 1
      end do
      if (i > len(s)) return
      b = index(s(i:), ' ')
      if (b == 0) b = len(s) - i + 2
      if (k == j) w = s(i:i + b - 2)
      i = i + b - 1
    end do
  end function word

  !> The start value p0 of the scan's parameter ipar in study st: st%params(ipar), or the value of
  !> the formula's constant (ipar > SCAN_CONSTANT). stat: TUBES_EINPUT if there is none.
  subroutine scan_start(st, ipar, p0, stat)
    type(study_t), intent(in) :: st
    integer, intent(in) :: ipar
    real(wp), intent(out) :: p0
    integer, intent(out) :: stat
    character(kind=c_char) :: key(LEN_SYSTEM + 1), cname(65)
    real(c_double) :: v
    p0 = 0
    stat = TUBES_EINPUT
    if (ipar >= 1 .and. ipar <= size(st%params)) then
      p0 = st%params(ipar)
      stat = TUBES_OK
    else if (ipar > SCAN_CONSTANT) then
      call f_to_c(trim(st%system), key)
      call f_to_c(trim(word(constant_names(trim(st%system)), ipar - SCAN_CONSTANT)), cname)
      if (expr_constant(key, cname, v) /= TUBES_OK) return
      p0 = v
      stat = TUBES_OK
    end if
  end subroutine scan_start

  !> The sign of det(a) (-1, 0 or 1), by Gaussian elimination with partial pivoting.
  pure integer function det_sign(a) result(s)
    real(wp), intent(in) :: a(:, :)
    real(wp) :: m(size(a, 1), size(a, 1)), row(size(a, 1))
    integer :: n, k, p, i
    n = size(a, 1)
    m = a
    s = 1
    do k = 1, n
      p = k - 1 + maxloc(abs(m(k:n, k)), 1)
      if (m(p, k) == 0) then
        s = 0
        return
      end if
      if (p /= k) then
        row = m(k, :)
        m(k, :) = m(p, :)
        m(p, :) = row
        s = -s
      end if
      if (m(k, k) < 0) s = -s
      do i = k + 1, n
        m(i, k + 1:n) = m(i, k + 1:n) - m(i, k)/m(k, k)*m(k, k + 1:n)
      end do
    end do
  end function det_sign

  !> The sign of the determinant of the linearised flow at the equilibrium e (0 if it failed).
  integer function eq_det_sign(model, e) result(s)
    class(hamiltonian_t), intent(in) :: model
    type(equilibrium_t), intent(in) :: e
    real(wp) :: jac(size(e%x), size(e%x))
    integer :: stat
    call rest_jacobian(model, e%x, jac, stat)
    s = 0
    if (stat == TUBES_OK) s = det_sign(jac)
  end function eq_det_sign

  !> The parameter scan of study st: parameter ipar (table order) from st%params(ipar) to `to` in
  !> n steps (n + 1 parameter values, value(1) the start), the saddle st%saddle's data and its
  !> Lyapunov orbits at the excess energies des (ascending, > 0) with the options opts. Column k
  !> of each table is step k - 1 (tables sized for n + 1 steps, SCAN_MAXEQ equilibria, MAX_DOF
  !> coordinates; NaN (reals), -1 (indices) or 0 where there is nothing):
  !>   n_eq, researched (1: the step's equilibria from a new search, after a fold or a failed
  !>   continuation), eq_q, eq_energy, eq_index (the index: eigenvalues with Re > 0), eq_name
  !>   (ASCII codes, blank-padded to 8), eq_det (the sign of the Jacobian's determinant);
  !>   saddle_found, saddle_q, saddle_energy, lambda, omega (N - 1 centre frequencies);
  !>   period, action, stability (the orbits' stability index), converged (1), restarted (1:
  !>   continued in energy from the saddle, as the orbits scene, not corrected from the previous
  !>   step's orbit: the first step, a step searched anew, or where the correction failed).
  !> Folds: n_fold (all found; the first SCAN_MAXFOLD are recorded), fold_step (between steps
  !> fold_step - 1 and fold_step, 1-based columns), fold_value (the bracket's midpoint),
  !> fold_width, fold_kind (FOLD_MEET, FOLD_INDEX or FOLD_BOX), fold_q (the equilibrium at the bracket's
  !> good end), fold_name, fold_partner (names as eq_name: the equilibrium it meets, the nearest
  !> other at the bracket's good end). stat: TUBES_EINPUT for bad arguments (ipar, n, to equal
  !> to the start, a model refused at a step's value), else the first failure's status.
  !> p_trans (optional, with sec, topts, a_tube, a_e and p_stat): at each step and each dE of des,
  !> the transition scene's p_trans = A_tube/A_E at the step's parameters (cut_at with the tube
  !> options topts on the section sec, section_info: the calls of a direct run, from the saddle
  !> found anew and its family continued in energy, so a step's numbers are those of the
  !> transition scene run at its value); a_tube, a_e the areas, p_stat the cut's status (else the
  !> energy surface's; 0: both worked; TUBES_EINPUT where the step has no saddle). NaN where
  !> either failed.
  subroutine scan_table(st, ipar, to, n, des, opts, value, n_eq, researched, eq_q, eq_energy, eq_index, eq_name, &
                        eq_det, saddle_found, saddle_q, saddle_energy, lambda, omega, period, action, stability, &
                        converged, restarted, n_fold, fold_step, fold_value, fold_width, fold_kind, fold_q, &
                        fold_name, fold_partner, stat, sec, topts, a_tube, a_e, p_trans, p_stat)
    type(study_t), intent(in) :: st
    integer, intent(in) :: ipar, n
    real(wp), intent(in) :: to, des(:)
    type(orbit_opts_t), intent(in) :: opts
    real(wp), intent(out) :: value(:), eq_q(:, :, :), eq_energy(:, :), saddle_q(:, :), saddle_energy(:), &
                             lambda(:), omega(:, :), period(:, :), action(:, :), stability(:, :), &
                             fold_value(:), fold_width(:), fold_q(:, :)
    integer, intent(out) :: n_eq(:), researched(:), eq_index(:, :), eq_name(:, :, :), eq_det(:, :), &
                            saddle_found(:), converged(:, :), restarted(:, :), n_fold, fold_step(:), &
                            fold_kind(:), fold_name(:, :), fold_partner(:, :), stat
    type(section_choice_t), intent(in), optional :: sec
    type(tube_opts_t), intent(in), optional :: topts
    real(wp), intent(out), optional :: a_tube(:, :), a_e(:, :), p_trans(:, :)
    integer, intent(out), optional :: p_stat(:, :)
    class(hamiltonian_t), allocatable :: model
    type(equilibrium_t), allocatable :: eqs(:), prev(:)
    type(orbit_t), allocatable :: orbs(:), prev_orbs(:)
    real(wp) :: params(size(st%params)), nan, p0, v
    integer, allocatable :: origin(:), sgn(:)
    integer :: nd, k, i, isad, ns
    logical :: want_p
    character(LEN_SYSTEM) :: sys          ! the step's model (a formula's constant: its own library)
    nan = ieee_value(1.0_wp, ieee_quiet_nan)
    value = nan; eq_q = nan; eq_energy = nan; saddle_q = nan; saddle_energy = nan; lambda = nan; omega = nan
    period = nan; action = nan; stability = nan; fold_value = nan; fold_width = nan; fold_q = nan
    n_eq = 0; researched = 0; eq_index = -1; eq_name = ichar(' '); eq_det = 0; saddle_found = 0; converged = 0
    restarted = 0; n_fold = 0; fold_step = 0; fold_kind = 0; fold_name = ichar(' '); fold_partner = ichar(' ')
    want_p = present(p_trans)
    if (want_p) then
      want_p = present(sec) .and. present(topts) .and. present(a_tube) .and. present(a_e) .and. present(p_stat)
      stat = TUBES_EINPUT
      if (.not. want_p) return
      p_trans = nan; a_tube = nan; a_e = nan; p_stat = TUBES_EINPUT
      if (size(p_trans, 1) < size(des) .or. size(p_trans, 2) < n + 1 .or. any(shape(a_tube) /= shape(p_trans)) .or. &
          any(shape(a_e) /= shape(p_trans)) .or. any(shape(p_stat) /= shape(p_trans))) return
    end if
    stat = TUBES_EINPUT
    if (n < 1 .or. n > SCAN_MAXSTEPS) return
    if (size(value) < n + 1 .or. size(period, 1) < size(des) .or. size(period, 2) < n + 1) return
    if (.not. (abs(to) <= huge(1.0_wp))) return
    call scan_start(st, ipar, p0, stat)
    if (stat /= TUBES_OK) return
    stat = TUBES_EINPUT
    if (to == p0) return
    do k = 2, size(des)
      if (.not. des(k) > des(k - 1)) return
    end do
    if (any(.not. (des > 0))) return
    params = st%params
    allocate (orbs(size(des)), prev_orbs(size(des)))
    call progress_begin('scan' // achar(0), 4)
    do i = 1, n + 1
      v = p0 + (to - p0)*real(i - 1, wp)/n
      if (i == n + 1) v = to                 ! the end value exactly: the direct run's bits
      value(i) = v
      call model_at(v, params, sys, model, stat)
      if (stat /= TUBES_OK) then
        stat = TUBES_EINPUT                  ! the model refuses this value (alpha <= 0, ...)
        return
      end if
      nd = model%ndof()
      if (i == 1) then
        call find_equilibria(model, st%lo(1:nd), st%hi(1:nd), st%n_grid, eqs, stat)
        if (stat /= TUBES_OK) return
      else
        call step_equilibria(i, stat)
        if (stat /= TUBES_OK) return
      end if
      if (size(eqs) > SCAN_MAXEQ .or. size(eqs) > size(eq_energy, 1)) then
        stat = TUBES_EINPUT
        return
      end if
      allocate (sgn(size(eqs)))
      do k = 1, size(eqs)
        sgn(k) = eq_det_sign(model, eqs(k))
      end do
      call record_equilibria(i)
      ! the saddle, by name as the direct run chooses it
      isad = 0
      do k = 1, size(eqs)
        if (eqs(k)%name == st%saddle .and. eqs(k)%rank1) isad = k
      end do
      ! after a new search the names are the search's: the orbits start afresh from the saddle
      if (researched(i) == 1) prev_orbs = orbit_t()
      if (isad > 0) then
        saddle_found(i) = 1
        saddle_q(1:nd, i) = eqs(isad)%q
        saddle_energy(i) = eqs(isad)%energy
        lambda(i) = eqs(isad)%lambda
        if (nd > 1) omega(1:nd - 1, i) = eqs(isad)%omegas(1:nd - 1)
        if (size(des) > 0) call step_orbits(i)
        if (want_p) call step_p_trans(i)
      else
        prev_orbs = orbit_t()                ! no saddle: the next orbits start afresh
      end if
      prev = eqs
      deallocate (sgn)
      call progress_tick(int(i, c_long), int(n + 1, c_long))
    end do
    stat = TUBES_OK
  contains

    !> The model at parameter value v: p(ipar) = v and make_model of st's system, or (a formula's
    !> constant) the library of st's formula with the constant set to v (tubes_expr_with_constant:
    !> built or loaded from the cache); sy its system name.
    subroutine model_at(v, p, sy, m, stat)
      real(wp), intent(in) :: v
      real(wp), intent(inout) :: p(:)
      character(LEN_SYSTEM), intent(out) :: sy
      class(hamiltonian_t), allocatable, intent(out) :: m
      integer, intent(out) :: stat
      character(2048) :: msg
      sy = st%system
      if (ipar <= size(p)) then
        p(ipar) = v
      else
        call formula_with_constant(trim(st%system), trim(word(constant_names(trim(st%system)), ipar - SCAN_CONSTANT)), &
                                   v, sy, msg, stat)
        if (stat /= TUBES_OK) return
      end if
      call make_model(trim(sy), p, m, stat)
    end subroutine model_at

    !> Step i's p_trans at each dE: the transition scene's calls (a direct run's) at the step's
    !> parameters, the orbit options of opts (as the study's: n_segments, tol, rtol, atol, the
    !> integrator; family 1).
    subroutine step_p_trans(i)
      integer, intent(in) :: i
      type(study_t) :: sp
      type(tube_cut_t) :: cut
      type(orbit_t) :: orb
      real(wp) :: smin, smax, area, darea
      integer :: j, sc, se
      sp = st
      sp%system = sys
      sp%params = params
      sp%n_segments = opts%n_segments
      sp%orb_tol = opts%tol
      sp%orb_rtol = opts%rtol
      sp%orb_atol = opts%atol
      sp%integ = opts%integ
      sp%family = 1
      do j = 1, size(des)
        call cut_at(sp, sec, des(j), topts, cut, orb, sc)
        if (sc >= TUBES_OK) a_tube(j, i) = cut%area
        call section_info(sp, sec, des(j), smin, smax, area, darea, se)
        if (se >= TUBES_OK) a_e(j, i) = area
        p_stat(j, i) = merge(min(se, TUBES_OK), sc, sc >= TUBES_OK)
        if (sc >= TUBES_OK .and. se >= TUBES_OK) p_trans(j, i) = cut%area/area
      end do
    end subroutine step_p_trans

    !> Step i's equilibria: continued from prev's positions; where one was lost, met another or
    !> changed the sign of its determinant, the fold located and the step's equilibria searched
    !> anew (researched).
    subroutine step_equilibria(i, stat)
      integer, intent(in) :: i
      integer, intent(out) :: stat
      real(wp), allocatable :: starts(:, :)
      logical, allocatable :: bad(:)
      integer :: k, psgn(size(prev))
      allocate (starts(nd, size(prev)), bad(size(prev)))
      do k = 1, size(prev)
        starts(:, k) = prev(k)%q
        psgn(k) = eq_det(k, i - 1)
      end do
      call continue_equilibria(model, st%lo(1:nd), st%hi(1:nd), st%n_grid, starts, eqs, origin, stat)
      if (stat /= TUBES_OK) return
      do k = 1, size(prev)
        bad(k) = .not. good_with(model, k, eqs, origin, psgn)
      end do
      if (.not. any(bad)) return
      do k = 1, size(prev)
        if (bad(k)) call locate_fold(i, k, psgn, stat)
        if (stat /= TUBES_OK) return
      end do
      researched(i) = 1
      ! the model at step i again (locate_fold made others) and a new search
      call make_model(trim(sys), params, model, stat)
      if (stat /= TUBES_OK) return
      call find_equilibria(model, st%lo(1:nd), st%hi(1:nd), st%n_grid, eqs, stat)
    end subroutine step_equilibria

    !> The fold of prev(k) between steps i - 1 and i, by bisection on good_at (positions
    !> continued from the bracket's good end), recorded unless it is the fold of a partner
    !> already recorded.
    subroutine locate_fold(i, k, psgn, stat)
      integer, intent(in) :: i, k, psgn(:)
      integer, intent(out) :: stat
      class(hamiltonian_t), allocatable :: m
      type(equilibrium_t), allocatable :: e(:)
      integer, allocatable :: org(:)
      real(wp) :: lo_v, hi_v, mid, qlo(nd, size(prev)), pm(size(params)), d, best
      integer :: j, jp, kind, it, jmeet
      character(LEN_SYSTEM) :: sm
      lo_v = value(i - 1)
      hi_v = value(i)
      do j = 1, size(prev)
        qlo(:, j) = prev(j)%q
      end do
      pm = params
      kind = FOLD_INDEX
      jmeet = 0
      do it = 1, 200
        if (abs(hi_v - lo_v) <= SCAN_FOLD_TOL*abs(to - p0)) exit
        mid = 0.5_wp*(lo_v + hi_v)
        call model_at(mid, pm, sm, m, stat)
        if (stat /= TUBES_OK) then
          stat = TUBES_EINPUT
          return
        end if
        call continue_equilibria(m, st%lo(1:nd), st%hi(1:nd), st%n_grid, qlo, e, org, stat)
        if (stat /= TUBES_OK) return
        if (good_with(m, k, e, org, psgn)) then
          lo_v = mid
          do j = 1, size(prev)
            if (org(j) > 0) qlo(:, j) = e(org(j))%q
          end do
        else
          hi_v = mid
          kind = FOLD_INDEX
          jmeet = 0
          if (org(k) == 0) then
            kind = FOLD_MEET
          else if (count(org == org(k)) > 1) then
            kind = FOLD_MEET
            do j = 1, size(prev)
              if (j /= k .and. org(j) == org(k) .and. jmeet == 0) jmeet = j
            end do
          end if
        end if
      end do
      if (kind == FOLD_MEET .and. jmeet == 0 .and. &
          any(min(qlo(:, k) - st%lo(1:nd), st%hi(1:nd) - qlo(:, k)) <= 1.0e-3_wp*(st%hi(1:nd) - st%lo(1:nd)))) &
        kind = FOLD_BOX                      ! lost at a face of the box: it left the box
      ! the partner: the one it met at the bracket's bad end, else the nearest other at the good end
      jp = jmeet
      best = huge(1.0_wp)
      do j = 1, size(prev)
        if (j == k .or. jmeet > 0) cycle
        d = sqrt(sum((qlo(:, j) - qlo(:, k))**2))
        if (d < best) then
          best = d
          jp = j
        end if
      end do
      ! the same fold seen from its partner: recorded once
      do j = 1, min(n_fold, size(fold_value))
        if (jp > 0 .and. fold_step(j) == i .and. same_name(fold_name(:, j), prev(jp)%name) .and. &
            same_name(fold_partner(:, j), prev(k)%name)) then
          stat = TUBES_OK
          return
        end if
      end do
      n_fold = n_fold + 1
      stat = TUBES_OK
      if (n_fold > size(fold_value)) return
      fold_step(n_fold) = i
      fold_value(n_fold) = 0.5_wp*(lo_v + hi_v)
      fold_width(n_fold) = abs(hi_v - lo_v)
      fold_kind(n_fold) = kind
      fold_q(1:nd, n_fold) = qlo(:, k)
      call put_name(prev(k)%name, fold_name(:, n_fold))
      if (jp > 0 .and. kind /= FOLD_BOX) call put_name(prev(jp)%name, fold_partner(:, n_fold))
    end subroutine locate_fold

    !> Is prev(k) continued into e (its start's origin org(k)) as itself: found, met by no other
    !> start, and its determinant's sign psgn(k) unchanged?
    logical function good_with(m, k, e, org, psgn) result(ok)
      class(hamiltonian_t), intent(in) :: m
      integer, intent(in) :: k, org(:), psgn(:)
      type(equilibrium_t), intent(in) :: e(:)
      ok = org(k) > 0
      if (.not. ok) return
      ok = count(org == org(k)) == 1
      if (.not. ok) return
      ok = eq_det_sign(m, e(org(k))) == psgn(k)
    end function good_with

    subroutine record_equilibria(i)
      integer, intent(in) :: i
      integer :: k
      n_eq(i) = size(eqs)
      do k = 1, size(eqs)
        eq_q(1:nd, k, i) = eqs(k)%q
        eq_energy(k, i) = eqs(k)%energy
        eq_index(k, i) = eqs(k)%morse
        eq_det(k, i) = sgn(k)
        call put_name(eqs(k)%name, eq_name(:, k, i))
      end do
    end subroutine record_equilibria

    !> Step i's orbits: each corrected from the previous step's orbit at its dE (single shooting
    !> where the model has a reversor and opts ask for it, else multiple shooting from the previous
    !> orbit's samples), else (the first step, no previous orbit, or a failed correction) the
    !> family continued in energy from the saddle as the orbits scene does (restarted).
    subroutine step_orbits(i)
      integer, intent(in) :: i
      type(orbit_t) :: fam(size(des))
      real(wp) :: x0(2*nd), tau, end_de, per
      real(wp), allocatable :: nodes(:, :)
      integer :: j, reason, s, nsg, l, need
      logical :: again(size(des))
      again = .true.
      do j = 1, size(des)
        if (.not. allocated(prev_orbs(j)%x0)) cycle
        if (.not. prev_orbs(j)%converged .or. size(prev_orbs(j)%x0) /= 2*nd) cycle
        orbs(j) = orbit_t(de=des(j))
        s = TUBES_EINPUT
        if (opts%n_segments <= 1) then
          x0 = prev_orbs(j)%x0
          tau = prev_orbs(j)%period/2
          call correct_symmetric(model, eqs(isad)%energy + des(j), des(j), x0, tau, opts, orbs(j), s)
        end if
        if (s == TUBES_EINPUT) then        ! multiple shooting, or no reversor
          nsg = max(opts%n_segments, 2)
          ns = size(prev_orbs(j)%t)
          allocate (nodes(2*nd, nsg))
          do l = 1, nsg
            nodes(:, l) = prev_orbs(j)%x(:, 1 + ((l - 1)*(ns - 1))/nsg)
          end do
          per = prev_orbs(j)%period
          call correct_multiple(model, eqs(isad)%energy + des(j), des(j), nodes, per, opts, orbs(j), s)
          deallocate (nodes)
        end if
        orbs(j)%de = des(j)
        if (s == TUBES_OK) call finish_orbit(model, orbs(j), opts, eqs, isad, s)
        again(j) = s /= TUBES_OK .or. .not. orbs(j)%converged
      end do
      need = count(again)
      if (need > 0) then
        call orbit_family(model, eqs, isad, pack(des, again), opts, fam(1:need), end_de, reason, s)
        if (s == TUBES_OK) then
          l = 0
          do j = 1, size(des)
            if (.not. again(j)) cycle
            l = l + 1
            orbs(j) = fam(l)
            restarted(j, i) = 1
          end do
        end if
      end if
      do j = 1, size(des)
        prev_orbs(j) = orbs(j)
        if (.not. orbs(j)%converged) cycle
        if (abs(des(j)) < de_floor(eqs(isad)%energy)) cycle
        converged(j, i) = 1
        period(j, i) = orbs(j)%period
        action(j, i) = orbs(j)%action
        stability(j, i) = orbs(j)%stability_index
      end do
    end subroutine step_orbits
  end subroutine scan_table

  !> name as ASCII codes, blank-padded to size(codes).
  pure subroutine put_name(name, codes)
    character(*), intent(in) :: name
    integer, intent(out) :: codes(:)
    integer :: k
    codes = ichar(' ')
    do k = 1, min(len_trim(name), size(codes))
      codes(k) = ichar(name(k:k))
    end do
  end subroutine put_name

  pure logical function same_name(codes, name)
    integer, intent(in) :: codes(:)
    character(*), intent(in) :: name
    integer :: c(size(codes))
    call put_name(name, c)
    same_name = all(c == codes)
  end function same_name

  !> The library of the formula model `system` with its constant `name` set to v, built or loaded
  !> from the cache (include/tubes.h tubes_expr_with_constant): its system name in sy; on failure
  !> stat < 0 and the reason in msg.
  subroutine formula_with_constant(system, name, v, sy, msg, stat)
    character(*), intent(in) :: system, name
    real(wp), intent(in) :: v
    character(*), intent(out) :: sy, msg
    integer, intent(out) :: stat
    character(kind=c_char) :: key(LEN_SYSTEM + 1), cname(65), newkey(LEN_SYSTEM + 1), cmsg(2048)
    call f_to_c(system, key)
    call f_to_c(name, cname)
    stat = expr_with_constant(key, cname, v, newkey, cmsg, size(cmsg))
    sy = c_to_f(newkey)
    msg = c_to_f(cmsg)
  end subroutine formula_with_constant
end module tubes_scan
