!> The lanes' driver: run_lanes' work (src/integrators/tubes_lanes.f90; docs/integrators-taylor.md
!> "Ensembles in lanes"), the step control of W integrations in structure-of-arrays form.
!>
!> Compiled three times (the Makefile): as the submodule tubes_lanes_run (run_lanes_base) with the
!> library's flags, for any processor of its architecture (x86-64: SSE2's two doubles per vector),
!> and with -DTUBES_LANES_V=3 and 4 as tubes_lanes_run_v3 (run_lanes_v3, -march=x86-64-v3: AVX2,
!> four) and tubes_lanes_run_v4 (run_lanes_v4, -march=x86-64-v4: AVX-512, eight), both with
!> -ffp-contract=off (no multiply-add the base build and the lone integrator lack: each build's
!> arithmetic is theirs, bit for bit, tests/test_lanes.f90); run_lanes runs the widest the
!> processor has (lane_driver).
#if TUBES_LANES_V == 4
#define TUBES_LANES_SUB tubes_lanes_run_v4
#define TUBES_LANES_RUN run_lanes_v4
#elif TUBES_LANES_V == 3
#define TUBES_LANES_SUB tubes_lanes_run_v3
#define TUBES_LANES_RUN run_lanes_v3
#else
#define TUBES_LANES_SUB tubes_lanes_run
#define TUBES_LANES_RUN run_lanes_base
#endif
submodule (tubes_lanes) TUBES_LANES_SUB
  use tubes_integrator, only: prop_begin, no_crossing
  use tubes_taylor, only: kernel_t, jet_kernel, taylor_prepare, taylor_rule, taylor_order, TAYLOR_MAX_ORDER
  use tubes_status, only: TUBES_EMAXSTEPS, TUBES_EMODEL, TUBES_ESTEP
  implicit none

