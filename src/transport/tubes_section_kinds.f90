!> Poincare sections of 2-DOF models for the tube dynamics scenes, one type for both kinds:
!> - SEC_RAY: the rolling ball's polar ray theta = theta0 (the paper's U1), in the canonical
!>   coordinates (r, p_r), the branch chosen by the sign of p_theta (tubes_ray_surface, tubes_section_events);
!> - SEC_PLANE: the plane q_k = c of any model whose H is quadratic in the momenta, in the
!>   canonical coordinates (s, p_s) = (q_j, p_j), j /= k, crossed with sign(dq_k/dt) = direction.
!> At an energy E the section's region is the set of (s, p_s) where a p_k with H = E exists; on
!> a plane, with H = 1/2 p^T A p + b . p + V at fixed q, that is D(p_s) >= 0 for the quadratic
!> D = (A_jk p_s + b_k)^2 - A_kk (A_jj p_s^2 + 2 b_j p_s + 2 (V - E)), and then
!> dq_k/dt = +-sqrt(D): the direction picks the root. The region is taken on the interval of s
!> that contains (or is nearest to) the saddle's s. Its area A_E and dA_E/dE are GSL quadratures.
!> Theory: docs/tubes.md, "Sections".
module tubes_section_kinds
  use, intrinsic :: iso_c_binding, only: c_double, c_int, c_ptr, c_loc, c_f_pointer, c_funptr, c_funloc
  use tubes_kinds, only: wp, PI
  use tubes_hamiltonian, only: hamiltonian_t, quadratic_parts, quadratic_in_p
  use tubes_ball, only: ball_t
  use tubes_integrator, only: event_t, plane_t
  use tubes_section_events, only: theta_line_t, polar_canonical
  use tubes_ray_surface, only: ray_t, section_region, section_area, boundary_pr, &
                           p_theta_from
  use tubes_quad, only: quad_area, quad_root
  use tubes_status, only: TUBES_OK, TUBES_EINPUT, TUBES_ENOCONV, TUBES_ENOREGION
  implicit none
  private

  integer, parameter, public :: SEC_RAY = 1     !! the ball's polar ray
  integer, parameter, public :: SEC_PLANE = 2   !! the plane q_k = c

  !> A section with its energy and region.
  type, public :: poincare_t
    integer :: kind = SEC_PLANE
    class(hamiltonian_t), allocatable :: model  !! the model (SEC_PLANE)
    type(ray_t) :: ray                          !! SEC_RAY: the ball, the ray, energy, [rmin, rmax]
    integer :: branch = 1                       !! the crossing direction: ray: sign(p_theta);
                                                !! plane: sign(dq_k/dt)
    integer :: k = 1                            !! plane: q_k = c
    real(wp) :: c = 0
    real(wp) :: energy = 0                      !! E of the region
    real(wp) :: smin = 0, smax = 0              !! the region's interval of s
    real(wp) :: s_anchor = 0                    !! plane: the interval holds (or is nearest) it
    real(wp) :: s_lo = -1, s_hi = 1             !! plane: where intervals are searched
    integer :: mode = 0                         !! quadrature integrand: 0 area, 1 dA/dE
  contains
    procedure :: event => sec_event             !! the crossings of the branch
    procedure :: return_event => sec_return     !! any crossing (both directions)
    procedure :: coords => sec_coords           !! (s, p_s) of a state on the section
    procedure :: state => sec_state             !! the state at (s, p_s) on the branch
    procedure :: set_energy => sec_set_energy   !! the region's interval at E
    procedure :: bounds => sec_bounds           !! p_s range of the region at s
    procedure :: area => sec_area               !! A_E, or dA_E/dE
  end type poincare_t

  public :: make_ray_section, make_plane_section, plane_search_range, plane_quadratic_in_p, make_plane_crossing


