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
  use tubes_taylor, only: taylor_t, kernel_t, horner_lanes, jet_kernel, taylor_prepare, taylor_rule, taylor_order, &
                          log_rho, TAYLOR_MAX_ORDER
  use tubes_status, only: TUBES_OK, TUBES_EMAXSTEPS, TUBES_EMODEL, TUBES_EINPUT, TUBES_ESTEP
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
  !>
  !> The lanes' step control is in structure-of-arrays form: while a lane integrates an item, its
  !> integrator's fields that a step reads and writes (t, the tolerances, the order and its rule,
  !> the norms, the step's size and end, the counters) and its state live in arrays of W (xs(l, :):
  !> lane l's state), and the step's start (|x|_inf, relative or absolute, 1/|x|, direction, what
  !> is left), the coefficients' norms, Horner's scheme and the refusal checks are loops over the
  !> lanes; only the order's logarithm (when the tolerance changes), the step size's log and exp
  !> (libm's scalar functions, as the lone integrator's) and a lane's end run lane by lane. Every
  !> lane's arithmetic is taylor_begin's, taylor_size's, horner's and taylor_advance's, bit for
  !> bit. The lane's taylor_t is written back (store) where its own code takes over: at the item's
  !> end, for an event or an observer (the dense output), and for a step the lanes' kernel cannot
  !> take (no lanes kernel, an extended state, a state not finite: the lane's own step, `slow`).
  subroutine run_lanes(jobs, items, out)
    class(lane_jobs_t), intent(inout) :: jobs
    integer, intent(in) :: items(:)
    type(ens_out_t), intent(inout) :: out
    type(lane_t), allocatable :: lane(:)
    type(kernel_t) :: kern(2)
    real(wp), allocatable :: tcb(:), wb(:), xb(:, :), xs(:, :)
    ! the lanes' integrators' step fields (taylor_t's of the same names)
    real(wp), allocatable :: t(:), t_old(:), tend(:), hs(:), hmax(:), rtol(:), atol(:), xn(:), rxn(:), &
                             dir(:), left(:), slack(:), eps_last(:), q_bound(:), pdir(:), r1(:), r2(:), r3(:)
    integer, allocatable :: pl(:), p_last(:), ford(:), nq(:)
    integer(i8), allocatable :: nsteps(:), nfev(:), nps(:), maxst(:)
    real(wp), allocatable :: relative(:)           ! (masks over the lanes: 1 or 0, as reals: they vectorise)
    logical, allocatable :: fresh(:), solo(:), rich(:)
    ! the step's temporaries
    real(wp), allocatable :: n1(:), n2(:), h(:), hn(:), ds(:)
    real(wp), allocatable :: fin(:), grp(:), lst(:), bad(:), ok(:)
    logical, allocatable :: go(:)
    integer, allocatable :: ord(:)
    real(wp) :: eps, lrho, ru(3)
    integer :: nxt, l, m, p, s, i, k, st, kslot, nl, nn, st1
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
    allocate (lane(nl), ord(nl), grp(nl), tcb(0), wb(0), xb(nl, 0), xs(nl, 0))
    allocate (t(nl), t_old(nl), tend(nl), hs(nl), hmax(nl), rtol(nl), atol(nl), xn(nl), rxn(nl), dir(nl), &
              left(nl), slack(nl), eps_last(nl), q_bound(nl), pdir(nl), r1(nl), r2(nl), r3(nl), pl(nl), &
              p_last(nl), ford(nl), nq(nl), nsteps(nl), nfev(nl), nps(nl), maxst(nl), relative(nl), &
              fresh(nl), solo(nl), rich(nl), n1(nl), n2(nl), h(nl), hn(nl), ds(nl), go(nl), &
              fin(nl), lst(nl), bad(nl), ok(nl))
    nn = -1                                     ! the state's size (the first item's)
    do l = 1, nl
      call benign(l)
    end do
    nxt = 1
    do l = 1, nl
      call fill(l)
    end do
    do while (any(lane%active))
      ! the lanes whose model has no lanes kernel: each its own step
      do l = 1, nl
        if (.not. (lane(l)%active .and. solo(l))) cycle
        if (lane(l)%ps%n >= lane(l)%ig%max_steps) then
          call finish(l, TUBES_EMAXSTEPS)
          cycle
        end if
        call lane(l)%ig%step(lane(l)%x, lane(l)%tend, st1)
        call stepped(l, st1)
      end do
      do l = 1, nl
        go(l) = lane(l)%active .and. .not. solo(l)
        if (go(l) .and. nps(l) >= maxst(l)) then
          call store(l)
          call finish(l, TUBES_EMAXSTEPS)
          go(l) = .false.
        end if
      end do
      ! the steps' start (taylor_begin), all lanes at once (a lane that does not step has a
      ! harmless copy: benign)
      call lanes_begin(nl, nn, xs, rtol, atol, t, tend, xn, fin, relative, rxn, dir, left, slack)
      ! each lane's order (a logarithm only when its tolerance changes)
      do l = 1, nl
        ord(l) = 0
        if (.not. go(l)) cycle
        eps = merge(rtol(l), atol(l), relative(l) > 0)
        if (.not. (fin(l) > 0 .and. eps > 0)) then   ! its own step says what is wrong
          call slow(l, .false.)
          cycle
        end if
        p = ford(l)
        if (p <= 0) then
          if (eps /= eps_last(l)) then
            eps_last(l) = eps
            p_last(l) = taylor_order(eps)
          end if
          p = p_last(l)
        end if
        if (p /= pl(l)) then
          if (p < 2 .or. p > TAYLOR_MAX_ORDER) then
            call slow(l, .false.)
            cycle
          end if
          ru = taylor_rule(p)
          r1(l) = ru(1)
          r2(l) = ru(2)
          r3(l) = ru(3)
          pl(l) = p
        end if
        ord(l) = p
        nfev(l) = nfev(l) + 1
        fresh(l) = .false.
      end do
      ! the lanes' orders (one, unless rtol and atol make some lanes relative and others not)
      do while (any(ord > 0))
        p = maxval(ord)
        grp = merge(1.0_wp, 0.0_wp, ord == p)
        ord = merge(0, ord, grp > 0)
        m = findloc(grp > 0, .true., 1)
        call batch_kernel(p, kslot, st, msg)
        if (st /= TUBES_OK) then                ! no lanes kernel: each lane on its own
          do l = 1, nl
            if (grp(l) > 0) call slow(l, .true.)
          end do
          cycle
        end if
        s = p + 1
        if (size(tcb) < nn*s*nl) then
          deallocate (tcb)
          allocate (tcb(nn*s*nl))
        end if
        if (size(wb) < kern(kslot)%nwork*s*nl) then
          deallocate (wb)
          allocate (wb(kern(kslot)%nwork*s*nl))
        end if
        call lanes_states(nl, s, nn, xs, grp, m, tcb)
        if (kern(kslot)%fn(p, lane(m)%ig%par, tcb, wb) /= 0) then   ! some lane not finite:
          do l = 1, nl                                           ! each on its own says which
            if (grp(l) > 0) call slow(l, .true.)
          end do
          cycle
        end if
        ! the steps' sizes (taylor_size): the norms of the last two orders over the lanes, each
        ! lane's log and exp, then the rest over the lanes again
        call lanes_norms(tcb, nl, s, nn, rxn, relative*grp, n1, n2)
        do l = 1, nl
          h(l) = 0
          if (.not. grp(l) > 0) cycle
          if (tiny(1.0_wp) <= min(n1(l), n2(l)) .and. max(n1(l), n2(l)) <= huge(1.0_wp)) then
            lrho = log_rho(n1(l), n2(l), r1(l), r2(l))
          else
            lrho = huge(1.0_wp)
            if (n1(l) > 0) lrho = -log(n1(l))*r1(l)
            if (n2(l) > 0) lrho = min(lrho, -log(n2(l))*r2(l))
          end if
          if (lrho < log(huge(1.0_wp))) then
            h(l) = exp(lrho + r3(l))
          else
            h(l) = huge(1.0_wp)
          end if
        end do
        call lanes_sizes(nl, h, hmax, left, slack, t, dir, grp, lst, bad, hn, ds)
        ! the new states (Horner's scheme) and the model's checks (taylor_advance), all lanes
        if (size(xb, 2) < nn) then
          deallocate (xb)
          allocate (xb(nl, nn))
        end if
        call horner_lanes(tcb, nl, s, nn, p, ds, xb)
        call lanes_advance(nl, nn, xb, nq, q_bound, grp, bad, lst, tend, hn, t, t_old, hs, nsteps, xs, ok)
        ! each lane's end of step: its failure, its event and observer, its end
        do l = 1, nl
          if (.not. grp(l) > 0) cycle
          if (.not. ok(l) > 0) then
            call store(l)
            call finish(l, merge(TUBES_ESTEP, TUBES_EMODEL, bad(l) > 0))
          else if (rich(l)) then                  ! its taylor_t with the step's dense output
            call store(l)
            if (allocated(lane(l)%ig%tc)) then
              if (size(lane(l)%ig%tc) < nn*s) deallocate (lane(l)%ig%tc)
            end if
            if (.not. allocated(lane(l)%ig%tc)) allocate (lane(l)%ig%tc(nn*s))
            do i = 1, nn
              do k = 1, s
                lane(l)%ig%tc((i - 1)*s + k) = tcb(((i - 1)*s + k - 1)*nl + l)
              end do
            end do
            st1 = TUBES_OK
            k = lane(l)%item
            call stepped(l, st1)
            if (lane(l)%active .and. lane(l)%item == k) nps(l) = lane(l)%ps%n   ! (t, x: as they were)
          else
            nps(l) = nps(l) + 1
            if (.not. pdir(l)*(tend(l) - t(l)) > 0) then
              call store(l)
              call finish(l, TUBES_OK)
            end if
          end if
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
          call load(l)
          return
        end if
        lane(l)%stat = st0                      ! failed, or nothing to integrate
        call jobs%finish(lane(l)%item, lane(l), out)
      end do
      lane(l)%active = .false.
      call benign(l)
    end subroutine fill

    !> Lane l's integrator into the arrays (a new item, or after its own code ran).
    subroutine load(l)
      integer, intent(in) :: l
      integer :: st0
      call taylor_prepare(lane(l)%ig, size(lane(l)%x), st0)
      if (nn < 0 .and. st0 == TUBES_OK) then     ! the first item: the state's size
        nn = size(lane(l)%x)
        deallocate (xs)
        allocate (xs(nl, nn))
        xs = 1
      end if
      rich(l) = allocated(lane(l)%event) .or. allocated(lane(l)%observer)
      solo(l) = st0 /= TUBES_OK .or. lane(l)%ig%flags /= 0 .or. size(lane(l)%x) /= nn
      if (solo(l)) then                         ! its own steps (its errors: its own step's)
        call benign(l)
        return
      end if
      associate (ig => lane(l)%ig)
        t(l) = ig%t
        t_old(l) = ig%t_old
        tend(l) = lane(l)%tend
        hs(l) = ig%hs
        hmax(l) = ig%h
        rtol(l) = ig%rtol
        atol(l) = ig%atol
        eps_last(l) = ig%eps_last
        p_last(l) = ig%p_last
        ford(l) = ig%order
        pl(l) = 0                               ! the rule: from the order afresh unless kept
        if (ig%ik /= 0) then
          pl(l) = ig%p
          r1(l) = ig%rule(1)
          r2(l) = ig%rule(2)
          r3(l) = ig%rule(3)
        end if
        nq(l) = ig%nq
        q_bound(l) = ig%q_bound
        nsteps(l) = ig%nsteps
        nfev(l) = ig%nfev
        maxst(l) = ig%max_steps
        fresh(l) = ig%fresh
      end associate
      xs(l, :) = lane(l)%x
      nps(l) = lane(l)%ps%n
      pdir(l) = lane(l)%ps%dir
    end subroutine load

    !> Lane l's arrays back into its integrator and state (its own code takes over).
    subroutine store(l)
      integer, intent(in) :: l
      associate (ig => lane(l)%ig)
        ig%t = t(l)
        ig%t_old = t_old(l)
        ig%hs = hs(l)
        ig%xn = xn(l)
        ig%relative = relative(l) > 0
        ig%rxn = rxn(l)
        ig%dir = dir(l)
        ig%left = left(l)
        ig%slack = slack(l)
        ig%eps_last = eps_last(l)
        ig%p_last = p_last(l)
        if (pl(l) > 0 .and. pl(l) /= ig%p) then  ! another order: its kernel, storage and rule
          ig%p = pl(l)                            ! afresh on its own next step
          ig%ik = 0
        end if
        ig%nsteps = nsteps(l)
        ig%nfev = nfev(l)
        ig%fresh = fresh(l)
      end associate
      lane(l)%x = xs(l, :)
      lane(l)%ps%n = nps(l)
    end subroutine store

    !> Lane l without an item (or on its own steps): values that no loop over the lanes can trip
    !> on (its results are never used).
    subroutine benign(l)
      integer, intent(in) :: l
      if (size(xs, 2) > 0) xs(l, :) = 1
      t(l) = 0
      t_old(l) = 0
      tend(l) = 1
      hs(l) = 0
      hmax(l) = 0
      rtol(l) = 1
      atol(l) = 1
      xn(l) = 1
      rxn(l) = 1
      relative(l) = 0
      q_bound(l) = huge(1.0_wp)
      nq(l) = 0
      pdir(l) = 1
      nps(l) = 0
      maxst(l) = 1
      pl(l) = 0
    end subroutine benign

    !> Lane l ends with status st (its integrator and state are up to date): its result, then
    !> the next item.
    subroutine finish(l, st)
      integer, intent(in) :: l, st
      lane(l)%stat = st
      lane(l)%active = .false.
      call jobs%finish(lane(l)%item, lane(l), out)
      call fill(l)
    end subroutine finish

    !> Lane l's step by its own one-lane kernel (begun: its evaluation was counted already).
    subroutine slow(l, begun)
      integer, intent(in) :: l
      logical, intent(in) :: begun
      integer :: st1
      call store(l)
      call lane(l)%ig%step(lane(l)%x, lane(l)%tend, st1)
      if (begun) lane(l)%ig%nfev = lane(l)%ig%nfev - 1
      call stepped(l, st1)
      if (lane(l)%active) call load(l)
    end subroutine slow

    !> Lane l has taken its step with status st1 (its integrator and state up to date): its
    !> events, observer and end, as propagate's.
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
      if (st == TUBES_OK .and. kern(kslot)%dim /= nn) then   ! not this state's: the lanes'
        kern(kslot) = kernel_t()                            ! own steps say so
        st = TUBES_EMODEL
      end if
    end subroutine batch_kernel
  end subroutine run_lanes

  !> The steps' start (taylor_begin's) of the lanes' states xs(l, :) at t(l) towards tend(l):
  !> xn = |x|_inf, fin: x finite (1, else 0), relative control (1) or not (0), rxn = 1/xn
  !> (relative lanes), the direction, what is left, and the slack of the last step.
  !> (Here and in the lanes_* below: masks as reals 1 or 0, values loaded and computed into
  !> locals before a merge chooses between them: loops gfortran vectorises, -fopt-info-vec; a
  !> merge of an expression is a branch, and so is an integer or logical mask from a real
  !> comparison.)
  pure subroutine lanes_begin(nl, n, xs, rtol, atol, t, tend, xn, fin, relative, rxn, dir, left, slack)
    integer, intent(in) :: nl, n
    real(wp), intent(in) :: xs(nl, n), rtol(nl), atol(nl), t(nl), tend(nl)
    real(wp), intent(out) :: xn(nl), dir(nl), left(nl), slack(nl), fin(nl), relative(nl)
    real(wp), intent(inout) :: rxn(nl)
    real(wp) :: a, f, hi
    integer :: i, l
    do l = 1, nl
      xn(l) = 0
      fin(l) = 1
    end do
    hi = huge(1.0_wp)
    do i = 1, n
      !$omp simd private(a, f)
      do l = 1, nl
        a = abs(xs(l, i))
        f = fin(l)
        xn(l) = max(xn(l), a)
        fin(l) = merge(f, 0.0_wp, a <= hi)
      end do
    end do
    !$omp simd
    do l = 1, nl
      relative(l) = merge(1.0_wp, 0.0_wp, rtol(l)*xn(l) > atol(l))
      dir(l) = sign(1.0_wp, tend(l) - t(l))
      left(l) = abs(tend(l) - t(l))
      slack(l) = 64*epsilon(1.0_wp)*max(abs(t(l)), abs(tend(l)))
    end do
    do l = 1, nl                    ! (a division only where relative: xn may be 0 elsewhere)
      if (relative(l) > 0) rxn(l) = 1/xn(l)
    end do
  end subroutine lanes_begin

  !> The coefficients of order 0 of the lanes' kernel array tc(l, k + 1, i): the states xs(l, :)
  !> of the lanes in grp, lane m's for the others (a copy that computes nothing of use).
  pure subroutine lanes_states(nl, s, n, xs, grp, m, tc)
    integer, intent(in) :: nl, s, n, m
    real(wp), intent(in) :: xs(nl, n), grp(nl)
    real(wp), intent(inout) :: tc(nl, s, n)
    real(wp) :: a, b
    integer :: i, l
    do i = 1, n
      b = xs(m, i)
      !$omp simd private(a)
      do l = 1, nl
        a = xs(l, i)
        tc(l, 1, i) = merge(a, b, grp(l) > 0)
      end do
    end do
  end subroutine lanes_states

  !> The largest |coefficient| of orders s - 2 and s - 1 of each lane over the components
  !> (taylor_size's n1, n2), tc(l, k + 1, i): coefficient k of component i in lane l; times
  !> rxn(l) where rel(l) = 1 (relative control).
  pure subroutine lanes_norms(tc, nl, s, n, rxn, rel, n1, n2)
    integer, intent(in) :: nl, s, n
    real(wp), intent(in) :: tc(nl, s, n), rxn(nl), rel(nl)
    real(wp), intent(out) :: n1(nl), n2(nl)
    real(wp) :: a, sc
    integer :: i, l
    do l = 1, nl
      n1(l) = 0
      n2(l) = 0
    end do
    do i = 1, n
      !$omp simd
      do l = 1, nl
        n1(l) = max(n1(l), abs(tc(l, s - 1, i)))
        n2(l) = max(n2(l), abs(tc(l, s, i)))
      end do
    end do
    !$omp simd private(a, sc)
    do l = 1, nl
      a = rxn(l)
      sc = merge(a, 1.0_wp, rel(l) > 0)
      n1(l) = n1(l)*sc                        ! (x 1: exact)
      n2(l) = n2(l)*sc
    end do
  end subroutine lanes_norms

  !> The rest of taylor_size for the lanes, from each lane's h (the series' step): at most hmax
  !> (if > 0), the last step lst (h = left), bad: too small to be taken, the signed step hn, and
  !> ds (hn for the lanes in grp that take it, else 0) for Horner's scheme.
  pure subroutine lanes_sizes(nl, h, hmax, left, slack, t, dir, grp, lst, bad, hn, ds)
    integer, intent(in) :: nl
    real(wp), intent(in) :: h(nl), hmax(nl), left(nl), slack(nl), t(nl), dir(nl), grp(nl)
    real(wp), intent(out) :: lst(nl), bad(nl), hn(nl), ds(nl)
    real(wp) :: a, b, c, hm, hh, hmin, ls, bd, g
    integer :: l
    !$omp simd private(a, b, c, hm, hh, hmin, ls, bd, g)
    do l = 1, nl
      a = h(l)
      b = hmax(l)
      c = left(l)
      hm = min(a, b)
      hh = merge(hm, a, b > 0)
      ls = merge(1.0_wp, 0.0_wp, hh >= c - slack(l))
      hh = merge(c, hh, ls > 0)
      hmin = 16*epsilon(1.0_wp)*max(abs(t(l)), tiny(1.0_wp))
      bd = merge(0.0_wp, 1.0_wp, hh >= hmin)*(1 - ls)
      lst(l) = ls
      bad(l) = bd
      a = dir(l)*hh
      hn(l) = a
      g = grp(l)*(1 - bd)
      ds(l) = merge(a, 0.0_wp, g > 0)
    end do
  end subroutine lanes_sizes

  !> taylor_advance for the lanes in grp that are not bad: the step taken (ok = 1) if the new
  !> state x(l, :) is finite and |x(l, 1:nq(l))|_1 <= q_bound(l) (summed in the order of the
  !> components, as sum's): xs, t (tend on the last step), nsteps; hs and t_old as taylor_size's.
  pure subroutine lanes_advance(nl, n, x, nq, q_bound, grp, bad, lst, tend, hn, t, t_old, hs, nsteps, xs, ok)
    integer, intent(in) :: nl, n, nq(nl)
    real(wp), intent(in) :: x(nl, n), q_bound(nl), tend(nl), hn(nl), grp(nl), bad(nl), lst(nl)
    real(wp), intent(inout) :: t(nl), t_old(nl), hs(nl), xs(nl, n)
    integer(i8), intent(inout) :: nsteps(nl)
    real(wp), intent(out) :: ok(nl)
    real(wp) :: qs(nl), fin(nl), a, b, f, q, g, tl, tn, te, hi
    integer :: i, l
    do l = 1, nl
      fin(l) = 1
      qs(l) = 0
    end do
    hi = huge(1.0_wp)
    do i = 1, n
      !$omp simd private(a, f, q)
      do l = 1, nl
        a = abs(x(l, i))
        f = fin(l)
        fin(l) = merge(f, 0.0_wp, a <= hi)
        q = merge(a, 0.0_wp, i <= nq(l))
        qs(l) = qs(l) + q                      ! (+ 0: exact)
      end do
    end do
    !$omp simd private(a, b, g, tl, tn, te)
    do l = 1, nl
      g = grp(l)*(1 - bad(l))
      ok(l) = merge(g*fin(l), 0.0_wp, qs(l) <= q_bound(l))
      a = hn(l)
      b = hs(l)
      hs(l) = merge(a, b, g > 0)
      tl = t(l)
      b = t_old(l)
      t_old(l) = merge(tl, b, g > 0)
      te = tend(l)
      tn = tl + a
      tn = merge(te, tn, lst(l) > 0)
      t(l) = merge(tn, tl, ok(l) > 0)
    end do
    do l = 1, nl
      if (ok(l) > 0) nsteps(l) = nsteps(l) + 1
    end do
    do i = 1, n
      !$omp simd private(a, b)
      do l = 1, nl
        a = x(l, i)
        b = xs(l, i)
        xs(l, i) = merge(a, b, ok(l) > 0)
      end do
    end do
  end subroutine lanes_advance

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
