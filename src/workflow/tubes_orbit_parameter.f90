!> Orbits of a family asked for by Jacobi constant or by period instead of dE (docs/orbits.md,
!> "Orbits by Jacobi constant or period"; &orbits jacobi, periods): each value becomes the excess
!> energy dE of its orbit, and the orbits are then those of that dE (family_at, bit for bit the
!> orbits of `de` = those energies).
!>
!> - Jacobi constant C: dE = E(C) - E_e with E(C) the model's (energy_of_jacobi: the CR3BP's
!>   C = -2 H); a model without a Jacobi constant is refused (PARAM_NOJACOBI).
!> - Period T of a saddle's Lyapunov family (opts%family 1..N-1, or 'vertical' / 'lyapunov' by
!>   name): the family is parametrised by dE; T(dE) is followed from the saddle's limit
!>   T_po = 2 pi / omega (dE -> 0) upwards on the grid dE_1 2^j (dE_1: the linear orbit's amplitude
!>   1e-3 of the distance to the nearest other equilibrium), each T an orbit of the family at that
!>   energy alone, to the first grid interval where T - T* changes sign (the first crossing from the
!>   saddle; a T that passes T* and comes back inside one grid interval is not seen); where the
!>   family ends first, the interval up to its end is searched on 30 points that close in on it.
!>   In the bracket, GSL's Brent (tubes_quad quad_root) on T(dE) - T* to |bracket| <= 1e-14 dE;
!>   the orbit at the root must have |T - T*| <= PERIOD_RTOL T* (else PARAM_NOCONV). A period the
!>   family does not reach between T_po and its end: PARAM_NOT_REACHED.
!> - Period T of a family that starts away from the saddle (period_de_away): a halo family
!>   ('halo_north', 'halo_south'), the axial family, a guess's family. Its T(dE) is probed on its own
!>   continuation (each probe the orbit `de` = that dE gives: the first crossing of that energy along
!>   the family's arc) once for all the periods asked for: the halo and axial families from dE_1 2^j
!>   up (below their branch point there is no orbit) to their end (where a doubling jumps over the
!>   whole family, points from below it that close in on the end the family said), a guess's family
!>   from the guess's energy dE_g on dE_g +- delta 2^j (delta = 1e-3 |dE_g|) both ways to its ends;
!>   where a period is not bracketed, each end of the probed range is closed in on (bisection,
!>   CLOSE_AWAY steps; CLOSE_FOLD points towards a fold in energy). Every interval of the probes
!>   where T - T* changes sign is a crossing; the one nearest the family's start (the lowest dE for a
!>   branch, the one nearest dE_g for a guess) is solved by Brent as above, and the number of the
!>   others and the nearest other's dE are returned (a fold in T(dE): one period, two orbits; the
!>   scene says so). 'branch:K' is refused (TUBES_EINPUT): its K counts the parent's bifurcations
!>   between the requested energies, which periods do not give.
module tubes_orbit_parameter
  use, intrinsic :: iso_c_binding, only: c_double, c_ptr, c_loc, c_f_pointer, c_funloc
  use tubes_kinds, only: wp, PI
  use tubes_status, only: TUBES_OK, TUBES_EINPUT, TUBES_ENOCONV, TUBES_EUNRESOLVED
  use tubes_hamiltonian, only: hamiltonian_t, energy_of_jacobi
  use tubes_equilibria, only: equilibrium_t
  use tubes_orbits, only: orbit_t, orbit_opts_t, linear_guess, named_mode, FAMILY_VERTICAL, FAMILY_PLANAR, &
                          FAMILY_BRANCH_PLUS, FAMILY_BRANCH_MINUS, FAMILY_AXIAL
  use tubes_study, only: study_t, seed_stores_t, setup_model, family_at
  use tubes_quad, only: quad_root
  implicit none
  private

  integer, parameter, public :: PARAM_DE = 0, PARAM_JACOBI = 1, PARAM_PERIOD = 2   !! which parameter
  !> per value: its dE found; the family does not reach it; the root finder or the orbit at the root
  !> failed; the model has no Jacobi constant
  integer, parameter, public :: PARAM_FOUND = 0, PARAM_NOT_REACHED = 1, PARAM_NOCONV = 2, PARAM_NOJACOBI = 3
  real(wp), parameter, public :: PERIOD_RTOL = 1.0e-12_wp   !! |T - T*| <= PERIOD_RTOL T* at the root
  real(wp), parameter :: BRENT_XTOL = 1.0e-14_wp            !! Brent's bracket, relative to dE
  real(wp), parameter :: GRID_AMP = 1.0e-3_wp               !! the grid's first dE: this linear amplitude
  integer, parameter :: GRID_MAX = 200, CLOSE_IN = 30
  !> a family away from the saddle: the points that close in on an end that is a fold in energy (the
  !> last 2^-CLOSE_FOLD of the interval is left out: there the orbit at a fixed energy is
  !> ill-conditioned, and at L1's halo fold the corrector took the far side 1.6e-6 from it)
  integer, parameter :: CLOSE_FOLD = 12
  integer, parameter :: CLOSE_AWAY = 20      !! ... bisection steps on an end's probes (2^-20 of the interval)
  integer, parameter :: MAX_DOUBLINGS = 48   !! a branch not met by dE_1 2^MAX_DOUBLINGS: none
  real(wp), parameter :: GUESS_STEP = 1.0e-3_wp             !! a guess's family: the first probe step / |dE_g|

  !> The family whose period is sought (the root finder's user data).
  type :: period_ctx_t
    type(study_t) :: st
    class(hamiltonian_t), allocatable :: model
    type(equilibrium_t), allocatable :: eqs(:)
    integer :: isad = 0
    type(orbit_opts_t) :: opts
    type(seed_stores_t), pointer :: stores => null()
    real(wp) :: target = 0, t_po = 0
    integer :: stat = TUBES_OK
    logical :: away = .false.   !! a family that starts away from the saddle: no T_po at dE <= 0
    real(wp) :: off_branch = -1 !! a probe's dE whose orbit the corrector took off its branch (-1: none)
  end type period_ctx_t

  !> A family's T(dE) probed along its continuation (period_de_away): the converged probes, dE ascending.
  type :: probes_t
    real(wp), allocatable :: de(:), t(:)
    real(wp) :: de_start = 0      !! the family's start: its lowest probe (a branch) or dE_g (a guess)
    logical :: closed = .false.   !! the ends closed in on
    real(wp) :: lo_fail = 0, hi_fail = 0, hi_end = -1   !! the nearest probes without an orbit, the family's end
    logical :: has_lo = .false., has_hi = .false.
  end type probes_t

  public :: family_parameter_des

contains

  !> The excess energies des(k) of the orbits of the study's family (opts) at values(k), a Jacobi
  !> constant (kind PARAM_JACOBI) or a period (PARAM_PERIOD); found(k) one of PARAM_FOUND, ...
  !> (des(k) = 0 where not PARAM_FOUND). t_po: the saddle's limit 2 pi / omega of the family (a
  !> family away from the saddle: the period of its probe nearest its start); t_reach, de_reach:
  !> where the period search went furthest (the last converged orbit before the family's end; 0 for
  !> Jacobi); e_saddle: E_e. A family away from the saddle (a halo, the axial family, a guess's):
  !> n_again(k) the crossings of values(k) other than the one taken (a fold in T(dE)), de_again(k)
  !> the nearest other's dE (the middle of its probes' interval; 0 if none), span the probes' lowest
  !> and highest dE and their least and greatest period (0 for a Lyapunov family). stat < 0: the
  !> study could not be set up, or the family or kind is not one this takes (TUBES_EINPUT).
  subroutine family_parameter_des(st, opts, kind, values, des, found, t_po, t_reach, de_reach, e_saddle, stat, &
                                  stores, n_again, de_again, span)
    type(study_t), intent(in) :: st
    type(orbit_opts_t), intent(in) :: opts
    integer, intent(in) :: kind
    real(wp), intent(in) :: values(:)
    real(wp), intent(out) :: des(size(values)), t_po, t_reach, de_reach, e_saddle
    integer, intent(out) :: found(size(values)), stat
    type(seed_stores_t), intent(inout), target, optional :: stores
    integer, intent(out), optional :: n_again(size(values))    !! a period's other crossings
    real(wp), intent(out), optional :: de_again(size(values))  !! the nearest other crossing's dE
    real(wp), intent(out), optional :: span(4)                 !! dE low, high; T least, greatest
    type(period_ctx_t), target :: c
    type(probes_t) :: pr
    integer :: k, mode, na(size(values))
    real(wp) :: da(size(values))
    des = 0
    found = PARAM_NOCONV
    t_po = 0
    t_reach = 0
    de_reach = 0
    e_saddle = 0
    na = 0
    da = 0
    if (present(n_again)) n_again = 0
    if (present(de_again)) de_again = 0
    if (present(span)) span = 0
    if (kind /= PARAM_JACOBI .and. kind /= PARAM_PERIOD) then
      stat = TUBES_EINPUT
      return
    end if
    call setup_model(trim(st%system), st%params, st%lo, st%hi, st%n_grid, trim(st%saddle), c%model, c%eqs, &
                     c%isad, stat, stores=stores)
    if (stat /= TUBES_OK) return
    e_saddle = c%eqs(c%isad)%energy
    if (kind == PARAM_JACOBI) then
      do k = 1, size(values)
        if (c%model%jacobi_factor() == 0) then
          found(k) = PARAM_NOJACOBI
        else
          des(k) = energy_of_jacobi(c%model, values(k)) - e_saddle
          found(k) = PARAM_FOUND
        end if
      end do
      return
    end if
    ! 'branch:K': K counts the parent's bifurcations between the requested energies, which
    ! periods do not give
    if (opts%branch > 0) then
      stat = TUBES_EINPUT
      return
    end if
    ! a family that starts away from the saddle: T(dE) probed along its own continuation
    if (allocated(opts%guess) .or. opts%family == FAMILY_BRANCH_PLUS .or. opts%family == FAMILY_BRANCH_MINUS .or. &
        opts%family == FAMILY_AXIAL) then
      c%st = st
      c%opts = opts
      if (present(stores)) c%stores => stores
      c%away = .true.
      call probe_family(c, pr, .false.)
      if (c%off_branch >= 0) c%stat = TUBES_ENOCONV    ! the family's T(dE) is not known there: no answer
      if ((c%stat < 0 .and. c%stat /= TUBES_ENOCONV) .or. c%off_branch >= 0) then
        stat = c%stat
        return
      end if
      do k = 1, size(values)
        c%target = values(k)
        call period_de_away(c, pr, des(k), found(k), na(k), da(k))
        if (c%off_branch >= 0) c%stat = TUBES_ENOCONV
        if ((c%stat < 0 .and. c%stat /= TUBES_ENOCONV) .or. c%off_branch >= 0) then
          stat = c%stat
          return
        end if
      end do
      if (size(pr%de) > 0) then
        k = minloc(abs(pr%de - pr%de_start), 1)
        t_po = pr%t(k)
        t_reach = pr%t(size(pr%t))
        de_reach = pr%de(size(pr%de))
        if (present(span)) span = [pr%de(1), pr%de(size(pr%de)), minval(pr%t), maxval(pr%t)]
      end if
      if (present(n_again)) n_again = na
      if (present(de_again)) de_again = da
      stat = TUBES_OK
      return
    end if
    ! periods: the Lyapunov families of a saddle (by number, or 'vertical' / 'lyapunov' by name:
    ! their centre mode's, named_mode)
    mode = opts%family
    if (mode == FAMILY_VERTICAL .or. mode == FAMILY_PLANAR) &
      mode = named_mode(c%eqs(c%isad), c%model%ndof(), opts%family)
    if (mode < 1 .or. mode > size(c%eqs(c%isad)%omegas)) then
      stat = TUBES_EINPUT
      return
    end if
    c%st = st
    c%opts = opts
    if (present(stores)) c%stores => stores
    c%t_po = 2*PI/c%eqs(c%isad)%omegas(mode)
    t_po = c%t_po
    do k = 1, size(values)
      c%target = values(k)
      call period_de(c, des(k), found(k), t_reach, de_reach)
      if (c%stat < 0 .and. c%stat /= TUBES_ENOCONV) then
        stat = c%stat
        return
      end if
    end do
    stat = TUBES_OK
  end subroutine family_parameter_des

  !> The probes of a family away from the saddle (module notes; period_de_away): a guess's family
  !> from dE_g both ways on dE_g +- delta 2^j to the first energy without an orbit on each side; a
  !> branch from dE_1 2^j up, past the energies below its start (no orbit), to the first energy
  !> without an orbit above it. close: add the points that close in on each end of the probed range
  !> (bisection between the end's probes with and without an orbit, CLOSE_AWAY steps; towards a fold
  !> in energy the family said it ends at, CLOSE_FOLD points).
  subroutine probe_family(c, pr, close)
    type(period_ctx_t), intent(inout) :: c
    type(probes_t), intent(inout) :: pr
    logical, intent(in) :: close
    real(wp) :: d, t, end_de, delta, a, b
    integer :: j, side
    logical :: ok, seen
    if (close) then
      if (pr%closed .or. size(pr%de) == 0) return
      pr%closed = .true.
      ! the lower end: bisection between the nearest probe without an orbit and the lowest with one
      ! (the family's start lies between them), each midpoint with an orbit a probe
      if (pr%has_lo) then
        a = pr%de(1)                    ! (a copy: probe reallocates pr%de)
        b = pr%lo_fail
        call bisect_end(a, b)
        if (c%stat < 0 .and. c%stat /= TUBES_ENOCONV) return
      end if
      ! the upper end: towards the family's end where it said one (a fold: CLOSE_FOLD points, from the
      ! highest probe, that close in on it), else bisection as at the lower end
      if (pr%has_hi) then
        a = pr%de(size(pr%de))
        b = pr%hi_fail
        if (pr%hi_end > a .and. pr%hi_end < b) then
          b = pr%hi_end
          do j = 1, CLOSE_FOLD
            call probe(a + (b - a)*(1 - 0.5_wp**j))
            if (c%stat < 0 .and. c%stat /= TUBES_ENOCONV) return
          end do
        else
          call bisect_end(a, b)
        end if
      end if
      return
    end if
    allocate (pr%de(0), pr%t(0))
    if (allocated(c%opts%guess)) then
      pr%de_start = c%model%energy(c%opts%guess) - c%eqs(c%isad)%energy
      call probe(pr%de_start, ok)
      if (.not. ok) return                   ! the guess did not converge: no family
      delta = GUESS_STEP*abs(pr%de_start)
      if (.not. delta > 0) delta = GUESS_STEP*abs(c%eqs(c%isad)%energy)
      if (.not. delta > 0) delta = GUESS_STEP
      do side = 1, -1, -2
        do j = 0, GRID_MAX - 1
          d = pr%de_start + side*delta*2.0_wp**j
          call probe(d, ok, end_de)
          if (c%stat < 0 .and. c%stat /= TUBES_ENOCONV) return
          if (ok) cycle
          if (side > 0) then
            pr%has_hi = .true.
            pr%hi_fail = d
            pr%hi_end = end_de
          else
            pr%has_lo = .true.
            pr%lo_fail = d
          end if
          exit
        end do
      end do
      return
    end if
    ! a branch: the grid's first energy as a Lyapunov family's (period_de)
    d = grid_first(c)
    pr%de_start = d
    seen = .false.
    a = 0
    do j = 1, GRID_MAX
      call probe(d, ok, end_de)
      if (c%stat < 0 .and. c%stat /= TUBES_ENOCONV) return
      if (.not. ok .and. .not. seen .and. end_de > a .and. end_de < d) then
        ! past the end of a family not yet met (the axial family lies within one doubling): it lies
        ! below its end, above the last energy below its start; points from there that close in on
        ! the end, to the first orbit
        do side = 1, CLOSE_IN
          call probe(a + (end_de - a)*(1 - 0.5_wp**side), seen)
          if (c%stat < 0 .and. c%stat /= TUBES_ENOCONV) return
          if (seen) exit
          pr%has_lo = .true.
          pr%lo_fail = a + (end_de - a)*(1 - 0.5_wp**side)
        end do
      end if
      if (ok) then
        seen = .true.
      else if (seen) then
        pr%has_hi = .true.
        pr%hi_fail = d
        pr%hi_end = end_de
        exit
      else
        pr%has_lo = .true.
        pr%lo_fail = d
        a = d
        if (d > 2.0_wp**MAX_DOUBLINGS*pr%de_start) exit   ! no family met in this range: none
      end if
      d = 2*d
    end do
    if (size(pr%de) > 0) pr%de_start = pr%de(1)
  contains
    ! CLOSE_AWAY bisection steps between the energies yes (with an orbit) and no (without), each
    ! midpoint a probe: one end of the probed range closed in on
    subroutine bisect_end(yes, no)
      real(wp), intent(in) :: yes, no
      real(wp) :: lo, hi, mid
      integer :: i
      logical :: okm
      lo = min(yes, no)
      hi = max(yes, no)
      do i = 1, CLOSE_AWAY
        mid = lo + (hi - lo)/2
        call probe(mid, okm)
        if (c%stat < 0 .and. c%stat /= TUBES_ENOCONV) return
        if (okm .eqv. (yes < no)) then
          lo = mid
        else
          hi = mid
        end if
      end do
    end subroutine bisect_end

    subroutine probe(de, ok_out, end_out)   ! the family's orbit at de, kept if it converged
      real(wp), intent(in) :: de
      logical, intent(out), optional :: ok_out
      real(wp), intent(out), optional :: end_out
      logical :: okp
      real(wp) :: ee
      integer :: i
      call period_at(c, de, t, okp, ee)
      if (present(ok_out)) ok_out = okp
      if (present(end_out)) end_out = ee
      if (.not. okp) return
      i = count(pr%de < de)
      pr%de = [pr%de(1:i), de, pr%de(i + 1:)]
      pr%t = [pr%t(1:i), t, pr%t(i + 1:)]
    end subroutine probe
  end subroutine probe_family

  !> The dE of the orbit of period c%target of a family away from the saddle (family_parameter_des):
  !> the crossing of T - T* among the probes pr nearest the family's start (the ends closed in on
  !> first if no interval holds one), solved by Brent; n_again the other crossings, de_again the
  !> middle of the nearest other's interval (0 if none).
  subroutine period_de_away(c, pr, de, found, n_again, de_again)
    type(period_ctx_t), intent(inout), target :: c
    type(probes_t), intent(inout) :: pr
    real(wp), intent(out) :: de, de_again
    integer, intent(out) :: found, n_again
    real(wp) :: g(size(pr%de) + 2*CLOSE_AWAY + CLOSE_FOLD), dist, best, next
    integer :: i, n, ibest, ncross
    de = 0
    de_again = 0
    n_again = 0
    found = PARAM_NOT_REACHED
    c%stat = TUBES_OK
    if (size(pr%de) == 0 .or. .not. (c%target > 0)) return
    if (count_crossings() == 0) then
      call probe_family(c, pr, .true.)
      if (c%stat < 0 .and. c%stat /= TUBES_ENOCONV) return
      c%stat = TUBES_OK                     ! a probe without an orbit is an end, not a failure
    end if
    ncross = count_crossings()
    if (ncross == 0) return
    ! the crossing nearest the start, and the nearest other
    n = size(pr%de)
    g(1:n) = pr%t - c%target
    best = huge(1.0_wp)
    next = huge(1.0_wp)
    ibest = 0
    do i = 1, n
      if (.not. crosses(i)) cycle
      dist = abs(pr%de(i) - pr%de_start)
      if (i < n) dist = min(dist, abs(pr%de(i + 1) - pr%de_start))
      if (dist < best) then
        best = dist
        ibest = i
      end if
    end do
    do i = 1, n
      if (i == ibest .or. .not. crosses(i)) cycle
      dist = abs(pr%de(i) - pr%de_start)
      if (i < n) dist = min(dist, abs(pr%de(i + 1) - pr%de_start))
      if (dist < next) then
        next = dist
        de_again = pr%de(i)
        if (i < n .and. g(i) /= 0) de_again = (pr%de(i) + pr%de(i + 1))/2
      end if
    end do
    n_again = ncross - 1
    if (g(ibest) == 0) then
      call period_root(c, pr%de(ibest), pr%de(ibest), de, found)
    else if (g(ibest + 1) == 0) then
      call period_root(c, pr%de(ibest + 1), pr%de(ibest + 1), de, found)
    else
      call period_root(c, pr%de(ibest), pr%de(ibest + 1), de, found)
    end if
  contains
    logical function crosses(i)   ! T - T* is 0 at probe i or changes sign between probes i and i + 1
      integer, intent(in) :: i
      real(wp) :: gi, gn
      gi = pr%t(i) - c%target
      crosses = gi == 0
      if (i < size(pr%de)) then
        gn = pr%t(i + 1) - c%target
        crosses = crosses .or. gi*gn < 0
      end if
    end function crosses
    integer function count_crossings() result(m)
      integer :: j
      m = 0
      do j = 1, size(pr%de)
        if (crosses(j)) m = m + 1
      end do
    end function count_crossings
  end subroutine period_de_away

  !> The dE of the first crossing of T(dE) = c%target from the saddle (family_parameter_des).
  subroutine period_de(c, de, found, t_reach, de_reach)
    type(period_ctx_t), intent(inout), target :: c
    real(wp), intent(out) :: de
    integer, intent(out) :: found
    real(wp), intent(inout) :: t_reach, de_reach
    real(wp) :: a, b, ga, gb, t, root, last_ok, end_de
    integer :: j
    logical :: ok, bracketed
    de = 0
    found = PARAM_NOT_REACHED
    c%stat = TUBES_OK
    if (.not. (c%target > 0)) return
    ga = c%t_po - c%target
    if (ga == 0) return                     ! the limit itself: no orbit (dE = 0)
    b = grid_first(c)
    a = 0
    last_ok = 0
    bracketed = .false.
    do j = 1, GRID_MAX
      call period_at(c, b, t, ok, end_de)
      if (.not. ok) exit
      last_ok = b
      t_reach = t
      de_reach = b
      gb = t - c%target
      if (sign(1.0_wp, gb) /= sign(1.0_wp, ga) .or. gb == 0) then
        bracketed = .true.
        exit
      end if
      a = b
      ga = gb
      b = 2*b
    end do
    if (.not. bracketed .and. .not. ok) then   ! the family ends between a and b: close in on its end
      if (end_de > last_ok .and. end_de < b) b = end_de
      do j = 1, CLOSE_IN
        root = last_ok + (b - last_ok)*(1 - 0.5_wp**j)
        call period_at(c, root, t, ok, end_de)
        if (.not. ok) cycle
        t_reach = t
        de_reach = root
        gb = t - c%target
        if (sign(1.0_wp, gb) /= sign(1.0_wp, ga) .or. gb == 0) then
          b = root
          bracketed = .true.
          exit
        end if
        a = root
        ga = gb
      end do
    end if
    if (.not. bracketed) return
    if (gb == 0) a = b
    call period_root(c, a, b, de, found)
  end subroutine period_de

  !> The dE of the period c%target between a and b (T - T* changes sign there; a == b: the root
  !> itself): Brent's root, and T there checked to PERIOD_RTOL. found PARAM_FOUND with de, or
  !> PARAM_NOCONV (c%stat TUBES_ENOCONV).
  subroutine period_root(c, a, b, de, found)
    type(period_ctx_t), intent(inout), target :: c
    real(wp), intent(in) :: a, b
    real(wp), intent(inout) :: de
    integer, intent(out) :: found
    real(wp) :: root, t, end_de
    logical :: ok
    integer :: gst
    found = PARAM_NOCONV
    root = b
    if (a /= b) then
      gst = quad_root(c_funloc(period_gap), c_loc(c), a, b, 0.0_wp, BRENT_XTOL, root)
      if (gst /= 0 .or. c%stat /= TUBES_OK) then
        c%stat = TUBES_ENOCONV
        return
      end if
    end if
    call period_at(c, root, t, ok, end_de)
    if (.not. ok .or. abs(t - c%target) > PERIOD_RTOL*c%target) then
      c%stat = TUBES_ENOCONV
      return
    end if
    de = root
    found = PARAM_FOUND
  end subroutine period_root

  !> The period t of the family's orbit at de alone (family_at); de <= 0: the saddle's limit T_po
  !> (a Lyapunov family; a family away from the saddle, c%away, its orbit there).
  !> ok: the orbit converged; end_de: the family's end where it did not (else -1). An orbit of a branch
  !> the corrector took off it (orbit_t off_branch) is not an end: c%off_branch = de, and the search
  !> stops with TUBES_ENOCONV (family_parameter_des).
  subroutine period_at(c, de, t, ok, end_de)
    type(period_ctx_t), intent(inout) :: c
    real(wp), intent(in) :: de
    real(wp), intent(out) :: t, end_de
    logical, intent(out) :: ok
    type(orbit_t), allocatable :: orbs(:)   ! (a local array: gfortran 12 -O1 -fcheck=all warned on its initialiser)
    integer :: reason, st
    end_de = -1
    t = c%t_po
    ok = .true.
    if (de <= 0 .and. .not. c%away) return
    allocate (orbs(1))
    call family_at(c%st, c%model, c%eqs, c%isad, [de], c%opts, orbs, end_de, reason, st, c%stores)
    ok = st == TUBES_OK .and. orbs(1)%converged
    if (orbs(1)%off_branch .and. c%off_branch < 0) c%off_branch = de
    if (st < 0 .and. st /= TUBES_EUNRESOLVED) c%stat = st   ! below the energy's resolution: no orbit
    if (ok) t = orbs(1)%period
  end subroutine period_at

  !> The grid's first energy: where the linear orbit's amplitude is GRID_AMP of the saddle's distance
  !> to the nearest other equilibrium (the model's length scale if none); 1e-6 without an amplitude.
  real(wp) function grid_first(c) result(d)
    type(period_ctx_t), intent(in) :: c
    real(wp) :: dist, amp, tau, x0(c%model%dim())
    integer :: j
    dist = huge(1.0_wp)
    do j = 1, size(c%eqs)
      if (j /= c%isad) dist = min(dist, norm2(c%eqs(j)%q - c%eqs(c%isad)%q))
    end do
    if (dist == huge(1.0_wp)) dist = c%model%length_scale()
    call linear_guess(c%model, c%eqs(c%isad), 1.0_wp, x0, tau)
    amp = norm2(x0(1:size(c%eqs(c%isad)%q)) - c%eqs(c%isad)%q)
    d = 1.0e-6_wp
    if (amp > 0) d = (GRID_AMP*dist/amp)**2
  end function grid_first

  !> T(dE) - T* for Brent (the user pointer: a period_ctx_t); a failed orbit inside the bracket
  !> sets the context's stat and answers 0, which ends the search.
  real(c_double) function period_gap(x, user) bind(C)
    real(c_double), value :: x
    type(c_ptr), value :: user
    type(period_ctx_t), pointer :: c
    real(wp) :: t, end_de
    logical :: ok
    call c_f_pointer(user, c)
    call period_at(c, x, t, ok, end_de)
    if (.not. ok) then
      if (c%stat == TUBES_OK) c%stat = TUBES_ENOCONV
      period_gap = 0
      return
    end if
    period_gap = t - c%target
  end function period_gap

end module tubes_orbit_parameter