contains

  !> The ball's ray theta0 [rad], branch = sign of p_theta.
  subroutine make_ray_section(sec, ball, theta0, branch)
    type(poincare_t), intent(out) :: sec
    type(ball_t), intent(in) :: ball
    real(wp), intent(in) :: theta0
    integer, intent(in) :: branch
    sec%kind = SEC_RAY
    sec%ray%ball = ball
    sec%ray%theta0 = theta0
    sec%branch = branch
  end subroutine make_ray_section

  !> The plane q_k = c of a 2-DOF model, crossed with sign(dq_k/dt) = direction; intervals of
  !> s are searched in [s_lo, s_hi] and the one holding (or nearest) s_anchor is the region.
  subroutine make_plane_section(sec, model, k, c, direction, s_anchor, s_lo, s_hi, stat)
    type(poincare_t), intent(out) :: sec
    class(hamiltonian_t), intent(in) :: model
    integer, intent(in) :: k, direction
    real(wp), intent(in) :: c, s_anchor, s_lo, s_hi
    integer, intent(out) :: stat
    stat = TUBES_EINPUT
    if (model%ndof() /= 2 .or. k < 1 .or. k > 2 .or. abs(direction) /= 1 .or. .not. s_hi > s_lo) return
    if (.not. plane_quadratic_in_p(model, k, c, s_lo, s_hi)) return   ! the region's D(p_s) would be wrong
    call make_plane_crossing(sec, 2, k, c, direction, stat)            ! the plane itself (TUBES_OK here)
    allocate (sec%model, source=model)
    sec%s_anchor = s_anchor
    sec%s_lo = s_lo
    sec%s_hi = s_hi
  end subroutine make_plane_section

  !> The plane q_k = c of a model with any number N of degrees of freedom, crossed with
  !> sign(dq_k/dt) = direction, for its crossings alone (event, return_event): no region, no
  !> energy, no (s, p_s) (the tube cuts of N > 2 take the pairs (q_j, p_j), j /= k:
  !> tubes_manifold cut_coords). TUBES_EINPUT for k outside 1 .. N or a direction not +-1.
  subroutine make_plane_crossing(sec, ndof, k, c, direction, stat)
    type(poincare_t), intent(out) :: sec
    integer, intent(in) :: ndof, k, direction
    real(wp), intent(in) :: c
    integer, intent(out) :: stat
    stat = TUBES_EINPUT
    if (k < 1 .or. k > ndof .or. abs(direction) /= 1) return
    sec%kind = SEC_PLANE
    sec%k = k
    sec%c = c
    sec%branch = direction
    stat = TUBES_OK
  end subroutine make_plane_crossing

  !> The interval of s = q_j (j /= k) searched for the region of the plane q_k = c: the
  !> &equilibria box [lo(j), hi(j)] widened by half its width on each side.
  pure subroutine plane_search_range(lo, hi, k, s_lo, s_hi)
    real(wp), intent(in) :: lo(:), hi(:)
    integer, intent(in) :: k
    real(wp), intent(out) :: s_lo, s_hi
    integer :: j
    j = 3 - k
    s_lo = lo(j) - (hi(j) - lo(j))/2
    s_hi = hi(j) + (hi(j) - lo(j))/2
  end subroutine plane_search_range

  !> Whether H is quadratic in the momenta on the plane q_k = c of a 2-DOF model (the premise of
  !> the plane's region {D(p_s) >= 0}): quadratic_in_p at 17 points of s in [s_lo, s_hi] where H
  !> is defined there (a singular point, a primary of the CR3BP, is passed over); .false. if it is
  !> defined at none.
  logical function plane_quadratic_in_p(model, k, c, s_lo, s_hi) result(ok)
    class(hamiltonian_t), intent(in) :: model
    integer, intent(in) :: k
    real(wp), intent(in) :: c, s_lo, s_hi
    integer, parameter :: NPT = 17
    real(wp) :: q(2), a(2, 2), pc(2), v
    integer :: i, st, ndef
    ok = .false.
    if (model%ndof() /= 2 .or. k < 1 .or. k > 2) return
    ndef = 0
    do i = 0, NPT - 1
      q(k) = c
      q(3 - k) = s_lo + (s_hi - s_lo)*(i + 0.5_wp)/NPT
      call quadratic_parts(model, q, a, pc, v, st)
      if (st /= 0) cycle
      ndef = ndef + 1
      if (.not. quadratic_in_p(model, q)) return
    end do
    ok = ndef > 0
  end function plane_quadratic_in_p

  !> (A subroutine, not a function: gfortran 12 leaks a polymorphic allocatable function result
  !> after the assignment; make sanitize found 1 MB per paper run.)
  subroutine sec_event(self, terminal, ev)
    class(poincare_t), intent(in) :: self
    logical, intent(in) :: terminal
    class(event_t), allocatable, intent(out) :: ev
    if (self%kind == SEC_RAY) then
      allocate (ev, source=theta_line_t(theta0=self%ray%theta0, branch=self%branch, terminal=terminal))
    else
      allocate (ev, source=plane_t(k=self%k, c=self%c, direction=self%branch, terminal=terminal))
    end if
  end subroutine sec_event

  subroutine sec_return(self, ev)
    class(poincare_t), intent(in) :: self
    class(event_t), allocatable, intent(out) :: ev
    if (self%kind == SEC_RAY) then
      allocate (ev, source=theta_line_t(theta0=self%ray%theta0, branch=0, terminal=.true.))
    else
      allocate (ev, source=plane_t(k=self%k, c=self%c, direction=0, terminal=.true.))
    end if
  end subroutine sec_return

  !> (s, p_s): ray (r, p_r); plane (q_j, p_j).
  pure function sec_coords(self, x) result(sp)
    class(poincare_t), intent(in) :: self
    real(wp), intent(in) :: x(:)
    real(wp) :: sp(2), pc(4)
    if (self%kind == SEC_RAY) then
      pc = polar_canonical(x(1:4))
      sp = [pc(1), pc(3)]
    else
      sp = [x(3 - self%k), x(5 - self%k)]
    end if
  end function sec_coords

  !> H = 1/2 p^T a p + b . p + v at configuration q (exact for H quadratic in p).
  subroutine quad_form(model, q, a, b, v, stat)
    class(hamiltonian_t), intent(in) :: model
    real(wp), intent(in) :: q(2)
    real(wp), intent(out) :: a(2, 2), b(2), v
    integer, intent(out) :: stat
    real(wp) :: x(4), g(4), h(4, 4)
    x = [q, 0.0_wp, 0.0_wp]
    v = model%energy(x)
    call model%gradient(x, g, stat)
    if (stat /= 0) return
    call model%hessian(x, h, stat)
    if (stat /= 0) return
    b = g(3:4)
    a = h(3:4, 3:4)
  end subroutine quad_form

  !> The quadratic D(p_s) = d2 p_s^2 + d1 p_s + d0 at s (plane; see the module comment), and the
  !> coefficients of dq_k/dt = A_kk p_k + A_jk p_s + b_k.
  subroutine plane_quadratic(sec, s, d2, d1, d0, akk, ajk, bk, stat)
    type(poincare_t), intent(in) :: sec
    real(wp), intent(in) :: s
    real(wp), intent(out) :: d2, d1, d0, akk, ajk, bk
    integer, intent(out) :: stat
    real(wp) :: q(2), a(2, 2), b(2), v, ajj, bj
    integer :: j
    j = 3 - sec%k
    q(sec%k) = sec%c
    q(j) = s
    call quad_form(sec%model, q, a, b, v, stat)
    akk = a(sec%k, sec%k)
    ajk = a(j, sec%k)
    ajj = a(j, j)
    bk = b(sec%k)
    bj = b(j)
    d2 = ajk**2 - akk*ajj
    d1 = 2*(ajk*bk - akk*bj)
    d0 = bk**2 - 2*akk*(v - sec%energy)
    if (stat == 0 .and. .not. (akk > 0 .and. d2 < 0)) stat = -1   ! not positive definite
  end subroutine plane_quadratic

  !> The discriminant of D: the region at s is non-empty where it is >= 0.
  real(wp) function plane_disc(sec, s) result(dd)
    type(poincare_t), intent(in) :: sec
    real(wp), intent(in) :: s
    real(wp) :: d2, d1, d0, akk, ajk, bk
    integer :: st
    call plane_quadratic(sec, s, d2, d1, d0, akk, ajk, bk, st)
    dd = -huge(1.0_wp)
    if (st == 0) dd = d1*d1 - 4*d2*d0
  end function plane_disc

  real(c_double) function f_disc(s, user) bind(C)
    real(c_double), value :: s
    type(c_ptr), value :: user
    type(poincare_t), pointer :: sec
    call c_f_pointer(user, sec)
    f_disc = plane_disc(sec, s)
  end function f_disc

  !> The p_s range [pmin, pmax] of the region at s (empty: pmin = pmax = the centre).
  subroutine sec_bounds(self, s, pmin, pmax)
    class(poincare_t), intent(in) :: self
    real(wp), intent(in) :: s
    real(wp), intent(out) :: pmin, pmax
    real(wp) :: d2, d1, d0, akk, ajk, bk, dd, mid, half
    integer :: st
    if (self%kind == SEC_RAY) then
      pmax = boundary_pr(self%ray, s)
      pmin = -pmax
      return
    end if
    call plane_quadratic(self, s, d2, d1, d0, akk, ajk, bk, st)
    pmin = 0
    pmax = 0
    if (st /= 0) return
    dd = d1*d1 - 4*d2*d0
    mid = -d1/(2*d2)
    half = sqrt(max(dd, 0.0_wp))/(2*abs(d2))
    pmin = mid - half
    pmax = mid + half
  end subroutine sec_bounds

  !> The state at (s, p_s) on the section's branch with the section's energy.
  !> stat = TUBES_EINPUT outside the region.
  subroutine sec_state(self, s, ps, x, stat)
    class(poincare_t), intent(in) :: self
    real(wp), intent(in) :: s, ps
    real(wp), intent(out) :: x(:)
    integer, intent(out) :: stat
    real(wp) :: pth, cs, sn, d2, d1, d0, akk, ajk, bk, dd, pk
    integer :: j
    if (self%kind == SEC_RAY) then
      call p_theta_from(self%ray, s, ps, self%branch, pth, stat)
      cs = cos(self%ray%theta0)
      sn = sin(self%ray%theta0)
      x(1:4) = [s*cs, s*sn, cs*ps - sn*pth/s, sn*ps + cs*pth/s]
      return
    end if
    x = 0
    call plane_quadratic(self, s, d2, d1, d0, akk, ajk, bk, stat)
    if (stat /= 0) then
      stat = TUBES_EINPUT
      return
    end if
    dd = d2*ps*ps + d1*ps + d0
    if (dd < 0) then
      stat = TUBES_EINPUT
      return
    end if
    ! A_kk p_k + A_jk p_s + b_k = direction sqrt(D)
    pk = (self%branch*sqrt(dd) - ajk*ps - bk)/akk
    j = 3 - self%k
    x(self%k) = self%c
    x(j) = s
    x(2 + self%k) = pk
    x(2 + j) = ps
    stat = TUBES_OK
  end subroutine sec_state

  !> The region's interval at energy E. Ray: around the well on the ray (section_region, out to
  !> rfar). Plane: the intervals where the discriminant is >= 0 on a grid of [s_lo, s_hi],
  !> refined by Brent; the one holding s_anchor, else the nearest. Plane: stat = TUBES_ENOREGION if
  !> no interval, or the one kept reaches an end of [s_lo, s_hi] (unbounded, or wider than the
  !> window); ray: TUBES_EINPUT if the
  !> energy surface does not meet the section there.
  subroutine sec_set_energy(self, energy, rfar, stat)
    class(poincare_t), intent(inout) :: self
    real(wp), intent(in) :: energy
    real(wp), intent(in) :: rfar      !! ray: outer end of the search [cm]
    integer, intent(out) :: stat
    stat = TUBES_EINPUT
    select type (self)
    type is (poincare_t)
      call set_energy_impl(self, energy, rfar, stat)
    end select
  end subroutine sec_set_energy

  subroutine set_energy_impl(self, energy, rfar, stat)
    type(poincare_t), intent(inout), target :: self
    real(wp), intent(in) :: energy
    real(wp), intent(in) :: rfar
    integer, intent(out) :: stat
    integer, parameter :: NGRID = 4000
    real(wp) :: a, b, fa, fb, best, lo, r
    integer :: i, st
    logical :: inside, open
    self%energy = energy
    if (self%kind == SEC_RAY) then
      self%ray%energy = energy
      call section_region(self%ray, rfar, stat)
      self%smin = self%ray%rmin
      self%smax = self%ray%rmax
      return
    end if
    stat = TUBES_ENOREGION
    best = huge(1.0_wp)
    inside = .false.
    a = self%s_lo
    fa = plane_disc(self, a)
    open = fa >= 0
    lo = a
    do i = 1, NGRID
      b = self%s_lo + (self%s_hi - self%s_lo)*i/NGRID
      fb = plane_disc(self, b)
      if (.not. open .and. fb >= 0) then         ! an interval opens in (a, b]
        st = quad_root(c_funloc(f_disc), c_loc(self), a, b, 0.0_wp, 1.0e-15_wp, r)
        lo = merge(r, b, st == 0)
        open = .true.
      else if (open .and. fb < 0) then           ! ... and closes
        st = quad_root(c_funloc(f_disc), c_loc(self), a, b, 0.0_wp, 1.0e-15_wp, r)
        call consider(lo, merge(r, a, st == 0))
        open = .false.
      end if
      a = b
      fa = fb
    end do
    if (open) call consider(lo, self%s_hi)
    if (inside) stat = TUBES_OK
    ! a region that reaches the ends of the search is unbounded or larger than the box: its
    ! area would be the search window's, not the energy surface's
    if (inside .and. (self%smin <= self%s_lo .or. self%smax >= self%s_hi)) stat = TUBES_ENOREGION
  contains
    subroutine consider(l, h)      ! keep the interval holding, or nearest to, s_anchor
      real(wp), intent(in) :: l, h
      real(wp) :: d
      if (.not. h > l) return
      d = 0
      if (self%s_anchor < l .or. self%s_anchor > h) d = min(abs(self%s_anchor - l), abs(self%s_anchor - h))
      if (d < best) then
        best = d
        self%smin = l
        self%smax = h
        inside = .true.
      end if
    end subroutine consider
  end subroutine set_energy_impl

  !> Integrand after s = smin + (smax - smin)(1 - cos phi)/2: mode 0 the width of the region
  !> at s (A_E), mode 1 its derivative in E (dA_E/dE).
  real(c_double) function f_plane(phi, user) bind(C)
    real(c_double), value :: phi
    type(c_ptr), value :: user
    type(poincare_t), pointer :: sec
    real(wp) :: s, dsdphi, d2, d1, d0, akk, ajk, bk, dd
    integer :: st
    call c_f_pointer(user, sec)
    s = sec%smin + (sec%smax - sec%smin)*(1 - cos(phi))/2
    dsdphi = (sec%smax - sec%smin)*sin(phi)/2
    call plane_quadratic(sec, s, d2, d1, d0, akk, ajk, bk, st)
    dd = max(d1*d1 - 4*d2*d0, 0.0_wp)
    if (st /= 0) then
      f_plane = 0
    else if (sec%mode == 0) then
      f_plane = sqrt(dd)/abs(d2)*dsdphi                ! width p_s+ - p_s-
    else if (dd > 0) then
      f_plane = 4*akk/sqrt(dd)*dsdphi                  ! d/dE of the width
    else
      f_plane = 0
    end if
  end function f_plane

  !> A_E, the area of the region [units of s x p_s], or with derivative its dA_E/dE [time] (GSL
  !> QAGS to relative 1e-12).
  subroutine sec_area(self, area, abserr, stat, derivative)
    class(poincare_t), intent(inout) :: self
    real(wp), intent(out) :: area, abserr
    integer, intent(out) :: stat
    logical, intent(in), optional :: derivative
    logical :: d
    area = 0
    abserr = 0
    stat = TUBES_EINPUT
    d = .false.
    if (present(derivative)) d = derivative
    select type (self)
    type is (poincare_t)                 ! the section's own type (not an extension) to quad_impl
      call quad_impl(self, d, area, abserr, stat)
    end select
  end subroutine sec_area

  !> A_E, or with derivative dA_E/dE.
  subroutine quad_impl(self, derivative, res, abserr, stat)
    type(poincare_t), intent(inout), target :: self
    logical, intent(in) :: derivative
    real(wp), intent(out) :: res, abserr
    integer, intent(out) :: stat
    if (self%kind == SEC_RAY) then
      call section_area(self%ray, res, abserr, stat, derivative)
      return
    end if
    self%mode = merge(1, 0, derivative)
    stat = quad_area(c_funloc(f_plane), c_loc(self), 0.0_wp, PI, res, abserr)
    if (stat /= 0) stat = TUBES_ENOCONV
  end subroutine quad_impl
end module tubes_section_kinds
