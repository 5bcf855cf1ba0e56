!> Transition fractions from tube dynamics: the tube cut's area over the energy surface's area
!> on the section (p_trans), the paper's leading-order formula, the Monte Carlo check by direct
!> integration, and Poincare maps of the section. Theory: docs/tubes.md.
module tubes_transport
  use, intrinsic :: iso_c_binding, only: c_int, c_double, c_long
  use tubes_kinds, only: wp
  use tubes_status, only: TUBES_OK, TUBES_EINPUT, TUBES_EVENT, TUBES_ENOCONV, TUBES_EFAULT
  use tubes_par, only: par_t, par_here, par_share, par_bcast, par_fault_item
  use tubes_hamiltonian, only: hamiltonian_t
  use tubes_integrator, only: integrator_t, observer_t, propagate, crossing_log_t
  use tubes_methods, only: integ_choice_t, make_integrator, uses_taylor
  use tubes_integrator, only: event_t
  use tubes_lanes, only: lane_t, lane_jobs_t, run_lanes_chunked, LANES
  use tubes_section_kinds, only: poincare_t
  implicit none
  private

  integer, parameter, public :: MC_RETURN = 0    !! came back to the section: no transition
  integer, parameter, public :: MC_TRANSIT = 1   !! entered the other well through the bottleneck
  integer, parameter, public :: MC_UNDECIDED = 2 !! neither within t_max

  !> The transit gate of a saddle: the configuration hyperplane (q - q_s) . n = dist, n the
  !> unit configuration part of the saddle's unstable eigenvector (its reaction coordinate)
  !> pointing away from the section's well. Stops an integration once a step ends beyond it.
  type, public :: gate_spec_t
    real(wp), allocatable :: origin(:)   !! the saddle's configuration q_s
    real(wp), allocatable :: normal(:)   !! unit normal n, towards the other side
    real(wp) :: dist = 0                 !! distance past the saddle [units of q]
  end type gate_spec_t

  type, extends(observer_t) :: gate_t
    type(gate_spec_t) :: spec
    logical :: passed = .false.
  contains
    procedure :: on_step => gate_on_step
  end type gate_t

  !> The Monte Carlo's points as the Taylor method's lanes' items (src/integrators/tubes_lanes.f90):
  !> each set up and classified as mc_classify does.
  type, extends(lane_jobs_t) :: mc_jobs_t
    class(hamiltonian_t), allocatable :: model
    type(poincare_t) :: psec
    type(gate_spec_t) :: gspec
    type(integ_choice_t) :: integ
    real(wp) :: t_max = 0, tol = 0
    real(wp), allocatable :: r(:), pr(:)
    integer, allocatable :: outcome(:), st(:)
  contains
    procedure :: start => mc_start
    procedure :: finish => mc_finish
  end type mc_jobs_t

  !> The Poincare map's seeds as lanes' items: each as one_map integrates it.
  type, extends(lane_jobs_t) :: map_jobs_t
    class(hamiltonian_t), allocatable :: model
    type(poincare_t) :: psec
    type(integ_choice_t) :: integ
    real(wp) :: t_max = 0, tol = 0
    integer :: n_iter = 0
    real(wp), allocatable :: x0(:, :), pts(:, :, :)
    integer, allocatable :: st(:)
  contains
    procedure :: start => map_start
    procedure :: finish => map_finish
  end type map_jobs_t

  !> Items of an ensemble per call of run_lanes (an OpenMP thread's unit of work)
  integer, parameter :: LANE_CHUNK = 64

  public :: inside_curve, mc_classify, monte_carlo, poincare_map, rng_uniform

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
    real(wp) :: x(ig%f%dim())
    integer :: n
    n = size(self%spec%normal)
    call ig%interp(t_hi, x)
    stop_now = dot_product(x(1:n) - self%spec%origin, self%spec%normal) > self%spec%dist
    if (stop_now) self%passed = .true.
  end subroutine gate_on_step

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
  !> branch: MC_RETURN) or passes the saddle's gate (MC_TRANSIT), or t_max (MC_UNDECIDED).
  subroutine mc_classify(ball, psec, x0, gspec, t_max, tol, integ, outcome, t_end, stat)
    class(hamiltonian_t), intent(in) :: ball
    type(poincare_t), intent(in) :: psec
    real(wp), intent(in) :: x0(:), t_max, tol
    type(gate_spec_t), intent(in) :: gspec
    type(integ_choice_t), intent(in) :: integ   !! the integrator
    integer, intent(out) :: outcome
    real(wp), intent(out) :: t_end
    integer, intent(out) :: stat
    class(integrator_t), allocatable :: ig
    type(gate_t) :: gate
    real(wp) :: x(size(x0))
    class(event_t), allocatable :: ret
    outcome = MC_UNDECIDED
    t_end = 0
    call make_integrator(integ, ig, stat, f=ball, rtol=tol, atol=tol)
    if (stat /= TUBES_OK) return
    call psec%return_event(ret)
    x = x0
    gate%spec = gspec
    call propagate(ig, x, t_max, stat, event=ret, observer=gate)
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

  !> Monte Carlo transition fraction: n points uniform in the permitted region of the
  !> section at its energy (rejection in the bounding box, GSL MT19937 from seed, drawn
  !> serially), each on the section's branch, integrated in parallel (OpenMP) and classified by
  !> the saddle's gate gspec. The cut (cr, cp) gives each point's predicted class (inside =
  !> transit).
  subroutine monte_carlo(model, psec, n, seed, gspec, t_max, tol, integ, cr, cp, r, pr, outcome, &
                         inside, stat)
    class(hamiltonian_t), intent(in) :: model
    type(integ_choice_t), intent(in) :: integ   !! the integrator
    type(poincare_t), intent(in) :: psec
    integer, intent(in) :: n
    integer(c_long), intent(in) :: seed
    real(wp), intent(in) :: t_max, tol, cr(:), cp(:)
    type(gate_spec_t), intent(in) :: gspec      !! the saddle's transit gate
    real(wp), intent(out) :: r(n), pr(n)
    integer, intent(out) :: outcome(n)
    logical, intent(out) :: inside(n)
    integer, intent(out) :: stat
    real(wp), allocatable :: u(:)
    real(wp) :: plo, phi_, pl, ph, pc, pmax, rr, pp_, x(model%dim()), te, box(4)
    integer :: k, m, i, st(n), kf
    type(par_t) :: pp
    stat = TUBES_OK
    if (n < 1) then
      stat = TUBES_EINPUT
      return
    end if
    ! the bounding box of the region in p_s: centre pc, half-height pmax (1 % margin)
    pl = huge(1.0_wp)
    ph = -huge(1.0_wp)
    do i = 0, 2000
      call psec%bounds(psec%smin + (psec%smax - psec%smin)*i/2000.0_wp, plo, phi_)
      pl = min(pl, plo)
      ph = max(ph, phi_)
    end do
    pc = (pl + ph)/2
    pmax = (ph - pl)/2*1.01_wp
    m = 0
    k = 0
    allocate (u(8*n + 64))
    stat = rng_uniform(seed, size(u), u)
    if (stat /= 0) then
      stat = TUBES_EINPUT                  ! GSL refused the seed or the size
      return
    end if
    do while (m < n)
      if (k + 2 > size(u)) then            ! rare: draw more from the same stream's seed + 1
        stat = rng_uniform(seed + k, size(u), u)
        if (stat /= 0) then
          stat = TUBES_EINPUT
          return
        end if
        k = 0
      end if
      rr = psec%smin + (psec%smax - psec%smin)*u(k + 1)
      pp_ = pc + pmax*(2*u(k + 2) - 1)
      k = k + 2
      call psec%bounds(rr, plo, phi_)
      if (pp_ > plo .and. pp_ < phi_) then
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
    if (uses_taylor(integ)) then
      call mc_lanes()
    else
      !$omp parallel do schedule(dynamic) default(shared) private(i, x, te)
      do i = 1, n
        if (.not. pp%mine(i)) cycle
        if (i == kf) then
          st(i) = TUBES_EFAULT
        else
          call psec%state(r(i), pr(i), x, st(i))
          if (st(i) == TUBES_OK) call mc_classify(model, psec, x, gspec, t_max, tol, integ, outcome(i), te, st(i))
        end if
        if (st(i) < 0) outcome(i) = st(i)
      end do
      !$omp end parallel do
    end if
    ! the cut's bounding box first: a point outside it is outside the curve (no edge straddles
    ! p, or an even number to its one side), the same answer as the full test's, O(1)
    box = [minval(cr), maxval(cr), minval(cp), maxval(cp)]
    !$omp parallel do schedule(static)
    do i = 1, n
      if (.not. pp%mine(i)) cycle
      if (r(i) < box(1) .or. r(i) > box(2) .or. pr(i) < box(3) .or. pr(i) > box(4)) then
        inside(i) = .false.
      else
        inside(i) = inside_curve(r(i), pr(i), cr, cp)
      end if
    end do
    !$omp end parallel do
    call par_share(outcome)
    call par_share(inside)
    call par_share(st)
    stat = min(0, minval(st))
  contains
    !> The points in the Taylor method's lanes, LANE_CHUNK per call of run_lanes.
    subroutine mc_lanes()
      type(mc_jobs_t) :: jobs
      integer, allocatable :: mine(:)
      allocate (jobs%model, source=model)
      jobs%psec = psec
      jobs%gspec = gspec
      jobs%integ = integ
      jobs%t_max = t_max
      jobs%tol = tol
      jobs%r = r
      jobs%pr = pr
      allocate (jobs%outcome(n), jobs%st(n))
      jobs%outcome = MC_UNDECIDED
      jobs%st = TUBES_OK
      mine = pack([(i, i = 1, n)], [(pp%mine(i) .and. i /= kf, i = 1, n)])
      if (kf >= 1 .and. kf <= n) then
        if (pp%mine(kf)) jobs%st(kf) = TUBES_EFAULT
      end if
      call run_lanes_chunked(jobs, mine, LANE_CHUNK)
      do i = 1, n
        if (.not. pp%mine(i)) cycle
        st(i) = jobs%st(i)
        outcome(i) = jobs%outcome(i)
        if (st(i) < 0) outcome(i) = st(i)
      end do
    end subroutine mc_lanes
  end subroutine monte_carlo

  !> Point k in a lane: mc_classify's set-up (the state on the section, the integrator of the
  !> choice with rtol = atol = tol, the return to the section as a terminal event, the gate).
  subroutine mc_start(self, k, lane, stat)
    class(mc_jobs_t), intent(inout) :: self
    integer, intent(in) :: k
    type(lane_t), intent(inout) :: lane
    integer, intent(out) :: stat
    class(event_t), allocatable :: ret
    type(gate_t) :: gate
    if (.not. allocated(lane%x)) allocate (lane%x(self%model%dim()))
    call self%psec%state(self%r(k), self%pr(k), lane%x, stat)
    if (stat /= TUBES_OK) return
    if (allocated(lane%ig%f)) then   ! the lane's last item had this job's model: restart it
      call lane%ig%restart(0.0_wp)
    else
      call lane%ig%init(self%model, 0.0_wp)
    end if
    lane%ig%h = self%integ%h
    lane%ig%rtol = self%tol
    lane%ig%atol = self%tol
    lane%tend = self%t_max
    call self%psec%return_event(ret)
    call move_alloc(ret, lane%event)
    gate%spec = self%gspec
    allocate (lane%observer, source=gate)
  end subroutine mc_start

  !> Point k's class, as mc_classify's.
  subroutine mc_finish(self, k, lane)
    class(mc_jobs_t), intent(inout) :: self
    integer, intent(in) :: k
    type(lane_t), intent(inout) :: lane
    logical :: passed
    passed = .false.
    if (allocated(lane%observer)) then
      select type (g => lane%observer)
      type is (gate_t)
        passed = g%passed
      end select
    end if
    self%st(k) = lane%stat
    if (lane%stat == TUBES_EVENT) then
      self%outcome(k) = MC_RETURN
      self%st(k) = TUBES_OK
    else if (passed) then
      self%outcome(k) = MC_TRANSIT
    else
      self%outcome(k) = MC_UNDECIDED
    end if
  end subroutine mc_finish

  !> Poincare map of the section branch: n_iter returns of each start state x0(:, j), recorded
  !> as (r, p_r) in pts(:, k, j) (NaN after a trajectory stops returning within t_max).
  subroutine poincare_map(ball, psec, x0, n_iter, t_max, tol, integ, pts, stat)
    use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
    class(hamiltonian_t), intent(in) :: ball
    type(poincare_t), intent(in) :: psec
    type(integ_choice_t), intent(in) :: integ   !! the integrator
    real(wp), intent(in) :: x0(:, :), t_max, tol
    integer, intent(in) :: n_iter
    real(wp), intent(out) :: pts(2, n_iter, size(x0, 2))
    integer, intent(out) :: stat
    real(wp) :: xs(size(x0, 1), size(x0, 2))
    integer :: j, st(size(x0, 2)), kf
    type(par_t) :: pp
    xs = x0
    call par_bcast(xs)                  ! seeds dealt out over MPI ranks (tubes_par)
    pp = par_here()
    kf = par_fault_item('map')
    pts = 0
    st = TUBES_OK
    if (uses_taylor(integ)) then
      call map_lanes()
    else
      !$omp parallel do schedule(dynamic) default(shared) private(j)
      do j = 1, size(x0, 2)
        if (.not. pp%mine(j)) cycle
        if (j == kf) then
          st(j) = TUBES_EFAULT
          pts(:, :, j) = ieee_value(1.0_wp, ieee_quiet_nan)
          cycle
        end if
        call one_map(ball, psec, xs(:, j), n_iter, t_max, tol, integ, pts(:, :, j), st(j))
      end do
      !$omp end parallel do
    end if
    call par_share(pts)
    call par_share(st)
    stat = min(0, minval(st))
  contains
    !> The seeds in the Taylor method's lanes (one seed per item: a few per thread).
    subroutine map_lanes()
      type(map_jobs_t) :: jobs
      integer, allocatable :: mine(:)
      integer :: ns
      ns = size(x0, 2)
      allocate (jobs%model, source=ball)
      jobs%psec = psec
      jobs%integ = integ
      jobs%t_max = t_max
      jobs%tol = tol
      jobs%n_iter = n_iter
      jobs%x0 = xs
      allocate (jobs%pts(2, n_iter, ns), jobs%st(ns))
      jobs%pts = ieee_value(1.0_wp, ieee_quiet_nan)
      jobs%st = TUBES_OK
      mine = pack([(j, j = 1, ns)], [(pp%mine(j) .and. j /= kf, j = 1, ns)])
      call run_lanes_chunked(jobs, mine, LANES)
      do j = 1, ns
        if (.not. pp%mine(j)) cycle
        if (j == kf) then
          st(j) = TUBES_EFAULT
          pts(:, :, j) = ieee_value(1.0_wp, ieee_quiet_nan)
        else
          st(j) = jobs%st(j)
          pts(:, :, j) = jobs%pts(:, :, j)
        end if
      end do
    end subroutine map_lanes
  end subroutine poincare_map

  !> Seed k in a lane: one_map's set-up.
  subroutine map_start(self, k, lane, stat)
    class(map_jobs_t), intent(inout) :: self
    integer, intent(in) :: k
    type(lane_t), intent(inout) :: lane
    integer, intent(out) :: stat
    class(event_t), allocatable :: ev
    stat = TUBES_OK
    if (allocated(lane%ig%f)) then   ! the lane's last item had this job's model: restart it
      call lane%ig%restart(0.0_wp)
    else
      call lane%ig%init(self%model, 0.0_wp)
    end if
    lane%ig%h = self%integ%h
    lane%ig%rtol = self%tol
    lane%ig%atol = self%tol
    lane%ig%max_steps = 100000000
    lane%x = self%x0(:, k)
    lane%tend = self%t_max
    lane%use_log = .true.
    lane%log%max_crossings = self%n_iter
    call self%psec%event(.false., ev)
    call move_alloc(ev, lane%event)
  end subroutine map_start

  !> Seed k's returns, as one_map's.
  subroutine map_finish(self, k, lane)
    class(map_jobs_t), intent(inout) :: self
    integer, intent(in) :: k
    type(lane_t), intent(inout) :: lane
    integer :: j
    self%st(k) = lane%stat
    if (lane%stat == TUBES_EVENT) self%st(k) = TUBES_OK
    do j = 1, min(lane%log%n, self%n_iter)
      self%pts(:, j, k) = self%psec%coords(lane%log%x(:, j))
    end do
  end subroutine map_finish

  !> The returns of one trajectory (all locals: thread-private by construction).
  subroutine one_map(ball, psec, x0, n_iter, t_max, tol, integ, pts, stat)
    use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
    class(hamiltonian_t), intent(in) :: ball
    type(poincare_t), intent(in) :: psec
    type(integ_choice_t), intent(in) :: integ
    real(wp), intent(in) :: x0(:), t_max, tol
    integer, intent(in) :: n_iter
    real(wp), intent(out) :: pts(2, n_iter)
    integer, intent(out) :: stat
    type(crossing_log_t) :: log
    class(integrator_t), allocatable :: ig
    class(event_t), allocatable :: ev
    real(wp) :: x(size(x0))
    integer :: k
    pts = ieee_value(1.0_wp, ieee_quiet_nan)
    call make_integrator(integ, ig, stat, f=ball, rtol=tol, atol=tol)
    if (stat /= TUBES_OK) return
    ig%max_steps = 100000000
    x = x0
    log%max_crossings = n_iter
    call psec%event(.false., ev)
    call propagate(ig, x, t_max, stat, event=ev, crossings=log)
    if (stat == TUBES_EVENT) stat = TUBES_OK
    do k = 1, min(log%n, n_iter)
      pts(:, k) = psec%coords(log%x(:, k))
    end do
  end subroutine one_map
end module tubes_transport
