!> Transition fractions from tube dynamics: the tube cut's area over the energy surface's area
!> on the section (p_trans), the paper's leading-order formula, the Monte Carlo check by direct
!> integration, and Poincare maps of the section. Theory: docs/tubes.md.
module tubes_transport
  use, intrinsic :: iso_c_binding, only: c_int, c_double, c_long
  use tubes_kinds, only: wp
  use tubes_status, only: TUBES_OK, TUBES_EINPUT, TUBES_EVENT, TUBES_ENOCONV, TUBES_EFAULT
  use tubes_par, only: par_t, par_here, par_share, par_bcast, par_fault_item
  use tubes_ball, only: ball_t
  use tubes_integrator, only: integrator_t, observer_t, propagate, crossing_log_t
  use tubes_dop853, only: dop853_t
  use tubes_sections, only: theta_line_t, polar_canonical
  use tubes_section, only: ray_t, section_region, section_area, section_darea, p_theta_from, &
                           boundary_pr
  implicit none
  private

  integer, parameter, public :: MC_RETURN = 0    !! came back to the section: no transition
  integer, parameter, public :: MC_TRANSIT = 1   !! entered the other well through the bottleneck
  integer, parameter, public :: MC_UNDECIDED = 2 !! neither within t_max

  !> Stops an integration once x(1) passes below a line x = x_stop (the other well's side).
  type, extends(observer_t) :: gate_t
    real(wp) :: x_stop = 0
    logical :: passed = .false.
  contains
    procedure :: on_step => gate_on_step
  end type gate_t

  public :: state_on_section, inside_curve, mc_classify, monte_carlo, poincare_map

  interface
    integer(c_int) function rng_uniform(seed, n, u) bind(C, name='tubes_rng_uniform')
      import :: c_int, c_double, c_long
      integer(c_long), value :: seed
      integer(c_int), value :: n
      real(c_double), intent(out) :: u(*)
    end function rng_uniform
  end interface

contains

  subroutine gate_on_step(self, ig, t_hi, stop_now)
    class(gate_t), intent(inout) :: self
    class(integrator_t), intent(inout) :: ig
    real(wp), intent(in) :: t_hi
    logical, intent(out) :: stop_now
    real(wp) :: x(4)
    call ig%interp(t_hi, x)
    stop_now = x(1) < self%x_stop
    if (stop_now) self%passed = .true.
  end subroutine gate_on_step

  !> The Cartesian state at (r, p_r) on the ray's section with p_theta of sign branch.
  subroutine state_on_section(ray, r, pr, branch, x, stat)
    type(ray_t), intent(in) :: ray
    real(wp), intent(in) :: r, pr
    integer, intent(in) :: branch
    real(wp), intent(out) :: x(4)
    integer, intent(out) :: stat
    real(wp) :: pth, c, s
    call p_theta_from(ray, r, pr, branch, pth, stat)
    c = cos(ray%theta0)
    s = sin(ray%theta0)
    x = [r*c, r*s, c*pr - s*pth/r, s*pr + c*pth/r]
  end subroutine state_on_section

  !> Point-in-polygon (even-odd rule) for the closed curve (cr, cp).
  pure logical function inside_curve(r, p, cr, cp) result(inside)
    real(wp), intent(in) :: r, p, cr(:), cp(:)
    integer :: i, j
    inside = .false.
    j = size(cr)
    do i = 1, size(cr)
      if ((cp(i) > p) .neqv. (cp(j) > p)) then
        if (r < (cr(j) - cr(i))*(p - cp(i))/(cp(j) - cp(i)) + cr(i)) inside = .not. inside
      end if
      j = i
    end do
  end function inside_curve

  !> Follow the state x0 (on the section) forward until it returns to the section (either
  !> branch: MC_RETURN) or passes x < x_stop (MC_TRANSIT), or t_max (MC_UNDECIDED).
  subroutine mc_classify(ball, theta0, x0, x_stop, t_max, tol, outcome, t_end, stat)
    type(ball_t), intent(in) :: ball
    real(wp), intent(in) :: theta0, x0(4), x_stop, t_max, tol
    integer, intent(out) :: outcome
    real(wp), intent(out) :: t_end
    integer, intent(out) :: stat
    type(dop853_t) :: ig
    type(gate_t) :: gate
    real(wp) :: x(4)
    call ig%init(ball, 0.0_wp)
    ig%rtol = tol
    ig%atol = tol
    x = x0
    gate%x_stop = x_stop
    call propagate(ig, x, t_max, stat, event=theta_line_t(theta0=theta0, branch=0, terminal=.true.), &
                   observer=gate)
    t_end = ig%t
    if (stat == TUBES_EVENT) then
      outcome = MC_RETURN
      stat = TUBES_OK
    else if (gate%passed) then
      outcome = MC_TRANSIT
    else
      outcome = MC_UNDECIDED
    end if
  end subroutine mc_classify

  !> Monte Carlo transition fraction: n points uniform in the permitted region of the ray's
  !> section at the ray's energy (rejection in the bounding box, GSL MT19937 from seed, drawn
  !> serially), each with p_theta of sign branch, integrated in parallel (OpenMP) and classified.
  !> The cut (cr, cp) gives each point's predicted class (inside = transit).
  subroutine monte_carlo(ray, n, seed, branch, x_stop, t_max, tol, cr, cp, r, pr, outcome, &
                         inside, stat)
    type(ray_t), intent(in) :: ray
    integer, intent(in) :: n, branch
    integer(c_long), intent(in) :: seed
    real(wp), intent(in) :: x_stop, t_max, tol, cr(:), cp(:)
    real(wp), intent(out) :: r(n), pr(n)
    integer, intent(out) :: outcome(n)
    logical, intent(out) :: inside(n)
    integer, intent(out) :: stat
    real(wp), allocatable :: u(:)
    real(wp) :: pmax, rr, pp_, x(4), te
    integer :: k, m, i, st(n), kf
    type(par_t) :: pp
    stat = TUBES_OK
    if (n < 1) then
      stat = TUBES_EINPUT
      return
    end if
    pmax = 0
    do i = 0, 2000
      pmax = max(pmax, boundary_pr(ray, ray%rmin + (ray%rmax - ray%rmin)*i/2000.0_wp))
    end do
    pmax = pmax*1.01_wp
    m = 0
    k = 0
    allocate (u(8*n + 64))
    stat = rng_uniform(seed, size(u), u)
    do while (m < n)
      if (k + 2 > size(u)) then            ! rare: draw more from the same stream's seed + 1
        stat = rng_uniform(seed + k, size(u), u)
        k = 0
      end if
      rr = ray%rmin + (ray%rmax - ray%rmin)*u(k + 1)
      pp_ = pmax*(2*u(k + 2) - 1)
      k = k + 2
      if (abs(pp_) < boundary_pr(ray, rr)) then
        m = m + 1
        r(m) = rr
        pr(m) = pp_
      end if
    end do
    ! the samples are dealt out over MPI ranks (tubes_par), and over threads inside a rank;
    ! a failed sample keeps its status as its outcome
    call par_bcast(r)
    call par_bcast(pr)
    pp = par_here()
    kf = par_fault_item('sample')
    outcome = MC_UNDECIDED
    inside = .false.
    st = TUBES_OK
    !$omp parallel do schedule(dynamic) default(shared) private(i, x, te)
    do i = 1, n
      if (.not. pp%mine(i)) cycle
      if (i == kf) then
        st(i) = TUBES_EFAULT
      else
        call state_on_section(ray, r(i), pr(i), branch, x, st(i))
        if (st(i) == TUBES_OK) call mc_classify(ray%ball, ray%theta0, x, x_stop, t_max, tol, outcome(i), te, st(i))
      end if
      if (st(i) < 0) outcome(i) = st(i)
      inside(i) = inside_curve(r(i), pr(i), cr, cp)
    end do
    !$omp end parallel do
    call par_share(outcome)
    call par_share(inside)
    call par_share(st)
    stat = min(0, minval(st))
  end subroutine monte_carlo

  !> Poincare map of the section branch: n_iter returns of each start state x0(:, j), recorded
  !> as (r, p_r) in pts(:, k, j) (NaN after a trajectory stops returning within t_max).
  subroutine poincare_map(ball, theta0, branch, x0, n_iter, t_max, tol, pts, stat)
    use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
    type(ball_t), intent(in) :: ball
    real(wp), intent(in) :: theta0, x0(:, :), t_max, tol
    integer, intent(in) :: branch, n_iter
    real(wp), intent(out) :: pts(2, n_iter, size(x0, 2))
    integer, intent(out) :: stat
    real(wp) :: xs(4, size(x0, 2))
    integer :: j, st(size(x0, 2)), kf
    type(par_t) :: pp
    xs = x0
    call par_bcast(xs)                  ! seeds dealt out over MPI ranks (tubes_par)
    pp = par_here()
    kf = par_fault_item('map')
    pts = 0
    st = TUBES_OK
    !$omp parallel do schedule(dynamic) default(shared) private(j)
    do j = 1, size(x0, 2)
      if (.not. pp%mine(j)) cycle
      if (j == kf) then
        st(j) = TUBES_EFAULT
        pts(:, :, j) = ieee_value(1.0_wp, ieee_quiet_nan)
        cycle
      end if
      call one_map(ball, theta0, branch, xs(:, j), n_iter, t_max, tol, pts(:, :, j), st(j))
    end do
    !$omp end parallel do
    call par_share(pts)
    call par_share(st)
    stat = min(0, minval(st))
  end subroutine poincare_map

  !> The returns of one trajectory (all locals: thread-private by construction).
  subroutine one_map(ball, theta0, branch, x0, n_iter, t_max, tol, pts, stat)
    use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
    type(ball_t), intent(in) :: ball
    real(wp), intent(in) :: theta0, x0(4), t_max, tol
    integer, intent(in) :: branch, n_iter
    real(wp), intent(out) :: pts(2, n_iter)
    integer, intent(out) :: stat
    type(crossing_log_t) :: log
    type(dop853_t) :: ig
    real(wp) :: x(4), pc(4)
    integer :: k
    pts = ieee_value(1.0_wp, ieee_quiet_nan)
    call ig%init(ball, 0.0_wp)
    ig%rtol = tol
    ig%atol = tol
    ig%max_steps = 100000000
    x = x0
    log%max_crossings = n_iter
    call propagate(ig, x, t_max, stat, event=theta_line_t(theta0=theta0, branch=branch, &
                   terminal=.false.), crossings=log)
    if (stat == TUBES_EVENT) stat = TUBES_OK
    do k = 1, min(log%n, n_iter)
      pc = polar_canonical(log%x(:, k))
      pts(:, k) = [pc(1), pc(3)]
    end do
  end subroutine one_map
end module tubes_transport
