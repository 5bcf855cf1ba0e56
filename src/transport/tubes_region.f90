!> The transition region of a 2-DOF section at its energy, for any vector field, conservative or
!> dissipative: the set of section points whose trajectory passes the saddle's gate before it meets
!> the section again (the Monte Carlo check's test, tubes_transport mc_classify). Its boundary is
!> the cut of the section with the stable manifold of the saddle equilibrium (dissipative fields:
!> dimension 2N - 1) or of its Lyapunov orbits (conservative: the tube): a boundary point's
!> trajectory reaches the saddle and stays. Found by shooting from the section: along rays from a
!> point inside, each boundary point is the limit of a bisection between a point that transits
!> and one that returns. The area is the trapezoidal rule of (1/2) rho(phi)^2 in the ray angle,
!> spectrally accurate for a smooth star-shaped region, refined by doubling the rays. A scan of
!> the section on a grid finds the inside point and checks the traced region: every scan point
!> that transits must lie inside it, every one that returns outside. Theory: docs/dissipation.md.
module tubes_region
  use tubes_kinds, only: wp, PI
  use tubes_status, only: TUBES_OK, TUBES_EINPUT, TUBES_ENOCONV, TUBES_ESHAPE, TUBES_EUNDECIDED
  use tubes_ensemble, only: ensemble_t, ens_out_t, ens_run, ens_agree
  use tubes_hamiltonian, only: hamiltonian_t
  use tubes_field, only: vector_field_t
  use tubes_methods, only: integ_choice_t
  use tubes_section_kinds, only: poincare_t
  use tubes_quad, only: polygon_area
  use tubes_transport, only: gate_spec_t, mc_classify, classify_points, MC_TRANSIT, MC_RETURN, MC_ESCAPE, MC_TRAPPED, &
                             MC_UNDECIDED
  implicit none
  private

  !> A scan point within this relative distance of the traced boundary (along its ray) is not
  !> held against the region (the boundary is known to the bisection's xtol and the interpolation
  !> between rays to area_tol)
  real(wp), parameter :: SHELL = 1.0e-6_wp

  !> Options of a transition region.
  type, public :: region_opts_t
    integer :: n_init = 32            !! rays of the first round (doubled each further round)
    integer :: n_max = 4096           !! rays at most
    real(wp) :: area_tol = 1.0e-8_wp  !! relative change of the area that ends the refinement
    real(wp) :: xtol = 1.0e-13_wp     !! bisection: each boundary point to this fraction of its ray
    integer :: n_scan = 32            !! scan: n_scan x n_scan grid over the section's box (0: none)
    real(wp) :: t_max = 20            !! longest integration of a point [time]
    real(wp) :: tol = 1.0e-12_wp      !! rtol = atol of each point's integration
    type(integ_choice_t) :: integ     !! the integrator
    logical :: local = .false.        !! on this MPI rank alone
    logical :: one_round = .false.    !! n_init rays, no refinement (a coarse region: its centre)
    !> points (s, p_s) to try first as the rays' origin (the first that transits is taken)
    real(wp), allocatable :: hints(:, :)
  end type region_opts_t

  !> The region: its boundary as n rays from centre in the scaled coordinates
  !> ((s - centre(1))/scale(1), (p_s - centre(2))/scale(2)) = rho (cos phi, sin phi).
  type, public :: region_t
    logical :: empty = .true.          !! no point found that transits (no rays then)
    integer :: n = 0                   !! rays
    real(wp) :: centre(2) = 0          !! (s, p_s) of the rays' origin (a point that transits)
    real(wp) :: scale(2) = 1           !! scales of s and p_s
    real(wp), allocatable :: phi(:)    !! ray angles, 2 pi (k - 1)/n
    real(wp), allocatable :: rho(:)    !! boundary radius on each ray (scaled)
    real(wp), allocatable :: s(:), p(:)   !! the boundary point (s, p_s)
    real(wp), allocatable :: t_in(:)   !! flight time to the gate of the innermost... the last
                                       !! transiting point of each bisection (it lingers at the saddle)
    real(wp), allocatable :: edge(:)   !! the ray's length to the edge of the energy surface (scaled)
    !> the boundary's trigonometric interpolant rho(phi) = a(0) + sum_k a(k) cos k phi + b(k) sin k phi
    real(wp), allocatable :: a(:), b(:)
    real(wp) :: area = 0               !! trapezoidal rule in phi [units of s x p_s]
    real(wp) :: area_polygon = 0       !! the polygon's (shoelace) area
    real(wp) :: area_change = 0        !! |last - previous round|
    integer :: rounds = 0
    integer, allocatable :: hist_n(:)        !! rays after each round
    real(wp), allocatable :: hist_area(:)    !! area after each round
    integer :: n_classified = 0        !! points integrated in all (scan, rays, checks)
    integer :: n_scan = 0              !! scan points on the energy surface
    integer :: n_scan_transit = 0      !! of them, transits
    integer :: n_scan_undecided = 0    !! neither transit nor return within t_max
    integer :: n_inconsistent = 0      !! scan points the traced region places on the wrong side
    real(wp) :: fail_phi = 0           !! the first ray that failed, and why
    integer :: fail_stat = 0
  end type region_t

  !> The rays of one round as an ensemble: item k bisects ray phi(k) from centre.
  type, extends(ensemble_t) :: ray_jobs_t
    class(hamiltonian_t), allocatable :: model
    class(vector_field_t), allocatable :: field
    type(poincare_t) :: psec
    type(gate_spec_t) :: gspec
    type(region_opts_t) :: opts
    real(wp) :: centre(2) = 0, scale(2) = 1
    real(wp) :: box(4) = 0                     !! the section's box: s min, max, p_s min, max
    real(wp), allocatable :: phi(:)
  contains
    procedure :: item => ray_item
  end type ray_jobs_t

  integer, parameter :: RAY_NR = 5   ! rho, s, p, t_in, edge
  integer, parameter :: RAY_NI = 1   ! points integrated

  public :: transition_region, region_inside, region_curve

contains

  !> The transition region of the section psec (at its energy) for the trajectories of field (the
  !> model's, with its dissipation), transit meaning the gate gspec passed before the section is met
  !> again. reg%empty with stat = TUBES_OK when no point of the hints and the scan transits (the
  !> caller decides whether the region is empty: tubes_study's threshold search). stat:
  !> TUBES_ESHAPE when a ray crosses the boundary more than once or the scan disagrees with the
  !> traced region (several pieces, or not star-shaped about its centre), or the region reaches the
  !> edge of the energy surface; TUBES_EUNDECIDED when a point neither transits nor returns within
  !> t_max; TUBES_ENOCONV when the area does not converge within n_max rays; an integration's
  !> failure as it is.
  subroutine transition_region(model, field, psec, gspec, opts, reg, stat)
    class(hamiltonian_t), intent(in) :: model     !! the model (the section's energy, escapes)
    class(vector_field_t), intent(in) :: field    !! what is integrated
    type(poincare_t), intent(in) :: psec          !! the section at the initial energy
    type(gate_spec_t), intent(in) :: gspec        !! the saddle's gate
    type(region_opts_t), intent(in) :: opts
    type(region_t), intent(out) :: reg
    integer, intent(out) :: stat
    type(ray_jobs_t) :: ens
    real(wp), allocatable :: ss(:), pp(:), phi(:), rho(:), sb(:), pb(:), tin(:), edge(:)
    integer, allocatable :: outc(:)
    real(wp) :: box(4), plo, phi_, c(2), a_old, a_new, cen(2), half(2)
    integer :: i, j, n, m, ns
    logical :: found
    stat = TUBES_EINPUT
    if (opts%n_init < 8 .or. opts%n_max < opts%n_init .or. .not. opts%xtol > 0 .or. opts%n_scan < 0) return
    stat = TUBES_OK
    ! the section's box
    box(1:2) = [psec%smin, psec%smax]
    box(3) = huge(1.0_wp)
    box(4) = -huge(1.0_wp)
    do i = 0, 400
      call psec%bounds(psec%smin + (psec%smax - psec%smin)*i/400.0_wp, plo, phi_)
      box(3) = min(box(3), plo)
      box(4) = max(box(4), phi_)
    end do
    ! the rays' origin: a hint that transits, else from the scan
    found = .false.
    if (allocated(opts%hints)) then
      do i = 1, size(opts%hints, 2)
        if (transits(opts%hints(:, i))) then
          found = .true.
          c = opts%hints(:, i)
          exit
        end if
        if (stat < 0) return
      end do
    end if
    call scan(stat)
    if (stat < 0) return
    if (.not. found) then
      if (reg%n_scan_transit == 0) return         ! empty as far as the scan sees
      call scan_centre(c, found)
      if (stat < 0) return
      if (.not. found) then
        reg%empty = .false.
        stat = TUBES_ESHAPE                       ! no scan point transits near the transits' middle
        return
      end if
    end if
    reg%empty = .false.
    reg%centre = c                                ! a point that transits (also where the trace fails)
    ! the scale: the transits' extent on the scan (one cell at least), else the box's
    half = [(box(2) - box(1)), (box(4) - box(3))]/2
    if (reg%n_scan_transit > 0) then
      half = [max(maxval(ss, mask=outc == MC_TRANSIT) - minval(ss, mask=outc == MC_TRANSIT), &
                  (box(2) - box(1))/max(1, opts%n_scan)), &
              max(maxval(pp, mask=outc == MC_TRANSIT) - minval(pp, mask=outc == MC_TRANSIT), &
                  (box(4) - box(3))/max(1, opts%n_scan))]/2
    end if
    ens = ray_jobs_t(psec=psec, gspec=gspec, opts=opts, box=box)
    allocate (ens%model, source=model)
    allocate (ens%field, source=field)
    ! round 0: the region seen from c; then its own centroid and extent as origin and scale
    ens%centre = c
    ens%scale = half
    n = opts%n_init
    phi = [((j - 1)*2*PI/n, j = 1, n)]
    call rays(phi, rho, sb, pb, tin, edge)
    if (stat < 0) return
    call centroid(sb, pb, cen, half)
    if (transits(cen)) then
      ens%centre = cen
    end if
    if (stat < 0) return
    ens%scale = max(half, 1.0e-300_wp)
    call rays(phi, rho, sb, pb, tin, edge)
    if (stat < 0) return
    allocate (reg%hist_n(0), reg%hist_area(0))
    a_old = huge(1.0_wp)
    do
      a_new = ens%scale(1)*ens%scale(2)*PI/n*sum(rho**2)
      call ens_agree(a_new, opts%local)
      reg%rounds = reg%rounds + 1
      reg%hist_n = [reg%hist_n, n]
      reg%hist_area = [reg%hist_area, a_new]
      reg%area_change = abs(a_new - a_old)
      if (opts%one_round .or. reg%area_change <= opts%area_tol*a_new) exit
      if (2*n > opts%n_max) then
        stat = TUBES_ENOCONV
        exit
      end if
      a_old = a_new
      ! the next round: the rays halfway between, merged in angle order
      block
        real(wp), allocatable :: phi2(:), rho2(:), sb2(:), pb2(:), tin2(:), edge2(:)
        phi2 = phi + PI/n
        call rays(phi2, rho2, sb2, pb2, tin2, edge2)
        if (stat < 0) return
        m = 2*n
        phi = interleave(phi, phi2)
        rho = interleave(rho, rho2)
        sb = interleave(sb, sb2)
        pb = interleave(pb, pb2)
        tin = interleave(tin, tin2)
        edge = interleave(edge, edge2)
        n = m
      end block
    end do
    reg%n = n
    reg%centre = ens%centre
    reg%scale = ens%scale
    reg%phi = phi
    reg%rho = rho
    reg%s = sb
    reg%p = pb
    reg%t_in = tin
    reg%edge = edge
    reg%area = a_new
    reg%area_polygon = abs(polygon_area(sb, pb))
    call interpolant(reg)
    ! the scan against the traced region
    do i = 1, ns
      if (outc(i) /= MC_TRANSIT .and. outc(i) /= MC_RETURN .and. outc(i) /= MC_ESCAPE .and. outc(i) /= MC_TRAPPED) cycle
      if (near_boundary(reg, ss(i), pp(i))) cycle
      if (region_inside(reg, ss(i), pp(i)) .neqv. (outc(i) == MC_TRANSIT)) reg%n_inconsistent = reg%n_inconsistent + 1
    end do
    if (reg%n_inconsistent > 0 .and. stat == TUBES_OK) stat = TUBES_ESHAPE
  contains
    logical function transits(pt)
      real(wp), intent(in) :: pt(2)
      real(wp) :: x(model%dim()), te
      integer :: oc, st
      transits = .false.
      call psec%state(pt(1), pt(2), x, st)
      if (st /= TUBES_OK) return
      call mc_classify(model, psec, x, gspec, opts%t_max, opts%tol, opts%integ, oc, te, st, field)
      reg%n_classified = reg%n_classified + 1
      if (st < 0) then
        stat = st
        return
      end if
      transits = oc == MC_TRANSIT
    end function transits
    subroutine scan(stat)        ! the n_scan^2 grid's points on the energy surface, classified
      integer, intent(out) :: stat
      integer :: a, b
      real(wp) :: s0, p0
      stat = TUBES_OK
      allocate (ss(opts%n_scan**2), pp(opts%n_scan**2))
      ns = 0
      do a = 1, opts%n_scan
        s0 = box(1) + (box(2) - box(1))*(a - 0.5_wp)/opts%n_scan
        call psec%bounds(s0, plo, phi_)
        do b = 1, opts%n_scan
          p0 = box(3) + (box(4) - box(3))*(b - 0.5_wp)/opts%n_scan
          if (.not. (p0 > plo .and. p0 < phi_)) cycle
          ns = ns + 1
          ss(ns) = s0
          pp(ns) = p0
        end do
      end do
      ss = ss(1:ns)
      pp = pp(1:ns)
      allocate (outc(ns))
      reg%n_scan = ns
      if (ns == 0) return
      call classify_points(model, psec, ss, pp, gspec, opts%t_max, opts%tol, opts%integ, outc, stat, field=field, &
                           local=opts%local)
      reg%n_classified = reg%n_classified + ns
      if (stat < 0) return
      reg%n_scan_transit = count(outc == MC_TRANSIT)
      reg%n_scan_undecided = count(outc == MC_UNDECIDED)
    end subroutine scan
    subroutine scan_centre(c, found)     ! the transits' mean, else the transit nearest to it
      real(wp), intent(out) :: c(2)
      logical, intent(out) :: found
      real(wp) :: m(2), d, best
      integer :: i, ib
      m = [sum(ss, mask=outc == MC_TRANSIT), sum(pp, mask=outc == MC_TRANSIT)]/reg%n_scan_transit
      c = m
      found = transits(m)
      if (found .or. stat < 0) return
      best = huge(1.0_wp)
      ib = 0
      do i = 1, ns
        if (outc(i) /= MC_TRANSIT) cycle
        d = ((ss(i) - m(1))/(box(2) - box(1)))**2 + ((pp(i) - m(2))/(box(4) - box(3)))**2
        if (d < best) then
          best = d
          ib = i
        end if
      end do
      c = [ss(ib), pp(ib)]
      found = .true.
    end subroutine scan_centre
    subroutine rays(ph, rho, sb, pb, tin, edge)   ! the rays ph from ens%centre, bisected
      real(wp), intent(in) :: ph(:)
      real(wp), allocatable, intent(out) :: rho(:), sb(:), pb(:), tin(:), edge(:)
      type(ens_out_t) :: out
      integer :: k
      ens%phi = ph
      call ens_run(ens, size(ph), out, RAY_NR, RAY_NI, fault='ray', local=opts%local)
      rho = out%r(1, :)
      sb = out%r(2, :)
      pb = out%r(3, :)
      tin = out%r(4, :)
      edge = out%r(5, :)
      reg%n_classified = reg%n_classified + sum(out%i(1, :))
      do k = 1, size(ph)
        if (out%st(k) < 0) then
          stat = out%st(k)
          reg%fail_phi = ph(k)
          reg%fail_stat = out%st(k)
          return
        end if
      end do
    end subroutine rays
  end subroutine transition_region

  !> Ray phi(k): its length to the edge of the energy surface, then the boundary by bisection
  !> between the centre (transits) and the edge (must return), and the two checks that the ray
  !> crosses the boundary once (halfway in: transits; halfway out: returns).
  subroutine ray_item(self, k, out)
    class(ray_jobs_t), intent(in) :: self
    integer, intent(in) :: k
    type(ens_out_t), intent(inout) :: out
    real(wp) :: dir(2), lo, hi, mid, edge, t_lo, te
    integer :: oc, st, nc
    dir = [self%scale(1)*cos(self%phi(k)), self%scale(2)*sin(self%phi(k))]
    nc = 0
    edge = ray_edge(self, dir)
    out%r(5, k) = edge
    ! the edge of the energy surface must return (a region that reaches it is not bounded by the
    ! manifold there)
    hi = edge*(1 - 1.0e-9_wp)
    call classify(hi, oc, te, st)
    if (st < 0) return
    if (oc == MC_TRANSIT) then
      out%st(k) = TUBES_ESHAPE
      return
    end if
    lo = 0
    t_lo = 0
    do while (hi - lo > self%opts%xtol*edge)
      mid = 0.5_wp*(lo + hi)
      if (mid <= lo .or. mid >= hi) exit
      call classify(mid, oc, te, st)
      if (st < 0) return
      if (oc == MC_TRANSIT) then
        lo = mid
        t_lo = te
      else
        hi = mid
      end if
    end do
    mid = 0.5_wp*(lo + hi)
    ! one crossing: halfway in transits, halfway out returns
    call classify(0.5_wp*mid, oc, te, st)
    if (st < 0) return
    if (oc /= MC_TRANSIT) then
      out%st(k) = TUBES_ESHAPE
      return
    end if
    call classify(0.5_wp*(mid + edge), oc, te, st)
    if (st < 0) return
    if (oc == MC_TRANSIT) then
      out%st(k) = TUBES_ESHAPE
      return
    end if
    out%r(1:4, k) = [mid, self%centre + mid*dir, t_lo]
    out%i(1, k) = nc
  contains
    subroutine classify(t, oc, te, st)
      real(wp), intent(in) :: t
      integer, intent(out) :: oc, st
      real(wp), intent(out) :: te
      real(wp) :: x(self%model%dim()), pt(2)
      pt = self%centre + t*dir
      nc = nc + 1
      call self%psec%state(pt(1), pt(2), x, st)
      if (st /= TUBES_OK) then        ! (the edge is found inside: cannot happen)
        out%st(k) = TUBES_EINPUT
        st = TUBES_EINPUT
        return
      end if
      call mc_classify(self%model, self%psec, x, self%gspec, self%opts%t_max, self%opts%tol, self%opts%integ, &
                       oc, te, st, self%field)
      if (st >= 0 .and. oc == MC_UNDECIDED) st = TUBES_EUNDECIDED
      if (st < 0) then
        out%st(k) = st
        out%i(1, k) = nc
      end if
    end subroutine classify
  end subroutine ray_item

  !> The length of the ray centre + t dir (t >= 0) to the first edge of the energy surface (the
  !> last t inside): marched in 256 steps to the box, then 80 bisections.
  real(wp) function ray_edge(self, dir) result(t)
    class(ray_jobs_t), intent(in) :: self
    real(wp), intent(in) :: dir(2)
    real(wp) :: tb, a, b, m
    integer :: i
    tb = huge(1.0_wp)
    if (dir(1) > 0) tb = min(tb, (self%box(2) - self%centre(1))/dir(1))
    if (dir(1) < 0) tb = min(tb, (self%box(1) - self%centre(1))/dir(1))
    if (dir(2) > 0) tb = min(tb, (self%box(4) - self%centre(2))/dir(2))
    if (dir(2) < 0) tb = min(tb, (self%box(3) - self%centre(2))/dir(2))
    a = 0
    b = tb
    do i = 1, 256
      if (.not. on_surface(tb*i/256.0_wp)) then
        b = tb*i/256.0_wp
        exit
      end if
      a = tb*i/256.0_wp
    end do
    if (a >= b) then
      t = a
      return
    end if
    do i = 1, 80
      m = 0.5_wp*(a + b)
      if (m <= a .or. m >= b) exit
      if (on_surface(m)) then
        a = m
      else
        b = m
      end if
    end do
    t = a
  contains
    logical function on_surface(tt)
      real(wp), intent(in) :: tt
      real(wp) :: pt(2), lo, hi
      pt = self%centre + tt*dir
      on_surface = .false.
      if (pt(1) <= self%psec%smin .or. pt(1) >= self%psec%smax) return
      call self%psec%bounds(pt(1), lo, hi)
      on_surface = pt(2) > lo .and. pt(2) < hi
    end function on_surface
  end function ray_edge

  !> The trigonometric interpolant of the rays' rho (the trapezoidal rule's own: exact at the n
  !> samples, spectrally accurate between them), its coefficients a(0:n/2), b(0:n/2).
  pure subroutine interpolant(reg)
    type(region_t), intent(inout) :: reg
    integer :: k, n, m
    n = reg%n
    m = n/2
    allocate (reg%a(0:m), reg%b(0:m))
    reg%a(0) = sum(reg%rho)/n
    reg%b(0) = 0
    do k = 1, m
      reg%a(k) = 2*sum(reg%rho*cos(k*reg%phi))/n
      reg%b(k) = 2*sum(reg%rho*sin(k*reg%phi))/n
    end do
    if (mod(n, 2) == 0) then      ! the Nyquist term once
      reg%a(m) = reg%a(m)/2
      reg%b(m) = reg%b(m)/2
    end if
  end subroutine interpolant

  !> The boundary radius at angle ph (the interpolant; cos k ph, sin k ph by the angle-addition
  !> recurrence).
  pure real(wp) function region_radius(reg, ph) result(r)
    type(region_t), intent(in) :: reg
    real(wp), intent(in) :: ph
    integer :: k
    real(wp) :: c1, s1, ck, sk, t
    c1 = cos(ph)
    s1 = sin(ph)
    ck = 1
    sk = 0
    r = reg%a(0)
    do k = 1, ubound(reg%a, 1)
      t = ck*c1 - sk*s1
      sk = sk*c1 + ck*s1
      ck = t
      r = r + reg%a(k)*ck + reg%b(k)*sk
    end do
  end function region_radius

  !> Is (s, ps) inside the region (its radius below the boundary's at its angle)?
  pure logical function region_inside(reg, s, ps) result(inside)
    type(region_t), intent(in) :: reg
    real(wp), intent(in) :: s, ps
    real(wp) :: u, v
    inside = .false.
    if (reg%empty .or. reg%n == 0) return
    u = (s - reg%centre(1))/reg%scale(1)
    v = (ps - reg%centre(2))/reg%scale(2)
    inside = hypot(u, v) < region_radius(reg, atan2(v, u))
  end function region_inside

  pure logical function near_boundary(reg, s, ps)
    type(region_t), intent(in) :: reg
    real(wp), intent(in) :: s, ps
    real(wp) :: u, v
    u = (s - reg%centre(1))/reg%scale(1)
    v = (ps - reg%centre(2))/reg%scale(2)
    near_boundary = abs(hypot(u, v)/region_radius(reg, atan2(v, u)) - 1) < SHELL
  end function near_boundary

  !> The boundary at m equally spaced angles (the interpolant): a closed polygon (s, p_s) for the
  !> tests of tubes_transport (inside_curve) and the plots.
  subroutine region_curve(reg, m, s, p)
    type(region_t), intent(in) :: reg
    integer, intent(in) :: m
    real(wp), allocatable, intent(out) :: s(:), p(:)
    real(wp) :: ph, r
    integer :: k
    allocate (s(m), p(m))
    do k = 1, m
      ph = (k - 1)*2*PI/m
      r = region_radius(reg, ph)
      s(k) = reg%centre(1) + r*reg%scale(1)*cos(ph)
      p(k) = reg%centre(2) + r*reg%scale(2)*sin(ph)
    end do
  end subroutine region_curve

  !> The centroid of the polygon (s, p) and its half-extents.
  pure subroutine centroid(s, p, c, half)
    real(wp), intent(in) :: s(:), p(:)
    real(wp), intent(out) :: c(2), half(2)
    real(wp) :: a, cr
    integer :: i, j
    a = 0
    c = 0
    do i = 1, size(s)
      j = mod(i, size(s)) + 1
      cr = s(i)*p(j) - s(j)*p(i)
      a = a + cr
      c = c + [s(i) + s(j), p(i) + p(j)]*cr
    end do
    c = c/(3*a)
    half = [maxval(s) - minval(s), maxval(p) - minval(p)]/2
  end subroutine centroid

  pure function interleave(a, b) result(c)
    real(wp), intent(in) :: a(:), b(:)
    real(wp) :: c(2*size(a))
    c(1::2) = a
    c(2::2) = b
  end function interleave
end module tubes_region
