!> One stepper abstraction with dense output; events and observers written once (propagate).
module tubes_integrator
  use tubes_kinds, only: wp, i8
  use tubes_field, only: vector_field_t
  use tubes_status, only: TUBES_OK, TUBES_EVENT, TUBES_EINPUT, TUBES_EMAXSTEPS, TUBES_ENOCONV
  implicit none
  private

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
    procedure(step_i), deferred :: step
    procedure(interp_i), deferred :: interp
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

  !> Event function g(t, x) = 0.
  type, abstract, public :: event_t
    integer :: direction = 0      !! +1 rising, -1 falling, 0 either
    logical :: terminal = .true.  !! stop propagate at the first root
  contains
    procedure(g_i), deferred :: g
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
    real(wp) :: c = 0       !! level
  contains
    procedure :: g => plane_g
  end type plane_t

  !> Dense-output hook called after every accepted step; owns its own buffers.
  type, abstract, public :: observer_t
  contains
    procedure(on_step_i), deferred :: on_step
  end type observer_t

  abstract interface
    !> Called with the step [ig%t_old, t_hi] (t_hi = ig%t, or the event time).
    subroutine on_step_i(self, ig, t_hi, stop_now)
      import :: observer_t, integrator_t, wp
      class(observer_t), intent(inout) :: self
      class(integrator_t), intent(inout) :: ig
      real(wp), intent(in) :: t_hi
      logical, intent(out) :: stop_now   !! .true. ends propagate with TUBES_OK
    end subroutine on_step_i
  end interface

  public :: propagate

contains

  !> Take a copy of the model and reset time and counters.
  subroutine integrator_init(self, f, t0)
    class(integrator_t), intent(inout) :: self
    class(vector_field_t), intent(in) :: f   !! the model
    real(wp), intent(in) :: t0               !! initial time [s]
    if (allocated(self%f)) deallocate (self%f)
    allocate (self%f, source=f)
    self%t = t0
    self%t_old = t0
    self%h_next = 0
    self%nfev = 0
    self%nsteps = 0
    self%nrejected = 0
    self%niter = 0
    self%fresh = .true.
  end subroutine integrator_init

  pure real(wp) function plane_g(self, t, x)
    class(plane_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:)
    plane_g = x(self%k) - self%c
  end function plane_g

  !> Integrate x from ig%t to tend (either direction), stopping at a terminal event.
  !> stat: TUBES_OK at tend (or when the observer asks), TUBES_EVENT at a terminal event
  !> (ig%t = event time, x = state there), < 0 on failure (x at the last accepted step).
  subroutine propagate(ig, x, tend, stat, event, observer)
    class(integrator_t), intent(inout) :: ig
    real(wp), intent(inout) :: x(:)
    real(wp), intent(in) :: tend
    integer, intent(out) :: stat
    class(event_t), intent(in), optional :: event
    class(observer_t), intent(inout), optional :: observer
    real(wp) :: g0, g1, te, dir, t_start
    real(wp), allocatable :: xe(:)
    integer(i8) :: n
    logical :: stop_now, hit
    stat = TUBES_OK
    if (size(x) /= ig%f%dim()) then
      stat = TUBES_EINPUT
      return
    end if
    dir = sign(1.0_wp, tend - ig%t)
    t_start = ig%t
    allocate (xe(size(x)))
    if (present(event)) g0 = event%g(ig%t, x)
    n = 0
    do while (dir*(tend - ig%t) > 0)
      if (n >= ig%max_steps) then
        stat = TUBES_EMAXSTEPS
        return
      end if
      call ig%step(x, tend, stat)
      if (stat < 0) return
      n = n + 1
      hit = .false.
      if (present(event)) then
        g1 = event%g(ig%t, x)
        if (crosses(g0, g1, event%direction)) then
          call locate_root(ig, event, g0, g1, te, xe, stat)
          if (stat < 0) return
          ! a root at the very start is the event this call was restarted from (g there is
          ! roundoff of either sign): not a new crossing
          hit = event%terminal .and. &
                abs(te - t_start) > 8*epsilon(1.0_wp)*max(1.0_wp, abs(t_start))
        end if
        g0 = g1
      end if
      if (present(observer)) then
        if (hit) then
          call observer%on_step(ig, te, stop_now)
        else
          call observer%on_step(ig, ig%t, stop_now)
        end if
        if (stop_now .and. .not. hit) return
      end if
      if (hit) then
        ig%t = te
        x = xe
        ig%fresh = .true.
        stat = TUBES_EVENT
        return
      end if
    end do
  end subroutine propagate

  pure logical function crosses(g0, g1, direction)
    real(wp), intent(in) :: g0, g1
    integer, intent(in) :: direction
    select case (direction)
    case (1);  crosses = g0 < 0 .and. g1 >= 0
    case (-1); crosses = g0 > 0 .and. g1 <= 0
    case default; crosses = (g0 < 0 .and. g1 >= 0) .or. (g0 > 0 .and. g1 <= 0)
    end select
  end function crosses

  !> Root of g(s, interp(s)) in the last step by the Illinois method; never re-integrates.
  subroutine locate_root(ig, event, g0, g1, te, xe, stat)
    class(integrator_t), intent(inout) :: ig
    class(event_t), intent(in) :: event
    real(wp), intent(in) :: g0, g1
    real(wp), intent(out) :: te, xe(:)
    integer, intent(out) :: stat
    real(wp) :: a, b, ga, gb, s, gs
    integer :: it, side
    a = ig%t_old; b = ig%t; ga = g0; gb = g1
    side = 0
    stat = TUBES_OK
    if (gb == 0) then
      te = b
      call ig%interp(te, xe)
      return
    end if
    do it = 1, 200
      s = (a*gb - b*ga)/(gb - ga)
      call ig%interp(s, xe)
      gs = event%g(s, xe)
      if (gs == 0 .or. abs(b - a) <= 4*epsilon(1.0_wp)*max(abs(a), abs(b), 1.0_wp)) then
        te = s
        return
      end if
      if (sign(1.0_wp, gs) == sign(1.0_wp, gb)) then
        b = s; gb = gs
        if (side == -1) ga = ga/2
        side = -1
      else
        a = s; ga = gs
        if (side == 1) gb = gb/2
        side = 1
      end if
      if (abs(b - a) <= 4*epsilon(1.0_wp)*max(abs(a), abs(b), 1.0_wp)) then
        te = s
        return
      end if
    end do
    te = s
    stat = TUBES_ENOCONV
  end subroutine locate_root
end module tubes_integrator