contains

  !> run_lanes' work: integrate the items `items` (in this order into the lanes as they free up)
  !> in nl lanes (1, 2, 4 or 8), their results into out. An item's numbers are the same for every
  !> width.
  !>
  !> The lanes' step control is in structure-of-arrays form: while a lane integrates an item, its
  !> integrator's fields that a step reads and writes (t, the tolerances, the order and its rule,
  !> the norms, the step's size and end, the counters) and its state live in arrays of W (xs(l, :):
  !> lane l's state), and the step's start (|x|_inf, relative or absolute, 1/|x|, direction, what
  !> is left), the coefficients' norms, the step size (step_sizes: no libm), Horner's scheme and the
  !> refusal checks are loops over the lanes; only the order's logarithm (when the tolerance
  !> changes) and a lane's end run lane by lane. Every
  !> lane's arithmetic is taylor_begin's, taylor_size's, horner's and taylor_advance's, bit for
  !> bit. The lane's taylor_t is written back (store) where its own code takes over: at the item's
  !> end, for an event or an observer (the dense output), and for a step the lanes' kernel cannot
  !> take (no lanes kernel, an extended state, a state not finite: the lane's own step, `slow`).
  module subroutine TUBES_LANES_RUN(jobs, items, out, nl)
    class(lane_jobs_t), intent(inout) :: jobs
    integer, intent(in) :: items(:)
    type(ens_out_t), intent(inout) :: out
    integer, intent(in) :: nl
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
    real(wp), allocatable :: n1(:), n2(:), h(:), hn(:), ds(:), tnx(:)
    real(wp), allocatable :: fin(:), grp(:), lst(:), bad(:), ok(:)
    ! the lanes' events where affine (g = ew(l, :) . x - ec(l); eaf(l) = 1), and the step's
    ! event_clear of each (clr(l) = 1: no root in the step) for all lanes at once
    real(wp), allocatable :: ew(:, :), ec(:), eaf(:), clr(:)
    logical, allocatable :: go(:)
    integer, allocatable :: ord(:)
    real(wp) :: eps, ru(3)
    integer :: nxt, l, m, p, s, k, st, kslot, nn, st1
    logical :: done
    character(512) :: msg
    allocate (lane(nl), ord(nl), grp(nl), tcb(0), wb(0), xb(nl, 0), xs(nl, 0), ew(nl, 0), ec(nl), eaf(nl), clr(nl))
    allocate (t(nl), t_old(nl), tend(nl), hs(nl), hmax(nl), rtol(nl), atol(nl), xn(nl), rxn(nl), dir(nl), &
              left(nl), slack(nl), eps_last(nl), q_bound(nl), pdir(nl), r1(nl), r2(nl), r3(nl), pl(nl), &
              p_last(nl), ford(nl), nq(nl), nsteps(nl), nfev(nl), nps(nl), maxst(nl), relative(nl), &
              fresh(nl), solo(nl), rich(nl), n1(nl), n2(nl), h(nl), hn(nl), ds(nl), tnx(nl), go(nl), &
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
        ! the steps' sizes (taylor_size): the norms of the last two orders, the rule's size
        ! (step_sizes: a vector loop) and the rest over the lanes
        call lanes_norms(tcb, nl, s, nn, rxn, relative*grp, n1, n2)
        call step_sizes(nl, n1, n2, r1, r2, r3, h)
        h = h*grp
        call lanes_sizes(nl, h, hmax, left, slack, t, dir, grp, lst, bad, hn, ds, tnx)
        ! the new states (Horner's scheme) and the model's checks (taylor_advance), all lanes
        if (size(xb, 2) < nn) then
          deallocate (xb)
          allocate (xb(nl, nn))
        end if
        call horner_lanes(tcb, nl, s, nn, p, ds, xb)
        call lanes_advance(nl, nn, xb, nq, q_bound, grp, bad, lst, tend, hn, tnx, t, t_old, hs, nsteps, xs, ok)
        if (any(eaf*ok > 0)) call lanes_event_clear(tcb, nl, s, nn, ew, ec, t, t_old, eaf*ok, clr)
        ! each lane's end of step: its failure, its event and observer, its end
        do l = 1, nl
          if (.not. grp(l) > 0) cycle
          if (.not. ok(l) > 0) then
            call store(l)
            call finish(l, merge(TUBES_ESTEP, TUBES_EMODEL, bad(l) > 0))
          else if (quiet(l)) then                 ! nothing for its event and observer
            nps(l) = nps(l) + 1
            if (.not. pdir(l)*(tend(l) - t(l)) > 0) then
              call store(l)
              call finish(l, TUBES_OK)
            end if
          else if (rich(l)) then                  ! its taylor_t with the step's dense output
            call store(l)
            if (allocated(lane(l)%ig%tc)) then
              if (size(lane(l)%ig%tc) < nn*s) deallocate (lane(l)%ig%tc)
            end if
            if (.not. allocated(lane(l)%ig%tc)) allocate (lane(l)%ig%tc(nn*s))
            call lane_coefficients(tcb, nl, l, nn*s, lane(l)%ig%tc)
            lane(l)%ig%x_end(1:nn) = xs(l, :)     ! the new state: its polynomial at hs (horner_lanes)
            lane(l)%ig%end_ok = .true.
            st1 = TUBES_OK
            k = lane(l)%item
            if (eaf(l) > 0) then
              call stepped(l, st1, clr(l) > 0)
            else
              call stepped(l, st1)
            end if
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

    !> A taken step of lane l (with an event or observer) that needs neither: what
    !> prop_after_step would conclude without the step's dense output. Its event (affine, so the
    !> step's clr(l) is known) has no root in the step and no sign change between its ends (g
    !> then kept as prop_after_step keeps it), and its observer is quiet (observer_t%quiet) at the
    !> step's end. .false.: nothing changed, the lane takes the full path.
    logical function quiet(l) result(q)
      integer, intent(in) :: l
      real(wp) :: g0, g1
      q = .false.
      if (.not. rich(l)) return
      if (allocated(lane(l)%event)) then
        if (.not. (eaf(l) > 0 .and. clr(l) > 0)) return
        g0 = lane(l)%ps%g0
        g1 = lane(l)%event%g(t(l), xs(l, :))
        if (.not. no_crossing(g0, g1)) return
      end if
      if (allocated(lane(l)%observer)) then
        if (.not. lane(l)%observer%quiet(lane(l)%ig, t(l), xs(l, :))) return
      end if
      if (allocated(lane(l)%event)) lane(l)%ps%g0 = g1
      q = .true.
    end function quiet

    !> Lane l's integrator into the arrays (a new item, or after its own code ran).
    subroutine load(l)
      integer, intent(in) :: l
      integer :: st0
      call taylor_prepare(lane(l)%ig, size(lane(l)%x), st0)
      if (nn < 0 .and. st0 == TUBES_OK) then     ! the first item: the state's size
        nn = size(lane(l)%x)
        deallocate (xs, ew)
        allocate (xs(nl, nn), ew(nl, nn))
        xs = 1
        ew = 0
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
      eaf(l) = 0
      ew(l, :) = 0
      ec(l) = 0
      if (allocated(lane(l)%event)) then
        block
          real(wp) :: wv(nn), cv
          logical :: aff
          call lane(l)%event%affine(nn, wv, cv, aff)
          if (aff) then
            ew(l, :) = wv
            ec(l) = cv
            eaf(l) = 1
          end if
        end block
      end if
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
        ig%end_ok = .false.                     ! (its coefficients are not copied here)
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
      r1(l) = 1                                 ! (the step size is computed for every lane)
      r2(l) = 0.5_wp
      r3(l) = -3
      if (size(ew, 2) > 0) ew(l, :) = 0
      ec(l) = 0
      eaf(l) = 0
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
    subroutine stepped(l, st1, clear)
      integer, intent(in) :: l
      integer, intent(inout) :: st1
      logical, intent(in), optional :: clear   !! the step's event_clear, known
      if (st1 < 0) then
        call finish(l, st1)
        return
      end if
      call lane_after_step(lane(l), done, st1, clear)
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
  end subroutine TUBES_LANES_RUN

  !> taylor_event_clear for the lanes with on(l) = 1 (an affine event g = w(l, :) . x - c(l), the
  !> step taken), all at once: clr(l) = 1 where the step surely holds no root (isolate_roots'
  !> bound, root_free), else 0. Each lane's sums are taylor_event_clear's operation for operation
  !> (event_polynomial over the components in order, a weight 0 adding 0; the powers of the step
  !> t - t_old), so the answer is the lone integrator's.
  pure subroutine lanes_event_clear(tc, nl, s, n, w, c, t, t_old, on, clr)
    integer, intent(in) :: nl, s, n
    real(wp), intent(in) :: tc(nl, s, n), w(nl, n), c(nl), t(nl), t_old(nl), on(nl)
    real(wp), intent(out) :: clr(nl)
    real(wp) :: a(nl, s), hk(nl), h(nl), tail(nl), q0(nl), wv, tv, q
    integer :: i, k, l
    do k = 1, s
      do l = 1, nl
        a(l, k) = 0
      end do
    end do
    do i = 1, n
      if (all(w(:, i) == 0)) cycle       ! (it would add 0 to every sum: a section's plane or ray
      do k = 1, s                        ! weighs 1 or 2 of the components)
        !$omp simd private(wv, tv)
        do l = 1, nl
          wv = w(l, i)
          tv = tc(l, k, i)
          a(l, k) = a(l, k) + merge(wv*tv, 0.0_wp, wv /= 0)
        end do
      end do
    end do
    !$omp simd
    do l = 1, nl
      a(l, 1) = a(l, 1) - c(l)
      h(l) = t(l) - t_old(l)
      hk(l) = 1
      q0(l) = a(l, 1)*hk(l)
      hk(l) = hk(l)*h(l)
      tail(l) = 0
    end do
    do k = 2, s
      !$omp simd private(q)
      do l = 1, nl
        q = a(l, k)*hk(l)
        hk(l) = hk(l)*h(l)
        tail(l) = tail(l) + abs(q)
      end do
    end do
    !$omp simd
    do l = 1, nl
      clr(l) = merge(on(l), 0.0_wp, abs(q0(l)) > tail(l)*(1 + 1.0e-3_wp))
    end do
  end subroutine lanes_event_clear

  !> Lane l's coefficients out of the lanes' kernel array (tc(l, j): lane l's j-th, j = (i - 1) s +
  !> k for coefficient k - 1 of component i) into its integrator's array c(1:m), m = n s: its dense
  !> output for an event or observer (a plain strided copy, without the kernel array's index
  !> arithmetic per element).
  pure subroutine lane_coefficients(tc, nl, l, m, c)
    integer, intent(in) :: nl, l, m
    real(wp), intent(in) :: tc(nl, m)
    real(wp), intent(inout) :: c(:)
    integer :: j
    do j = 1, m
      c(j) = tc(l, j)
    end do
  end subroutine lane_coefficients

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
  pure subroutine lanes_sizes(nl, h, hmax, left, slack, t, dir, grp, lst, bad, hn, ds, tnx)
    integer, intent(in) :: nl
    real(wp), intent(in) :: h(nl), hmax(nl), left(nl), slack(nl), t(nl), dir(nl), grp(nl)
    real(wp), intent(out) :: lst(nl), bad(nl), hn(nl), ds(nl), tnx(nl)
    real(wp) :: a, b, c, hm, hh, hmin, ls, bd, g, tn, a2
    integer :: l
    !$omp simd private(a, b, c, hm, hh, hmin, ls, bd, g, tn, a2)
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
      tn = t(l) + a                            ! the step on the time grid (taylor_size)
      a2 = tn - t(l)
      a = merge(a, a2, ls > 0)
      tnx(l) = tn
      hn(l) = a
      g = grp(l)*(1 - bd)
      ds(l) = merge(a, 0.0_wp, g > 0)
    end do
  end subroutine lanes_sizes

  !> taylor_advance for the lanes in grp that are not bad: the step taken (ok = 1) if the new
  !> state x(l, :) is finite and |x(l, 1:nq(l))|_1 <= q_bound(l) (summed in the order of the
  !> components, as sum's): xs, t (tend on the last step), nsteps; hs and t_old as taylor_size's.
  pure subroutine lanes_advance(nl, n, x, nq, q_bound, grp, bad, lst, tend, hn, tnx, t, t_old, hs, nsteps, xs, ok)
    integer, intent(in) :: nl, n, nq(nl)
    real(wp), intent(in) :: x(nl, n), q_bound(nl), tend(nl), hn(nl), tnx(nl), grp(nl), bad(nl), lst(nl)
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
      tn = tnx(l)
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

  !> Horner's scheme for the lanes of the lanes' kernel array (tc(l, k + 1, i): coefficient k of
  !> component i in lane l), each lane at its own ds(l): x(l, :) = sum_k tc(l, k + 1, :) ds(l)^k.
  !> The lanes are independent chains (the vector unit takes several at once, and their latencies
  !> overlap); each lane's arithmetic is horner's, bit for bit.
  pure subroutine horner_lanes(tc, nl, s, n, p, ds, x)
    integer, intent(in) :: nl, s, n, p
    real(wp), intent(in) :: tc(nl, s, n), ds(nl)
    real(wp), intent(out) :: x(nl, n)
    real(wp) :: a1, a2, a3, a4, a5, a6, a7, a8
    integer :: i, k, l
    if (nl == 8) then                  ! eight lanes at a time in registers (one AVX-512 vector)
      do i = 1, n
        a1 = tc(1, p + 1, i)
        a2 = tc(2, p + 1, i)
        a3 = tc(3, p + 1, i)
        a4 = tc(4, p + 1, i)
        a5 = tc(5, p + 1, i)
        a6 = tc(6, p + 1, i)
        a7 = tc(7, p + 1, i)
        a8 = tc(8, p + 1, i)
        do k = p, 1, -1
          a1 = a1*ds(1) + tc(1, k, i)
          a2 = a2*ds(2) + tc(2, k, i)
          a3 = a3*ds(3) + tc(3, k, i)
          a4 = a4*ds(4) + tc(4, k, i)
          a5 = a5*ds(5) + tc(5, k, i)
          a6 = a6*ds(6) + tc(6, k, i)
          a7 = a7*ds(7) + tc(7, k, i)
          a8 = a8*ds(8) + tc(8, k, i)
        end do
        x(1, i) = a1
        x(2, i) = a2
        x(3, i) = a3
        x(4, i) = a4
        x(5, i) = a5
        x(6, i) = a6
        x(7, i) = a7
        x(8, i) = a8
      end do
      return
    end if
    do i = 1, n                        ! four lanes at a time in registers (as horner's components)
      do l = 1, nl - 3, 4
        a1 = tc(l, p + 1, i)
        a2 = tc(l + 1, p + 1, i)
        a3 = tc(l + 2, p + 1, i)
        a4 = tc(l + 3, p + 1, i)
        do k = p, 1, -1
          a1 = a1*ds(l) + tc(l, k, i)
          a2 = a2*ds(l + 1) + tc(l + 1, k, i)
          a3 = a3*ds(l + 2) + tc(l + 2, k, i)
          a4 = a4*ds(l + 3) + tc(l + 3, k, i)
        end do
        x(l, i) = a1
        x(l + 1, i) = a2
        x(l + 2, i) = a3
        x(l + 3, i) = a4
      end do
      do l = 4*(nl/4) + 1, nl
        a1 = tc(l, p + 1, i)
        do k = p, 1, -1
          a1 = a1*ds(l) + tc(l, k, i)
        end do
        x(l, i) = a1
      end do
    end do
  end subroutine horner_lanes
  include 'tubes_step_size.inc'

end submodule TUBES_LANES_SUB
