!> Ensembles in lanes (docs/integrators-taylor.md, "Lanes"): the items of an ensemble (Monte Carlo
!> points, tube seeds, Poincare seeds) integrated by the Taylor method W at a time (the width:
!> from the processor, 8 with AVX-512, 4 with AVX, 2 otherwise, or forced: lane_width), in
!> lockstep: one kernel call computes the Taylor coefficients of every lane (the processor's
!> vector instructions do the lanes at once), then each lane finishes its own step (its step
!> size, its events, its observer) exactly as a lone integration would: each lane's arithmetic is
!> the one-lane kernel's, so an item's numbers do not depend on the lane it falls in, on the
!> other items, on the number of threads or of MPI ranks (tests/test_lanes.f90). A lane whose
!> integration ends takes the next item.
!>
!> An ensemble whose items can run in lanes extends lane_jobs_t (an ensemble_t of the ensemble
!> layer, src/parallel/tubes_ensemble.f90): `start` sets up item k in a lane (its integrator's
!> model and tolerances, state, end time, event, observer, crossing log); `finish` writes its
!> result into its column of ens_out_t, as `item` would. With `lanes` set, a thread's chunk of
!> items is one run_lanes call; else the chunk's items run one by one (`item`, any method). Every
!> lane of a run_lanes call integrates the same model.
module tubes_lanes
  use tubes_kinds, only: wp, i8
  use tubes_field, only: vector_field_t
  use tubes_integrator, only: event_t, observer_t, crossing_log_t, prop_t, prop_after_step
  use tubes_taylor, only: taylor_t
  use tubes_status, only: TUBES_OK, TUBES_EINPUT
  use, intrinsic :: iso_c_binding, only: c_int, c_char
  use tubes_cstrings, only: c_to_f
  use tubes_ensemble, only: ensemble_t, ens_out_t, ens_chunk_items
  implicit none
  private

  integer, parameter, public :: MAX_LANES = 8   !! the widest lanes (8 doubles: AVX-512)
  !> The lanes' driver's builds (run_lanes, src/integrators/tubes_lanes_run.f90, compiled once per
  !> instruction set; the same bits from each): for any processor of the build's architecture
  !> (x86-64: SSE2), for x86-64-v3 (AVX2) and for x86-64-v4 (AVX-512).
  integer, parameter, public :: LANES_BASE = 0, LANES_X86_64_V3 = 1, LANES_X86_64_V4 = 2

  interface
    integer(c_int) function jet_lanes_default(msg, lmsg) bind(C, name='tubes_jet_lanes_default')
      import :: c_int, c_char
      character(kind=c_char), intent(out) :: msg(*)
      integer(c_int), value :: lmsg
    end function jet_lanes_default
    integer(c_int) function lanes_driver_c(forced, msg, lmsg) bind(C, name='tubes_lanes_driver')
      import :: c_int, c_char
      integer(c_int), value :: forced, lmsg
      character(kind=c_char), intent(out) :: msg(*)
    end function lanes_driver_c
  end interface

  !> One lane: an integration in progress.
  type, public :: lane_t
    type(taylor_t) :: ig                          !! its integrator (model, tolerances, t)
    real(wp), allocatable :: x(:)                 !! its state at ig%t
    real(wp) :: tend = 0                          !! where it ends [time]
    class(event_t), allocatable :: event          !! its section, if any
    class(observer_t), allocatable :: observer    !! its observer, if any
    type(crossing_log_t) :: log                   !! its crossings (with use_log)
    logical :: use_log = .false.
    integer :: stat = TUBES_OK                    !! its propagate status, when it ends
    integer :: item = 0                           !! the item it integrates
    logical :: active = .false.
    type(prop_t) :: ps
  contains
    procedure :: setup => lane_setup
  end type lane_t

  !> The items of an ensemble, in lanes or one by one.
  type, abstract, extends(ensemble_t), public :: lane_jobs_t
    logical :: lanes = .false.    !! a chunk in lanes (the Taylor method), else item by item
    integer :: width = 0          !! integrations per kernel call, 1, 2, 4 or 8; 0: lane_width()
    integer :: driver = -1        !! the driver's build (LANES_*, one the processor runs); -1: lane_driver()
  contains
    procedure(start_i), deferred :: start
    procedure(finish_i), deferred :: finish
    procedure :: chunk => lanes_chunk
  end type lane_jobs_t

  abstract interface
    !> Set up item k in lane: lane%ig initialised with the model (ig%init) and its tolerances,
    !> lane%x, lane%tend, and as the item needs lane%event, lane%observer, lane%use_log and
    !> lane%log%max_crossings. stat < 0: the item failed before any integration (finish is
    !> then called with lane%stat = stat).
    subroutine start_i(self, k, lane, stat)
      import :: lane_jobs_t, lane_t
      class(lane_jobs_t), intent(inout) :: self
      integer, intent(in) :: k
      type(lane_t), intent(inout) :: lane
      integer, intent(out) :: stat
    end subroutine start_i
    !> Item k ended in lane: lane%stat is what propagate would have returned (TUBES_OK at
    !> tend or when the observer stopped it, TUBES_EVENT at a stopping crossing, < 0 on
    !> failure), lane%x the state at lane%ig%t. Its result goes to out's column k only.
    subroutine finish_i(self, k, lane, out)
      import :: lane_jobs_t, lane_t, ens_out_t
      class(lane_jobs_t), intent(in) :: self
      integer, intent(in) :: k
      type(lane_t), intent(inout) :: lane
      type(ens_out_t), intent(inout) :: out
    end subroutine finish_i
  end interface

  interface
    !> run_lanes' work (src/integrators/tubes_lanes_run.f90), one build per instruction set.
    !> (The procedures they call here are public: gfortran 12 gives a private one no symbol that
    !> a submodule's object can link to.)
    module subroutine run_lanes_base(jobs, items, out, nl)
      class(lane_jobs_t), intent(inout) :: jobs
      integer, intent(in) :: items(:)
      type(ens_out_t), intent(inout) :: out
      integer, intent(in) :: nl            !! the lanes' width: 1, 2, 4 or 8
    end subroutine run_lanes_base
    module subroutine run_lanes_v3(jobs, items, out, nl)
      class(lane_jobs_t), intent(inout) :: jobs
      integer, intent(in) :: items(:)
      type(ens_out_t), intent(inout) :: out
      integer, intent(in) :: nl            !! the lanes' width: 1, 2, 4 or 8
    end subroutine run_lanes_v3
    module subroutine run_lanes_v4(jobs, items, out, nl)
      class(lane_jobs_t), intent(inout) :: jobs
      integer, intent(in) :: items(:)
      type(ens_out_t), intent(inout) :: out
      integer, intent(in) :: nl            !! the lanes' width: 1, 2, 4 or 8
    end subroutine run_lanes_v4
  end interface

  public :: run_lanes, lane_width, lane_driver, lane_after_step

contains

  !> The lane's integrator for a new item of field, from t = 0 with the item's largest step h,
  !> tolerances and step budget: restarted (a lane's items all have their job's model), or set
  !> up on the lane's first item.
  subroutine lane_setup(self, field, h, rtol, atol, max_steps)
    class(lane_t), intent(inout) :: self
    class(vector_field_t), intent(in) :: field
    real(wp), intent(in) :: h, rtol, atol
    integer(i8), intent(in), optional :: max_steps
    if (allocated(self%ig%f)) then
      call self%ig%restart(0.0_wp)
    else
      call self%ig%init(field, 0.0_wp)
    end if
    self%ig%h = h
    self%ig%rtol = rtol
    self%ig%atol = atol
    if (present(max_steps)) self%ig%max_steps = max_steps
  end subroutine lane_setup

  !> A thread's unit of work: the items ks in lanes, or one by one.
  subroutine lanes_chunk(self, ks, out)
    class(lane_jobs_t), intent(inout) :: self
    integer, intent(in) :: ks(:)
    type(ens_out_t), intent(inout) :: out
    if (self%lanes) then
      call run_lanes(self, ks, out)
    else
      call ens_chunk_items(self, ks, out)
    end if
  end subroutine lanes_chunk

  !> The lanes' width of this processor: $TUBES_LANES if set (1, 2, 4 or 8: forced), else 8 with
  !> AVX-512F, 4 with AVX, 2 otherwise (src/io/tubes_expr.c). stat TUBES_EINPUT with the reason in
  !> msg for any other TUBES_LANES.
  subroutine lane_width(w, stat, msg)
    integer, intent(out) :: w, stat
    character(*), intent(out) :: msg
    character(kind=c_char) :: cmsg(512)
    w = int(jet_lanes_default(cmsg, 512))
    msg = ''
    stat = TUBES_OK
    if (w < 1) then
      msg = c_to_f(cmsg)
      stat = TUBES_EINPUT
      w = 0
    end if
  end subroutine lane_width

  !> The lanes' driver's build to run (LANES_*): forced (>= 0: stat TUBES_EINPUT if this processor
  !> lacks its instructions), else $TUBES_LANES_DRIVER if set (x86-64, x86-64-v3 or x86-64-v4: the
  !> same check), else the widest this processor runs (src/io/tubes_expr.c). The reason in msg.
  subroutine lane_driver(forced, d, stat, msg)
    integer, intent(in) :: forced
    integer, intent(out) :: d, stat
    character(*), intent(out) :: msg
    character(kind=c_char) :: cmsg(512)
    d = int(lanes_driver_c(int(forced, c_int), cmsg, 512))
    msg = ''
    stat = TUBES_OK
    if (d < 0) then
      msg = c_to_f(cmsg)
      stat = TUBES_EINPUT
    end if
  end subroutine lane_driver

  !> Integrate the items `items` (in this order into the lanes as they free up), their results
  !> into out: the lanes' driver built for this processor's vector instructions (lane_driver;
  !> jobs%driver forces one). An item's numbers are the same for every width (jobs%width) and
  !> every build of the driver.
  subroutine run_lanes(jobs, items, out)
    class(lane_jobs_t), intent(inout) :: jobs
    integer, intent(in) :: items(:)
    type(ens_out_t), intent(inout) :: out
    integer :: d, nl, st, i, k
    character(512) :: msg
    type(lane_t) :: lane
    nl = jobs%width
    st = TUBES_OK
    if (nl == 0) call lane_width(nl, st, msg)
    if (st == TUBES_OK) call lane_driver(jobs%driver, d, st, msg)
    if (st /= TUBES_OK .or. .not. any(nl == [1, 2, 4, 8])) then   ! every item fails
      do i = 1, size(items)                     ! (the reason is on stderr: tubes_expr.c)
        lane%item = items(i)
        if (allocated(lane%event)) deallocate (lane%event)
        if (allocated(lane%observer)) deallocate (lane%observer)
        call jobs%start(items(i), lane, k)
        lane%stat = TUBES_EINPUT
        call jobs%finish(items(i), lane, out)
      end do
      return
    end if
    select case (d)
    case (LANES_X86_64_V4)
      call run_lanes_v4(jobs, items, out, nl)
    case (LANES_X86_64_V3)
      call run_lanes_v3(jobs, items, out, nl)
    case default
      call run_lanes_base(jobs, items, out, nl)
    end select
  end subroutine run_lanes

  !> prop_after_step with the lane's own event, observer and log (unallocated: absent): a lane's
  !> end of step in run_lanes.
  subroutine lane_after_step(ln, done, stat, clear)
    type(lane_t), intent(inout) :: ln
    logical, intent(out) :: done
    integer, intent(out) :: stat
    logical, intent(in), optional :: clear      !! the step's event_clear, known (prop_after_step)
    if (ln%use_log) then
      call prop_after_step(ln%ig, ln%x, ln%ps, done, stat, ln%event, ln%observer, ln%log, clear)
    else
      call prop_after_step(ln%ig, ln%x, ln%ps, done, stat, ln%event, ln%observer, clear=clear)
    end if
  end subroutine lane_after_step
end module tubes_lanes
