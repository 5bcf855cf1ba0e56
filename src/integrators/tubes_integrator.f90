!> One stepper abstraction with dense output; events and observers written once (propagate).
!> Events are found on the dense output of every accepted step: g(s, interp(s)) is sampled at
!> event%nsub interior points, every sign change between consecutive samples is bracketed and
!> refined by the Illinois method (docs/events.md). Nothing is ever re-integrated.
module tubes_integrator
  use tubes_kinds, only: wp, i8
  use tubes_field, only: vector_field_t, field_rk => vector_field_t
  use tubes_status, only: TUBES_OK, TUBES_EVENT, TUBES_EINPUT, TUBES_EMAXSTEPS, TUBES_ENOCONV, &
                          TUBES_EMODEL, TUBES_ESTEP
  implicit none
  private

  integer, parameter :: rk = wp   ! the kind of the kind-generic sources included below

  !> A time stepper. The last accepted step spans [t_old, t]; interp is valid there.
  type, abstract, public :: integrator_t
    class(vector_field_t), allocatable :: f   !! owned copy of the model
    real(wp) :: t_old = 0                     !! start of the last accepted step [s]
    real(wp) :: t = 0                         !! current time [s]
    real(wp) :: rtol = 1.0e-12_wp             !! relative tolerance (variable-step methods)
    real(wp) :: atol = 1.0e-12_wp             !! absolute tolerance (variable-step methods)
    real(wp) :: h = 0                         !! fixed step [s] if > 0; else first step guess
    real(wp) :: h_next = 0                    !! step proposed for the next attempt [s]
    integer(i8) :: max_steps = 10000000_i8    !! accepted-step budget per propagate call
    integer(i8) :: nfev = 0                   !! right-hand-side evaluations
    integer(i8) :: nsteps = 0                 !! accepted steps
    integer(i8) :: nrejected = 0              !! rejected steps
    integer(i8) :: niter = 0                  !! implicit methods: Newton/fixed-point iterations
    logical :: fresh = .true.                 !! state was set from outside: restart the stepper
  contains
    procedure :: init => integrator_init
    procedure :: restart => integrator_restart   !! a new integration of the same model
    procedure(step_i), deferred :: step
    procedure(interp_i), deferred :: interp
    !> interior times of the last step at which an event's g is sampled (scan_step); default:
    !> the event's nsub equally spaced points; the Taylor method isolates the roots instead
    procedure :: event_samples => integrator_event_samples
    !> whether the last step surely holds no root of the event's g (default: not known); then
    !> scan_step need not sample it (the Taylor method: event_samples' own bound, below)
    procedure :: event_clear => integrator_event_clear
  end type integrator_t

  abstract interface
    !> One accepted step from (t, x) towards tmax; never passes tmax and lands on it.
    subroutine step_i(self, x, tmax, stat)
      import :: integrator_t, wp
      class(integrator_t), intent(inout) :: self
      real(wp), intent(inout) :: x(:)
      real(wp), intent(in) :: tmax
      integer, intent(out) :: stat
    end subroutine step_i
    !> Dense output at s in [t_old, t] of the last accepted step.
    subroutine interp_i(self, s, xs)
      import :: integrator_t, wp
      class(integrator_t), intent(inout) :: self   ! may build interpolation data lazily
      real(wp), intent(in) :: s
      real(wp), intent(out) :: xs(:)
    end subroutine interp_i
  end interface

  !> Event function g(t, x) = 0. A crossing is a sign change of g along the trajectory that
  !> passes the `direction` filter (sign of dg/dt) and the state-dependent `accept` filter;
  !> `orientation` gives the direction reported for it (default: the sign of dg/dt).
  type, abstract, public :: event_t
    integer :: direction = 0      !! +1 rising (dg/dt > 0 in time), -1 falling, 0 either
    logical :: terminal = .true.  !! stop propagate at the first accepted crossing
    !> interior sample points of g per step (>= 0). Two crossings closer than about
    !> h/(nsub+1) can both fall between two samples and then neither is seen
    !> (docs/events.md measures it). 4 costs 4 cheap interpolations per step; 0 tests the
    !> step ends only (and does not need the dense output of steps without a crossing)
    integer :: nsub = 4
  contains
    procedure(g_i), deferred :: g
    procedure :: accept => event_accept            !! filter on the state at a crossing
    procedure :: orientation => event_orientation  !! direction reported for a crossing
    procedure :: affine => event_affine            !! g = w . x - c? (default: no)
  end type event_t

  abstract interface
    pure real(wp) function g_i(self, t, x)
      import :: event_t, wp
      class(event_t), intent(in) :: self
      real(wp), intent(in) :: t, x(:)
    end function g_i
  end interface

  !> The plane x(k) = c.
  type, extends(event_t), public :: plane_t
    integer :: k = 1        !! state component
    real(wp) :: c = 0       !! level [units of x(k)]
  contains
    procedure :: g => plane_g
    procedure :: affine => plane_affine
  end type plane_t

  !> Every crossing found by propagate, in the order of integration (appended across calls).
  type, public :: crossing_log_t
    integer :: n = 0                       !! crossings recorded
    integer :: max_crossings = 1000000     !! propagate stops (TUBES_EVENT) when n reaches it
    real(wp), allocatable :: t(:)          !! crossing times t(1:n) [s]
    real(wp), allocatable :: x(:, :)       !! states x(:, 1:n) at the crossings
    integer, allocatable :: direction(:)   !! orientation of each crossing: +1 or -1
  contains
    procedure :: clear => log_clear
  end type crossing_log_t

  !> The step grid of a fixed-step method: t_k = t0 + k hs, one rounding per step (no drift of t
  !> over many steps); a call that starts where the last step ended with the same step continues it.
  type, public :: step_grid_t
    real(wp) :: t0 = 0          !! the grid's origin [s]
    real(wp) :: hs = 0          !! its signed spacing (0: no grid) [s]
    integer(i8) :: n = 0        !! the index k of the current t on it
    real(wp) :: mark = 0        !! t as set by the last step (t changed outside: a new grid)
    logical :: on = .false.     !! the step being tried is on the grid
  contains
    procedure :: begin => grid_begin
    procedure :: trial => grid_trial
    procedure :: finish => grid_finish
    procedure :: retry => grid_retry
  end type step_grid_t

  !> A propagate call between its steps (prop_begin, prop_after_step).
  type, public :: prop_t
    real(wp) :: dir = 1                    !! +1 forward, -1 backward in time
    real(wp) :: t_start = 0                !! the call's start [s]
    real(wp) :: g0 = 0                     !! the event's g at the last step's end
    integer(i8) :: n = 0                   !! steps taken
    real(wp), allocatable :: xe(:)         !! the state at a stopping crossing
  end type prop_t

  !> Dense-output hook called after every accepted step; owns its own buffers.
  type, abstract, public :: observer_t
    logical :: stop_now = .false.   !! set by on_step to end propagate with TUBES_OK (reset before each call)
  contains
    procedure(on_step_i), deferred :: on_step
    procedure :: quiet => observer_quiet
  end type observer_t

  abstract interface
    !> Called with the step [ig%t_old, t_hi] (t_hi = ig%t, or the event time).
    subroutine on_step_i(self, ig, t_hi)
      import :: observer_t, integrator_t, wp
      class(observer_t), intent(inout) :: self   !! its stop_now = .true. ends propagate
      class(integrator_t), intent(inout) :: ig
      real(wp), intent(in) :: t_hi
    end subroutine on_step_i
  end interface

  integer, parameter :: MAX_NSUB = 10000     ! sanity bound on event%nsub
  integer, parameter :: MAX_ITER = 300       ! root refinement: >> 3 x 64 bisections
  real(wp), parameter :: EPS = epsilon(1.0_wp)
  !> Root refinement stops when the bracket is below max(T_RTOL |t|, T_ATOL) [s]:
  !> a few ulps of t, and 1e-15 s near t = 0.
  real(wp), parameter, public :: T_RTOL = 4*EPS
  real(wp), parameter, public :: T_ATOL = 1.0e-15_wp

  public :: propagate, prop_begin, prop_after_step, start_step, hermite, stale_state, all_finite, no_crossing
  public :: integrator_init   ! for a method that extends init (tubes_taylor)

contains

  !> The cubic with values x0, x1 and slopes f0, f1 at t0, t0 + h, evaluated at s: the dense
  !> output of the steppers that have none of their own (RK4, the GSL backends).
  pure subroutine hermite(x0, f0, x1, f1, t0, h, s, xs)
    real(wp), intent(in) :: x0(:), f0(:), x1(:), f1(:), t0, h, s
    real(wp), intent(out) :: xs(:)
    real(wp) :: th, th1
    if (h == 0) then
      xs = x1
      return
    end if
    th = (s - t0)/h
    th1 = 1 - th
    ! x0 + th (x1 - x0) + th th1 [ th1 h f0 - th h f1 + (th - th1) (x1 - x0) ]
    xs = x0 + th*(x1 - x0) + th*th1*((th1*h)*f0 - (th*h)*f1 + (th - th1)*(x1 - x0))
  end subroutine hermite

  include 'tubes_start_step.inc'   ! start_step in real(wp)

  !> Take a copy of the model and reset time and counters.
  subroutine integrator_init(self, f, t0)
    class(integrator_t), intent(inout) :: self
    class(vector_field_t), intent(in) :: f   !! the model
    real(wp), intent(in) :: t0               !! initial time [s]
    if (allocated(self%f)) deallocate (self%f)
    allocate (self%f, source=f)
    call self%restart(t0)
  end subroutine integrator_init

  !> A new integration of the same model from t0: the stepper restarts (as after init), the
  !> counters are cleared; what the method built for the model (a Taylor kernel) is kept.
  subroutine integrator_restart(self, t0)
    class(integrator_t), intent(inout) :: self
    real(wp), intent(in) :: t0        !! initial time [s]
    self%t = t0
    self%t_old = t0
    self%h_next = 0
    self%nfev = 0
    self%nsteps = 0
    self%nrejected = 0
    self%niter = 0
    self%fresh = .true.
  end subroutine integrator_restart

  pure real(wp) function plane_g(self, t, x)
    class(plane_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:)
    plane_g = x(self%k) - self%c
  end function plane_g

  !> Default filter: every crossing counts.
  pure logical function event_accept(self, t, x)
    class(event_t), intent(in) :: self
    real(wp), intent(in) :: t      !! crossing time [s]
    real(wp), intent(in) :: x(:)   !! state at the crossing
    event_accept = .true.
  end function event_accept

  !> Default: g is not known to be affine in the state.
  pure subroutine event_affine(self, n, w, c, ok)
    class(event_t), intent(in) :: self
    integer, intent(in) :: n           !! state dimension
    real(wp), intent(out) :: w(n), c   !! g(t, x) = w . x - c when ok
    logical, intent(out) :: ok
    w = 0
    c = 0
    ok = .false.
  end subroutine event_affine

  pure subroutine plane_affine(self, n, w, c, ok)
    class(plane_t), intent(in) :: self
    integer, intent(in) :: n
    real(wp), intent(out) :: w(n), c
    logical, intent(out) :: ok
    w = 0
    c = self%c
    ok = self%k >= 1 .and. self%k <= n
    if (ok) w(self%k) = 1
  end subroutine plane_affine

  !> Not known (the default): the step is sampled.
  logical function integrator_event_clear(self, event) result(clear)
    class(integrator_t), intent(inout) :: self
    class(event_t), intent(in) :: event
    clear = .false.
  end function integrator_event_clear

  !> The event's nsub equally spaced interior points of the last step.
  subroutine integrator_event_samples(self, event, ts, m)
    class(integrator_t), intent(inout) :: self
    class(event_t), intent(in) :: event
    real(wp), allocatable, intent(out) :: ts(:)   !! interior sample times, in the order of integration
    integer, intent(out) :: m                     !! how many
    integer :: j
    m = event%nsub
    allocate (ts(m))
    do j = 1, m
      ts(j) = self%t_old + (self%t - self%t_old)*(real(j, wp)/(m + 1))
    end do
  end subroutine integrator_event_samples

  !> Default orientation of a crossing: the sign of dg/dt there (`slope`, +1 or -1).
  pure integer function event_orientation(self, t, x, slope)
    class(event_t), intent(in) :: self
    real(wp), intent(in) :: t      !! crossing time [s]
    real(wp), intent(in) :: x(:)   !! state at the crossing
    integer, intent(in) :: slope   !! sign of dg/dt across the crossing (in time)
    event_orientation = slope
  end function event_orientation

  !> At the start of a step call towards tmax: the step's start t, direction dir and size h, and
  !> the grid continued or started at t.
  pure subroutine grid_begin(g, t_now, tmax, h_set, t, dir, h)
    class(step_grid_t), intent(inout) :: g
    real(wp), intent(in) :: t_now, tmax, h_set   !! the integrator's t and h, the call's end
    real(wp), intent(out) :: t, dir, h           !! the step's start, direction and size
    t = t_now
    dir = sign(1.0_wp, tmax - t_now)
    h = h_set
    g%on = t == g%mark .and. dir*h == g%hs
    if (.not. g%on) then
      g%t0 = t
      g%n = 0
      g%hs = dir*h
      g%on = .true.
    end if
  end subroutine grid_begin

  !> The step to try from t towards tmax with step h: t_full its end, hs its signed size, last if
  !> it lands on tmax (a full step reaching tmax up to 64 ulps of t); stat TUBES_ESTEP if hs is
  !> below roundoff of t and not the last.
  pure subroutine grid_trial(g, t, tmax, dir, h, t_full, hs, last, stat)
    class(step_grid_t), intent(in) :: g
    real(wp), intent(in) :: t, tmax, dir, h
    real(wp), intent(out) :: t_full, hs
    logical, intent(out) :: last
    integer, intent(out) :: stat
    real(wp) :: hmin
    stat = TUBES_OK
    if (g%on) then              ! one rounding, no accumulated drift of t
      t_full = g%t0 + (g%n + 1)*g%hs
    else
      t_full = t + dir*h
    end if
    last = dir*(tmax - t_full) <= 64*epsilon(1.0_wp)*max(h, abs(t_full))
    if (last) then
      hs = tmax - t
    else
      hs = t_full - t
    end if
    hmin = 16*epsilon(1.0_wp)*max(abs(t), abs(tmax) - abs(tmax - t), 1.0e-300_wp)
    if (abs(hs) < hmin .and. .not. last) stat = TUBES_ESTEP
  end subroutine grid_trial

  !> A fixed-step method's kept copies are stale: a fresh start, none yet or of another
  !> dimension, or the state x changed from outside since the last step (saved: the state that
  !> step left).
  pure logical function stale_state(fresh, saved, x) result(stale)
    logical, intent(in) :: fresh
    real(wp), allocatable, intent(in) :: saved(:)
    real(wp), intent(in) :: x(:)
    stale = .true.
    if (fresh .or. .not. allocated(saved)) return
    if (size(saved) /= size(x)) return
    stale = any(x /= saved)
  end function stale_state

  !> Every component of x is finite (no NaN, no Inf).
  pure logical function all_finite(x)
    real(wp), intent(in) :: x(:)
    all_finite = all(abs(x) <= huge(1.0_wp))
  end function all_finite

  !> After a trial step whose model evaluations ended with status fs: .false. to accept it
  !> (fs = 0) or to stop (fs < 0: stat = TUBES_EMODEL); .true. to try again at h/4 off the grid
  !> (fs > 0: the model asked for a smaller step), the rejection counted.
  logical function grid_retry(g, fs, h, nrejected, stat) result(again)
    class(step_grid_t), intent(inout) :: g
    integer, intent(in) :: fs
    real(wp), intent(inout) :: h
    integer(i8), intent(inout) :: nrejected
    integer, intent(inout) :: stat
    again = fs > 0
    if (fs < 0) stat = TUBES_EMODEL
    if (.not. again) return
    h = h/4
    g%on = .false.
    nrejected = nrejected + 1
  end function grid_retry

  !> After the accepted step: advance on the grid (or drop it), the new t.
  function grid_finish(g, last, tmax, t_full) result(t_new)
    class(step_grid_t), intent(inout) :: g
    logical, intent(in) :: last
    real(wp), intent(in) :: tmax, t_full
    real(wp) :: t_new
    if (g%on .and. .not. last) then
      g%n = g%n + 1
    else
      g%hs = 0                  ! the next step starts a new grid
    end if
    if (last) then
      t_new = tmax
    else
      t_new = t_full
    end if
    g%mark = t_new
  end function grid_finish

  !> Forget all recorded crossings (keeps the storage and max_crossings).
  subroutine log_clear(self)
    class(crossing_log_t), intent(inout) :: self
    self%n = 0
  end subroutine log_clear

  !> Append a crossing, growing the storage geometrically.
  subroutine log_append(log, t, x, direction)
    type(crossing_log_t), intent(inout) :: log
    real(wp), intent(in) :: t, x(:)
    integer, intent(in) :: direction
    real(wp), allocatable :: tt(:), xx(:, :)
    integer, allocatable :: dd(:)
    integer :: cap
    if (allocated(log%t)) then   ! storage of another state dimension (log cleared): drop it
      if (size(log%x, 1) /= size(x)) deallocate (log%t, log%x, log%direction)
    end if
    if (.not. allocated(log%t)) then
      cap = max(1, min(64, log%max_crossings))
      allocate (log%t(cap), log%x(size(x), cap), log%direction(cap))
    else if (log%n >= size(log%t)) then
      cap = int(min(2*int(size(log%t), i8), int(log%max_crossings, i8)))
      allocate (tt(cap), xx(size(x), cap), dd(cap))
      tt(1:log%n) = log%t(1:log%n)
      xx(:, 1:log%n) = log%x(:, 1:log%n)
      dd(1:log%n) = log%direction(1:log%n)
      call move_alloc(tt, log%t)
      call move_alloc(xx, log%x)
      call move_alloc(dd, log%direction)
    end if
    log%n = log%n + 1
    log%t(log%n) = t
    log%x(:, log%n) = x
    log%direction(log%n) = direction
  end subroutine log_append

  !> Integrate x from ig%t to tend (either direction), recording crossings of `event` and
  !> stopping at a terminal one.
  !> stat: TUBES_OK at tend (or when the observer asks); TUBES_EVENT at a terminal crossing or
  !> when `crossings` reaches max_crossings (ig%t = crossing time, x = state there); < 0 on
  !> failure (x at the last accepted step). A root at the very start of the call (a restart
  !> from an event) is not a new crossing.
  subroutine propagate(ig, x, tend, stat, event, observer, crossings)
    class(integrator_t), intent(inout) :: ig
    real(wp), intent(inout) :: x(:)                   !! state at ig%t, on return at ig%t
    real(wp), intent(in) :: tend                      !! final time [s]
    integer, intent(out) :: stat
    class(event_t), intent(in), optional :: event     !! section to detect
    class(observer_t), intent(inout), optional :: observer
    !> every accepted crossing is appended to it (ignored without event)
    type(crossing_log_t), intent(inout), optional :: crossings
    type(prop_t) :: ps
    logical :: done, plain
    call prop_begin(ig, x, tend, ps, stat, event, crossings)
    if (stat /= TUBES_OK) return
    plain = .not. (present(event) .or. present(observer))   ! nothing to do between steps
    do while (ps%dir*(tend - ig%t) > 0)
      if (ps%n >= ig%max_steps) then
        stat = TUBES_EMAXSTEPS
        return
      end if
      call ig%step(x, tend, stat)
      if (stat < 0) return
      if (plain) then
        ps%n = ps%n + 1
      else
        call prop_after_step(ig, x, ps, done, stat, event, observer, crossings)
        if (done) return
      end if
    end do
  end subroutine propagate

  !> The start of a propagate call: checks, the direction, g at the start. (propagate, and the
  !> lanes' driver src/integrators/tubes_lanes.f90, which steps several integrations at once.)
  subroutine prop_begin(ig, x, tend, ps, stat, event, crossings)
    class(integrator_t), intent(inout) :: ig
    real(wp), intent(in) :: x(:), tend
    type(prop_t), intent(out) :: ps
    integer, intent(out) :: stat
    class(event_t), intent(in), optional :: event
    type(crossing_log_t), intent(in), optional :: crossings
    stat = TUBES_OK
    if (size(x) /= ig%f%dim()) then
      stat = TUBES_EINPUT
      return
    end if
    if (present(event)) then
      if (event%nsub < 0 .or. event%nsub > MAX_NSUB .or. abs(event%direction) > 1) then
        stat = TUBES_EINPUT
        return
      end if
      if (present(crossings)) then
        if (crossings%n >= crossings%max_crossings) then   ! full: the caller must clear it
          stat = TUBES_EINPUT
          return
        end if
        if (crossings%n > 0) then
          if (size(crossings%x, 1) /= size(x)) then
            stat = TUBES_EINPUT
            return
          end if
        end if
      end if
    end if
    ps%dir = sign(1.0_wp, tend - ig%t)
    ps%t_start = ig%t
    allocate (ps%xe(size(x)))
    if (present(event)) ps%g0 = event%g(ig%t, x)
    ps%n = 0
  end subroutine prop_begin

  !> After an accepted step of a propagate call: the step's crossings and the observer.
  !> done: the call ends here with stat (TUBES_EVENT at a stopping crossing, x and ig%t moved
  !> there; TUBES_OK when the observer asks; < 0 on failure); else it goes on (stat TUBES_OK).
  subroutine prop_after_step(ig, x, ps, done, stat, event, observer, crossings, clear)
    class(integrator_t), intent(inout) :: ig
    real(wp), intent(inout) :: x(:)
    type(prop_t), intent(inout) :: ps
    logical, intent(out) :: done
    integer, intent(out) :: stat
    class(event_t), intent(in), optional :: event
    class(observer_t), intent(inout), optional :: observer
    type(crossing_log_t), intent(inout), optional :: crossings
    !> ig%event_clear(event) of this step, where the caller has it already (the lanes: for all
    !> lanes at once)
    logical, intent(in), optional :: clear
    real(wp) :: g1, te
    logical :: hit
    stat = TUBES_OK
    done = .false.
    ps%n = ps%n + 1
    hit = .false.
    if (present(event)) then
      g1 = event%g(ig%t, x)
      call scan_step(ig, event, x, ps%g0, g1, ps%dir, ps%t_start, te, ps%xe, hit, stat, crossings, clear)
      if (stat < 0) then
        done = .true.
        return
      end if
      ps%g0 = g1
    end if
    if (present(observer)) then
      observer%stop_now = .false.
      if (hit) then
        call observer%on_step(ig, te)
      else
        call observer%on_step(ig, ig%t)
      end if
      if (observer%stop_now .and. .not. hit) then
        done = .true.
        return
      end if
    end if
    if (hit) then
      ig%t = te
      x = ps%xe
      ig%fresh = .true.
      stat = TUBES_EVENT
      done = .true.
    end if
  end subroutine prop_after_step

  !> g0, g1 at the ends of a step that holds no root of the event (event_clear): nothing to
  !> sample, both finite and without a sign change between them (scan_step's rule for a crossing:
  !> the left end nonzero, the right one zero or of the other sign).
  pure logical function no_crossing(g0, g1)
    real(wp), intent(in) :: g0, g1
    no_crossing = .false.
    if (.not. (abs(g0) <= huge(1.0_wp) .and. abs(g1) <= huge(1.0_wp))) return
    no_crossing = .not. ((g0 < 0 .and. g1 >= 0) .or. (g0 > 0 .and. g1 <= 0))
  end function no_crossing

  !> Whether the step that ends at (t, x) needs nothing of on_step but what quiet has done (the
  !> observer's own state updated as on_step would, for a step whose end is all it looks at):
  !> then the lanes' driver leaves out on_step and the step's dense output (tubes_lanes). On
  !> .false. nothing is changed. ig: the integration's integrator, for its field (ig%f) only (its
  !> step's fields and dense output are not up to date there). The default: .false. (on_step
  !> every step).
  logical function observer_quiet(self, ig, t, x) result(q)
    class(observer_t), intent(inout) :: self
    class(integrator_t), intent(in) :: ig
    real(wp), intent(in) :: t
    real(wp), intent(in) :: x(:)
    q = .false.
  end function observer_quiet

  !> All crossings of `event` in the last accepted step [t_old, t], in the order of
  !> integration. g is sampled at the step ends (g0, g1) and at nsub equally spaced interior
  !> points of the dense output; each sign change between consecutive samples is refined.
  !> Accepted crossings go to the log; `hit` (with te, xe) reports the first one that stops
  !> the integration (terminal event, or the log reaching max_crossings).
  subroutine scan_step(ig, event, x, g0, g1, dir, t_start, te, xe, hit, stat, crossings, clear)
    class(integrator_t), intent(inout) :: ig
    class(event_t), intent(in) :: event
    real(wp), intent(in) :: x(:)          !! state at ig%t (end of the step)
    real(wp), intent(in) :: g0, g1        !! g at ig%t_old and at ig%t
    real(wp), intent(in) :: dir           !! +1 forward, -1 backward in time
    real(wp), intent(in) :: t_start       !! start of the propagate call [s]
    real(wp), intent(out) :: te           !! time of the stopping crossing [s]
    real(wp), intent(out) :: xe(:)        !! state there
    logical, intent(out) :: hit
    integer, intent(out) :: stat
    type(crossing_log_t), intent(inout), optional :: crossings
    logical, intent(in), optional :: clear    !! ig%event_clear(event), known already
    real(wp), allocatable :: inner(:)
    integer :: m
    logical :: cl
    stat = TUBES_OK
    hit = .false.
    te = ig%t
    ! a step the integrator knows to hold no root, with finite ends and no sign change between
    ! them: nothing to sample (what scan_samples would conclude with no interior sample; most
    ! steps of an ensemble: the Taylor method's bound, without its samples' arrays)
    if (present(clear)) then
      cl = clear
    else
      cl = ig%event_clear(event)
    end if
    if (cl) then
      if (no_crossing(g0, g1)) return
    end if
    call ig%event_samples(event, inner, m)
    call scan_samples(m + 1)
  contains
    !> The m - 1 interior samples and the two ends (automatic arrays: the stack, not the heap).
    subroutine scan_samples(m)
      integer, intent(in) :: m
      real(wp) :: ts(0:m), gv(0:m)
      real(wp) :: xs(size(x))
      integer :: j, slope, orient
      ts(0) = ig%t_old
      gv(0) = g0
      ts(m) = ig%t
      gv(m) = g1
      do j = 1, m - 1
        ts(j) = inner(j)
        call ig%interp(ts(j), xs)
        gv(j) = event%g(ts(j), xs)
      end do
      if (.not. all_finite(gv)) then   ! NaN/Inf from the model or the interpolant
        stat = TUBES_EMODEL
        return
      end if
      do j = 1, m
        ! a sign change in (ts(j-1), ts(j)]: the left sample nonzero, the right one zero or of
        ! the other sign. A root exactly on a sample thus belongs to the interval it ends, and a
        ! step end to its own step only (the next step starts from g = 0: no sign change).
        if (gv(j - 1) < 0 .and. gv(j) >= 0) then
          slope = 1
        else if (gv(j - 1) > 0 .and. gv(j) <= 0) then
          slope = -1
        else
          cycle
        end if
        slope = slope*nint(dir)                 ! sign of dg/dt in time
        if (event%direction /= 0 .and. event%direction /= slope) cycle
        call refine_root(ig, event, ts(j - 1), ts(j), gv(j - 1), gv(j), j == m, x, te, xe, stat)
        if (stat < 0) return
        ! a root at the very start is the event this call was restarted from (g there is
        ! roundoff of either sign): not a new crossing
        if (j == 1 .and. ig%t_old == t_start .and. &
            abs(te - t_start) <= 8*EPS*max(1.0_wp, abs(t_start))) cycle
        if (.not. event%accept(te, xe)) cycle
        orient = event%orientation(te, xe, slope)
        if (present(crossings)) then
          call log_append(crossings, te, xe, orient)
          if (crossings%n >= crossings%max_crossings) hit = .true.
        end if
        if (event%terminal) hit = .true.
        if (hit) return
      end do
    end subroutine scan_samples
  end subroutine scan_step

  !> Root of g(s, interp(s)) in the bracket (a, b] of the last step (a, b in the order of
  !> integration; g(a) /= 0, g(b) zero or of the other sign) by the Illinois method, with a
  !> bisection whenever three iterations in a row fail to halve the bracket (roundoff-level
  !> g). Returns te = b of the final bracket: on the far side of the root (g(te) = 0 or of the
  !> sign after the crossing), within max(T_RTOL |t|, T_ATOL) of it; so a propagate restarted
  !> from (te, xe) does not see the same crossing again. Never re-integrates.
  subroutine refine_root(ig, event, a_in, b_in, ga_in, gb_in, b_is_end, x_end, te, xe, stat)
    class(integrator_t), intent(inout) :: ig
    class(event_t), intent(in) :: event
    real(wp), intent(in) :: a_in, b_in, ga_in, gb_in
    logical, intent(in) :: b_is_end        !! b_in is the step end ig%t, where x = x_end
    real(wp), intent(in) :: x_end(:)
    real(wp), intent(out) :: te, xe(:)
    integer, intent(out) :: stat
    real(wp) :: a, b, ga, gb, s, gs, w, w_prev, xs(size(xe))
    integer :: it, side, slow
    logical :: b_moved
    stat = TUBES_OK
    xe = x_end   ! the state at b while b is the step end
    a = a_in; b = b_in; ga = ga_in; gb = gb_in
    side = 0
    slow = 0
    b_moved = .false.
    w_prev = abs(b - a)
    do it = 1, MAX_ITER
      if (gb == 0) exit
      w = abs(b - a)
      if (w <= max(T_RTOL*max(abs(a), abs(b)), T_ATOL)) exit
      if (slow >= 3) then
        s = a + (b - a)/2
        slow = 0
      else
        s = (a*gb - b*ga)/(gb - ga)
        ! keep the secant point strictly inside the bracket (it can round onto an end)
        if (.not. (min(a, b) < s .and. s < max(a, b))) s = a + (b - a)/2
      end if
      call ig%interp(s, xs)
      gs = event%g(s, xs)
      if (.not. (abs(gs) <= huge(1.0_wp))) then
        stat = TUBES_EMODEL
        te = b
        xe = xs
        return
      end if
      if (gs /= 0 .and. sign(1.0_wp, gs) == sign(1.0_wp, ga)) then
        a = s; ga = gs
        if (side == 1) gb = gb/2      ! b kept twice in a row: Illinois halving
        side = 1
      else
        b = s; gb = gs
        xe = xs
        b_moved = .true.
        if (side == -1) ga = ga/2
        side = -1
      end if
      if (abs(b - a) > w_prev/2) then
        slow = slow + 1
      else
        slow = 0
        w_prev = abs(b - a)
      end if
    end do
    if (it > MAX_ITER) stat = TUBES_ENOCONV
    te = b
    if (.not. (b_is_end .or. b_moved)) call ig%interp(te, xe)   ! b is an interior sample
  end subroutine refine_root
end module tubes_integrator
