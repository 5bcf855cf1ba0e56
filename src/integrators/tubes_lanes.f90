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
  use tubes_integrator, only: event_t, observer_t, crossing_log_t, prop_t, prop_begin, prop_after_step
  use tubes_taylor, only: taylor_t, kernel_t, taylor_begin, taylor_size, taylor_advance, horner_lanes, jet_kernel
  use tubes_status, only: TUBES_OK, TUBES_EMAXSTEPS, TUBES_EMODEL, TUBES_EINPUT
  use, intrinsic :: iso_c_binding, only: c_int, c_char
  use tubes_cstrings, only: c_to_f
  use tubes_ensemble, only: ensemble_t, ens_out_t, ens_chunk_items
  implicit none
  private

  integer, parameter, public :: MAX_LANES = 8   !! the widest lanes (8 doubles: AVX-512)

  interface
    integer(c_int) function jet_lanes_default(msg, lmsg) bind(C, name='tubes_jet_lanes_default')
      import :: c_int, c_char
      character(kind=c_char), intent(out) :: msg(*)
      integer(c_int), value :: lmsg
    end function jet_lanes_default
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

  public :: run_lanes, lane_width

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

  !> Integrate the items `items` (in this order into the lanes as they free up), their results
  !> into out. An item's numbers are the same for every width (jobs%width).
  subroutine run_lanes(jobs, items, out)
    class(lane_jobs_t), intent(inout) :: jobs
    integer, intent(in) :: items(:)
    type(ens_out_t), intent(inout) :: out
    type(lane_t), allocatable :: lane(:)
    type(kernel_t) :: kern(2)
    real(wp), allocatable :: tcb(:), wb(:), ds(:), xb(:, :)
    integer :: nxt, l, m, p, s, i, k, ik, st, n, kslot, nl
    integer, allocatable :: ord(:), sts(:)
    logical, allocatable :: grp(:), lst(:)
    logical :: done
    character(512) :: msg
    nl = jobs%width
    st = TUBES_OK
    if (nl == 0) call lane_width(nl, st, msg)
    if (st /= TUBES_OK .or. .not. any(nl == [1, 2, 4, 8])) then   ! no width: every item fails
      allocate (lane(1))                        ! (the reason is on stderr: tubes_expr.c)
      do i = 1, size(items)
        lane(1)%item = items(i)
        if (allocated(lane(1)%event)) deallocate (lane(1)%event)
        if (allocated(lane(1)%observer)) deallocate (lane(1)%observer)
        call jobs%start(items(i), lane(1), k)
        lane(1)%stat = TUBES_EINPUT
        call jobs%finish(items(i), lane(1), out)
      end do
      return
    end if
    allocate (lane(nl), ord(nl), grp(nl), tcb(0), wb(0), ds(nl), sts(nl), lst(nl), xb(nl, 0))
    nxt = 1
    do l = 1, nl
      call fill(l)
    end do
    do while (any(lane%active))
      ! the lanes' orders (one, unless rtol and atol make some lanes relative and others not)
      ord = 0
      do l = 1, nl
        if (.not. lane(l)%active) cycle
        if (lane(l)%ps%n >= lane(l)%ig%max_steps) then
          call finish(l, TUBES_EMAXSTEPS)
          cycle
        end if
        call taylor_begin(lane(l)%ig, lane(l)%x, lane(l)%tend, ik, st)
        if (st /= TUBES_OK) then
          call finish(l, st)
          cycle
        end if
        ord(l) = lane(l)%ig%p
      end do
      do while (any(ord > 0))
        p = maxval(ord)
        grp = ord == p
        ord = merge(0, ord, grp)
        m = findloc(grp, .true., 1)
        call batch_kernel(p, kslot, st, msg)
        if (st /= TUBES_OK) then                ! no lanes kernel: each lane on its own
          do l = 1, nl
            if (grp(l)) call lone_step(l)
          end do
          cycle
        end if
        s = p + 1
        n = size(lane(m)%x)
        if (size(tcb) < n*s*nl) then
          deallocate (tcb)
          allocate (tcb(n*s*nl))
        end if
        if (size(wb) < kern(kslot)%nwork*s*nl) then
          deallocate (wb)
          allocate (wb(kern(kslot)%nwork*s*nl))
        end if
        do l = 1, nl                         ! a free lane computes a copy of a busy one
          k = merge(l, m, grp(l))
          do i = 1, n                           ! (its state: taylor_begin's order 0)
            tcb(((i - 1)*s)*nl + l) = lane(k)%x(i)
          end do
        end do
        if (kern(kslot)%fn(p, lane(m)%ig%par, tcb, wb) /= 0) then   ! some lane not finite:
          do l = 1, nl                                           ! each on its own says which
            if (grp(l)) call lone_step(l)
          end do
          cycle
        end if
        ! the rest of the lanes' steps, as taylor_end's: each lane's size, then the new states of
        ! all (one Horner's scheme, the lanes side by side), then each lane's end, events and
        ! observer (their coefficients read in place in tcb; copied to the lane's integrator only
        ! where its dense output is needed)
        if (size(xb, 2) < n) then
          deallocate (xb)
          allocate (xb(nl, n))
        end if
        ds = 0
        do l = 1, nl
          sts(l) = TUBES_OK
          if (.not. grp(l)) cycle
          call taylor_size(lane(l)%ig, tcb(l:), nl, lst(l), sts(l))
          if (sts(l) == TUBES_OK) ds(l) = lane(l)%ig%hs
        end do
        call horner_lanes(tcb, nl, s, n, p, ds, xb)
        do l = 1, nl
          if (.not. grp(l)) cycle
          if (sts(l) == TUBES_OK) then
            do i = 1, n                         ! (no reallocation test: x has its size)
              lane(l)%x(i) = xb(l, i)
            end do
            call taylor_advance(lane(l)%ig, tcb(l:), nl, lane(l)%x, lane(l)%tend, lst(l), sts(l))
            if (allocated(lane(l)%event) .or. allocated(lane(l)%observer)) then   ! the dense output
              do i = 1, n
                do k = 1, p
                  lane(l)%ig%tc((i - 1)*s + k + 1) = tcb(((i - 1)*s + k)*nl + l)
                end do
              end do
            end if
          end if
          call stepped(l, sts(l))
        end do
      end do
    end do
  contains
    !> Lane l takes the next item, if any.
    subroutine fill(l)
      integer, intent(in) :: l
      integer :: st0
      do while (nxt <= size(items))
        lane(l)%item = items(nxt)
        nxt = nxt + 1
        if (allocated(lane(l)%event)) deallocate (lane(l)%event)
        if (allocated(lane(l)%observer)) deallocate (lane(l)%observer)
        lane(l)%use_log = .false.
        call lane(l)%log%clear()
        lane(l)%stat = TUBES_OK
        call jobs%start(lane(l)%item, lane(l), st0)
        if (st0 >= 0) then          ! (an unallocated event is an absent argument)
          if (lane(l)%use_log) then
            call prop_begin(lane(l)%ig, lane(l)%x, lane(l)%tend, lane(l)%ps, st0, lane(l)%event, lane(l)%log)
          else
            call prop_begin(lane(l)%ig, lane(l)%x, lane(l)%tend, lane(l)%ps, st0, lane(l)%event)
          end if
        end if
        if (st0 == TUBES_OK .and. lane(l)%ps%dir*(lane(l)%tend - lane(l)%ig%t) > 0) then
          lane(l)%active = .true.
          return
        end if
        lane(l)%stat = st0                      ! failed, or nothing to integrate
        call jobs%finish(lane(l)%item, lane(l), out)
      end do
      lane(l)%active = .false.
    end subroutine fill

    !> Lane l ends with status st: its result, then the next item.
    subroutine finish(l, st)
      integer, intent(in) :: l, st
      lane(l)%stat = st
      lane(l)%active = .false.
      call jobs%finish(lane(l)%item, lane(l), out)
      call fill(l)
    end subroutine finish

    !> Lane l's step by its own one-lane kernel (taylor_begin was called).
    subroutine lone_step(l)
      integer, intent(in) :: l
      integer :: st1
      call lane(l)%ig%step(lane(l)%x, lane(l)%tend, st1)
      lane(l)%ig%nfev = lane(l)%ig%nfev - 1     ! taylor_begin counted this step's evaluation
      call stepped(l, st1)
    end subroutine lone_step

    !> Lane l has taken its step with status st1: its events, observer and end, as propagate's.
    subroutine stepped(l, st1)
      integer, intent(in) :: l
      integer, intent(inout) :: st1
      if (st1 < 0) then
        call finish(l, st1)
        return
      end if
      call lane_after_step(lane(l), done, st1)
      if (done) then
        call finish(l, st1)
      else if (.not. lane(l)%ps%dir*(lane(l)%tend - lane(l)%ig%t) > 0) then
        call finish(l, TUBES_OK)
      end if
    end subroutine stepped

    !> The kernel of order p for nl lanes (kept: at most two orders), slot kslot.
    subroutine batch_kernel(p, kslot, st, msg)
      integer, intent(in) :: p
      integer, intent(out) :: kslot, st
      character(*), intent(out) :: msg
      st = TUBES_OK
      do kslot = 1, 2
        if (kern(kslot)%order == p) return
      end do
      msg = ''                                  ! (512 blanks: not on every step)
      kslot = merge(2, 1, kern(1)%order >= 0)
      if (kslot == 2 .and. kern(2)%order >= 0) kern(1) = kern(2)
      if (lane(m)%ig%flags /= 0) then
        st = TUBES_EMODEL                       ! an extended state's loop kernel has no lanes
        return
      end if
      call jet_kernel(lane(m)%ig%spec, p, nl, lane(m)%ig%flags, kern(kslot), msg, st)
    end subroutine batch_kernel
  end subroutine run_lanes

  !> prop_after_step with the lane's own event, observer and log (unallocated: absent).
  subroutine lane_after_step(ln, done, stat)
    type(lane_t), intent(inout) :: ln
    logical, intent(out) :: done
    integer, intent(out) :: stat
    if (ln%use_log) then
      call prop_after_step(ln%ig, ln%x, ln%ps, done, stat, ln%event, ln%observer, ln%log)
    else
      call prop_after_step(ln%ig, ln%x, ln%ps, done, stat, ln%event, ln%observer)
    end if
  end subroutine lane_after_step
end module tubes_lanes
