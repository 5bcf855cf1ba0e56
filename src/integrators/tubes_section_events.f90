!> Surfaces of section for the rolling ball's canonical state (x, y, px, py) [cm, cm, cm/s, cm/s]
!> as events for propagate: the ray theta = theta0 oriented by the sign of the canonical angular
!> momentum p_theta (the paper's U1 = theta_line_t(theta0 = pi/4)), and the coordinate lines
!> x = c, y = c. Definitions and orientation conventions: docs/events.md.
module tubes_section_events
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
  use, intrinsic :: iso_fortran_env, only: int64
  use tubes_kinds, only: wp, PI
  use tubes_integrator, only: event_t, plane_t
  implicit none
  private

  real(wp), parameter :: QNAN = transfer(int(z'7FF8000000000000', int64), 1.0_wp)   ! a quiet NaN

  integer, parameter, public :: U1_MINUS = -1   !! U1^-: -sign(p_theta) = -1, i.e. p_theta > 0
  integer, parameter, public :: U1_PLUS = 1     !! U1^+: -sign(p_theta) = +1, i.e. p_theta < 0

  !> The ray {r > 0, theta = theta0} in the (x, y) plane. g = cos(theta0) y - sin(theta0) x
  !> (= r sin(theta - theta0), zero on the whole line through the origin); crossings of the
  !> opposite ray (x cos(theta0) + y sin(theta0) <= 0) are not crossings of the section.
  !> A crossing is oriented by the sign of p_theta = x py - y px (reported as its direction),
  !> not by the sign of dg/dt: the two can differ (docs/events.md). Select a branch with
  !> `branch`; the inherited `direction` filters on dg/dt and is normally left at 0.
  type, extends(event_t), public :: theta_line_t
    real(wp) :: theta0 = 0   !! angle of the ray from the +x axis [rad]
    integer :: branch = 0    !! +1: only p_theta > 0; -1: only p_theta < 0; 0: either
    !> cos(theta0) and sin(theta0), set by the constructor theta_line_t(theta0, ...) (NaN until
    !> then: g is NaN and propagate reports the event as failed rather than use a wrong ray)
    real(wp) :: c0 = QNAN, s0 = QNAN
  contains
    procedure :: g => theta_g
    procedure :: accept => theta_accept
    procedure :: orientation => theta_orientation
    procedure :: affine => theta_affine
  end type theta_line_t

  !> theta_line_t(theta0, branch, terminal): the ray with its cosine and sine computed once
  interface theta_line_t
    module procedure new_theta_line
  end interface theta_line_t

  public :: polar_canonical, u1_section, x_line, y_line

contains

  pure function new_theta_line(theta0, branch, terminal, direction, nsub) result(ev)
    real(wp), intent(in) :: theta0               !! angle of the ray from the +x axis [rad]
    integer, intent(in), optional :: branch      !! default 0 (either sign of p_theta)
    logical, intent(in), optional :: terminal    !! default .true. (as event_t)
    integer, intent(in), optional :: direction   !! the filter on dg/dt (event_t; default 0)
    integer, intent(in), optional :: nsub        !! interior samples per step (event_t)
    type(theta_line_t) :: ev
    ev%theta0 = theta0
    ev%c0 = cos(theta0)
    ev%s0 = sin(theta0)
    if (present(branch)) ev%branch = branch
    if (present(terminal)) ev%terminal = terminal
    if (present(direction)) ev%direction = direction
    if (present(nsub)) ev%nsub = nsub
  end function new_theta_line

  pure real(wp) function theta_g(self, t, x)
    class(theta_line_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:)
    theta_g = self%c0*x(2) - self%s0*x(1)
  end function theta_g

  !> g = w . x with w = (-sin theta0, cos theta0, 0, ...).
  pure subroutine theta_affine(self, n, w, c, ok)
    class(theta_line_t), intent(in) :: self
    integer, intent(in) :: n
    real(wp), intent(out) :: w(n), c
    logical, intent(out) :: ok
    w = 0
    c = 0
    ok = n >= 2
    if (.not. ok) return
    w(1) = -self%s0
    w(2) = self%c0
  end subroutine theta_affine

  !> On the ray r > 0, and p_theta of the requested branch (p_theta = 0 belongs to neither).
  pure logical function theta_accept(self, t, x)
    class(theta_line_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:)
    real(wp) :: pth
    theta_accept = .false.
    if (size(x) < 4) return   ! not a canonical (x, y, px, py) state
    theta_accept = self%c0*x(1) + self%s0*x(2) > 0
    if (.not. theta_accept .or. self%branch == 0) return
    pth = x(1)*x(4) - x(2)*x(3)
    theta_accept = (self%branch > 0 .and. pth > 0) .or. (self%branch < 0 .and. pth < 0)
  end function theta_accept

  !> The branch of a crossing: sign(p_theta) (0 only if p_theta is exactly 0).
  pure integer function theta_orientation(self, t, x, slope)
    class(theta_line_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:)
    integer, intent(in) :: slope
    real(wp) :: pth
    theta_orientation = 0
    if (size(x) < 4) return
    pth = x(1)*x(4) - x(2)*x(3)
    theta_orientation = merge(1, merge(-1, 0, pth < 0), pth > 0)
  end function theta_orientation

  !> Polar canonical coordinates of a state (x, y, px, py): [r, theta, p_r, p_theta] with
  !> r = |(x, y)| [cm], theta = atan2(y, x) [rad] in (-pi, pi], p_r = (x px + y py)/r [cm/s]
  !> (momentum conjugate to r), p_theta = x py - y px [cm^2/s] (conjugate to theta). The point
  !> transformation q = r (cos theta, sin theta) gives p_r = p . dq/dr, p_theta = p . dq/dtheta.
  !> At r = 0, p_r is undefined and returned as NaN.
  pure function polar_canonical(x) result(pc)
    real(wp), intent(in) :: x(4)   !! (x, y, px, py)
    real(wp) :: pc(4)              !! (r, theta, p_r, p_theta)
    pc(1) = hypot(x(1), x(2))
    pc(2) = atan2(x(2), x(1))
    if (pc(1) > 0) then
      pc(3) = (x(1)*x(3) + x(2)*x(4))/pc(1)
    else
      pc(3) = ieee_value(1.0_wp, ieee_quiet_nan)
    end if
    pc(4) = x(1)*x(4) - x(2)*x(3)
  end function polar_canonical

  !> The paper's section U1^pm = {theta = pi/4, -sign(p_theta) = pm} (first-quadrant ray):
  !> pm = U1_MINUS (-1) is the p_theta > 0 branch, U1_PLUS (+1) the p_theta < 0 branch,
  !> 0 both.
  pure function u1_section(pm, terminal) result(ev)
    integer, intent(in) :: pm                  !! U1_MINUS, U1_PLUS or 0
    logical, intent(in), optional :: terminal  !! default .true. (as event_t)
    type(theta_line_t) :: ev
    ev = theta_line_t(PI/4, -pm, terminal)
  end function u1_section

  !> The line x = c (state component 1); direction +1: dx/dt > 0, -1: dx/dt < 0, 0 (default).
  pure function x_line(c, direction, terminal) result(ev)
    real(wp), intent(in) :: c                  !! level [cm]
    integer, intent(in), optional :: direction
    logical, intent(in), optional :: terminal  !! default .true.
    type(plane_t) :: ev
    ev = coordinate_line(1, c, direction, terminal)
  end function x_line

  !> The line y = c (state component 2); direction as x_line's for dy/dt.
  pure function y_line(c, direction, terminal) result(ev)
    real(wp), intent(in) :: c                  !! level [cm]
    integer, intent(in), optional :: direction
    logical, intent(in), optional :: terminal  !! default .true.
    type(plane_t) :: ev
    ev = coordinate_line(2, c, direction, terminal)
  end function y_line

  pure function coordinate_line(k, c, direction, terminal) result(ev)
    integer, intent(in) :: k
    real(wp), intent(in) :: c
    integer, intent(in), optional :: direction
    logical, intent(in), optional :: terminal
    type(plane_t) :: ev
    ev%k = k
    ev%c = c
    if (present(direction)) ev%direction = direction
    if (present(terminal)) ev%terminal = terminal
  end function coordinate_line
end module tubes_section_events
