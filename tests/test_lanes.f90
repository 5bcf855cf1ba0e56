!> Test items for test_lanes: trajectories of the ball from a list of states, each to a time of
!> its own, with a section (non-terminal, logged) and, for every third item, a terminal one; every
!> second item also watched by the Monte Carlo's gate (a line with a bounded segment: the
!> integration ends where it passes the segment, crossings beside it counted), whose steps the
!> lanes leave out where it is quiet (observer_t%quiet). Item 10's section is a plane it never
!> reaches (y = -100 cm): it crosses the gate's line beside the segment, back, and then within
!> it with every step between on the quiet path.
module test_lanes_jobs
  use tubes_kinds, only: wp, i8
  use tubes_hamiltonian, only: hamiltonian_t
  use tubes_integrator, only: plane_t, propagate, crossing_log_t
  use tubes_taylor, only: taylor_t
  use tubes_lanes, only: lane_t, lane_jobs_t
  use tubes_ensemble, only: ens_out_t
  use tubes_status, only: TUBES_OK
  use tubes_transport, only: gate_t
  implicit none
  private
  public :: traj_jobs_t

  integer, parameter, public :: MAXX = 50           !! crossing times kept per item
  !> an item's reals: final state, time, crossings, their times, the gate passed (1) and crossings beside it
  integer, parameter, public :: NR = 4 + 2 + MAXX + 2

  type, extends(lane_jobs_t) :: traj_jobs_t
    class(hamiltonian_t), allocatable :: model
    real(wp), allocatable :: x0(:, :), tend(:)
    real(wp) :: tol = 1.0e-12_wp      !! rtol (and atol, unless atol > 0)
    real(wp) :: atol = -1
    integer(i8) :: budget = 0         !! > 0: the step budget (max_steps) of every fourth item
    logical :: sections = .true.      !! the items' section (else none: no dense output needed)
  contains
    procedure :: item => traj_item
    procedure :: start => traj_start
    procedure :: finish => traj_finish
  end type traj_jobs_t

contains

  !> Item k alone: the Taylor method's propagate with the same event (the lanes' reference).
  subroutine traj_item(self, k, out)
    class(traj_jobs_t), intent(in) :: self
    integer, intent(in) :: k
    type(ens_out_t), intent(inout) :: out
    type(taylor_t) :: ig
    type(crossing_log_t) :: log
    type(gate_t) :: gate
    real(wp) :: x(4)
    integer :: stat
    call ig%init(self%model, 0.0_wp)
    ig%rtol = self%tol
    ig%atol = merge(self%atol, self%tol, self%atol > 0)
    if (self%budget > 0 .and. mod(k, 4) == 2) ig%max_steps = self%budget
    x = self%x0(:, k)
    log%max_crossings = MAXX
    gate = a_gate()
    if (self%sections .and. mod(k, 2) == 0) then
      call propagate(ig, x, self%tend(k), stat, event=plane_t(k=2, c=merge(-100.0_wp, 9.0_wp, k == 10), terminal=mod(k, 3) == 0), &
                     crossings=log, observer=gate)
    else if (self%sections) then
      call propagate(ig, x, self%tend(k), stat, event=plane_t(k=2, c=merge(-100.0_wp, 9.0_wp, k == 10), terminal=mod(k, 3) == 0), &
                     crossings=log)
    else
      call propagate(ig, x, self%tend(k), stat)
    end if
    call put(out, k, stat, x, ig%t, log, gate)
  end subroutine traj_item

  !> The gate: the line y = 5 cm passed downwards, its segment x in [6.6, 7] cm (the test's
  !> trajectories cross the line downwards at x = 6.94 (item 2), 6.98 (4), 6.51 then 6.81 (10),
  !> ...: both within the segment and beside it).
  type(gate_t) function a_gate() result(g)
    g%spec%origin = [0.0_wp, 0.0_wp]
    g%spec%normal = [0.0_wp, -1.0_wp]
    g%spec%dist = -5.0_wp
    g%spec%tangent = [1.0_wp, 0.0_wp]
    g%spec%seg_lo = 6.6_wp
    g%spec%seg_hi = 7.0_wp
  end function a_gate

  subroutine traj_start(self, k, lane, stat)
    class(traj_jobs_t), intent(inout) :: self
    integer, intent(in) :: k
    type(lane_t), intent(inout) :: lane
    integer, intent(out) :: stat
    type(taylor_t) :: fresh
    stat = TUBES_OK
    lane%x = self%x0(:, k)
    call lane%ig%init(self%model, 0.0_wp)
    lane%ig%rtol = self%tol
    lane%ig%atol = merge(self%atol, self%tol, self%atol > 0)
    lane%ig%max_steps = fresh%max_steps       ! (a lane's integrator keeps it from its last item)
    if (self%budget > 0 .and. mod(k, 4) == 2) lane%ig%max_steps = self%budget
    lane%tend = self%tend(k)
    if (.not. self%sections) return
    allocate (lane%event, source=plane_t(k=2, c=merge(-100.0_wp, 9.0_wp, k == 10), terminal=mod(k, 3) == 0))
    if (mod(k, 2) == 0) allocate (lane%observer, source=a_gate())
    lane%use_log = .true.
    lane%log%max_crossings = MAXX
  end subroutine traj_start

  subroutine traj_finish(self, k, lane, out)
    class(traj_jobs_t), intent(in) :: self
    integer, intent(in) :: k
    type(lane_t), intent(inout) :: lane
    type(ens_out_t), intent(inout) :: out
    if (allocated(lane%observer)) then
      select type (g => lane%observer)
      type is (gate_t)
        call put(out, k, lane%stat, lane%x, lane%ig%t, lane%log, g)
      end select
    else
      call put(out, k, lane%stat, lane%x, lane%ig%t, lane%log, a_gate())
    end if
  end subroutine traj_finish

  !> Item k's outputs: its status, final state and time, its crossings, and its gate's findings.
  subroutine put(out, k, stat, x, t, log, gate)
    type(ens_out_t), intent(inout) :: out
    integer, intent(in) :: k, stat
    real(wp), intent(in) :: x(4), t
    type(crossing_log_t), intent(in) :: log
    type(gate_t), intent(in) :: gate
    integer :: n
    n = min(log%n, MAXX)
    out%st(k) = stat
    out%r(:, k) = 0
    out%r(1:4, k) = x
    out%r(5, k) = t
    out%r(6, k) = log%n
    out%r(7:6 + n, k) = log%t(1:n)
    out%r(NR - 1, k) = merge(1, 0, gate%passed)
    out%r(NR, k) = gate%outside
  end subroutine put
end module test_lanes_jobs

!> The Taylor method's lanes (src/integrators/tubes_lanes.f90): every item's final state, time,
!> status and section crossings are those of a lone propagate call of the same integrator, bit
!> for bit, whatever lane it falls in and whatever the other items (the items in another order,
!> in chunks over 2 threads through the ensemble layer), and the same as the item run alone
!> (ens_run without lanes); items that end early (a terminal crossing) hand their lane to the next.
!> The same at every width (1, 2, 4, 8 lanes per kernel call, forced through jobs%width), and the
!> processor's width (lane_width) is one of them; and with every build of the lanes' driver that
!> the processor runs (x86-64, x86-64-v3, x86-64-v4: forced through jobs%driver).
program test_lanes
  use tubes_kinds, only: wp
  use tubes_check, only: check_true, check_eq, finish
  use tubes_status, only: TUBES_OK, TUBES_EVENT, TUBES_EMAXSTEPS, TUBES_EINPUT
  use tubes_models, only: make_model, MAX_PARAMS
  use tubes_hamiltonian, only: hamiltonian_t
  use tubes_lanes, only: run_lanes, lane_width, lane_driver, LANES_BASE, LANES_X86_64_V4
  use tubes_ensemble, only: ens_out_t, ens_run
  use test_lanes_jobs, only: traj_jobs_t, NR
  implicit none
  integer, parameter :: N = 11                 ! not a multiple of 2, 4, 8: lanes idle at the end
  integer, parameter :: WIDTHS(4) = [1, 2, 4, 8]
  type(traj_jobs_t) :: a
  type(ens_out_t) :: in_order, reordered, alone, chunked, wide
  real(wp) :: params(MAX_PARAMS)
  integer :: k, perm(N), w, stat, dw
  character(512) :: msg
  params = 0
  params(1:7) = [0.07_wp, 1.017_wp, 15.103_wp, 0.00656_wp, 12.065_wp, 981.0_wp, 0.0_wp]
  call setup(a)
  a%lanes = .true.
  a%width = 4
  call ens_run(a, N, in_order, NR, 0, chunk=N)            ! one run_lanes call, items 1..N
  perm = [(N + 1 - k, k = 1, N)]
  perm(1:2) = perm([2, 1])
  allocate (reordered%r(NR, N), reordered%i(0, N), reordered%st(N))
  reordered%r = 0
  reordered%st = TUBES_OK
  call run_lanes(a, perm, reordered)
  call check_true('lanes: the same numbers in another order of the items', same(in_order, reordered))
  print '(a, i0, a, i0)', '  gates passed: ', nint(sum(in_order%r(NR - 1, :))), ', crossings beside them: ', &
    nint(sum(in_order%r(NR, :)))
  call check_true('lanes: some gates passed, some crossed beside their segment (both paths of gate_t)', &
                  sum(in_order%r(NR - 1, :)) > 0 .and. sum(in_order%r(NR, :)) > 0)
  call ens_run(a, N, chunked, NR, 0, chunk=3, threads=2)
  call check_true('lanes: the same numbers in chunks of 3 over 2 threads', same(in_order, chunked))
  a%lanes = .false.
  call ens_run(a, N, alone, NR, 0)
  call check_true('lanes: each item as a lone propagate, bit for bit', same(in_order, alone))
  call check_true('lanes: terminal items stopped at a crossing', all(in_order%st(3:N:3) == TUBES_EVENT))
  call check_true('lanes: the others ran to their end', &
                  all(pack(in_order%st, [(mod(k, 3) /= 0, k = 1, N)]) == TUBES_OK))
  call check_true('lanes: crossings found', sum(in_order%r(6, :)) > N)
  call lane_driver(-1, dw, stat, msg)         ! the driver run by default (the processor's widest,
  call check_eq('lanes: lane_driver status', stat, TUBES_OK)   ! or TUBES_LANES_DRIVER's)
  write (*, '(a,i0)') 'lanes: the default driver ', dw
  call every_driver_width('', .true.)         ! every driver it runs and every width: the lone
                                             ! propagate's numbers
  a%lanes = .false.                          ! no section: the lanes never copy their coefficients
  a%sections = .false.
  call ens_run(a, N, alone, NR, 0)
  call check_true('lanes: no section, the items ran to their end', all(alone%st == TUBES_OK))
  call every_driver_width('no section, ', .false.)
  ! rtol 1e-12, atol 1e-11: a lane is relative (order 15) while |x|_inf > 10 and absolute (order
  ! 14) otherwise, so the lanes split into two kernel calls of two orders; and every fourth item
  ! runs out of steps (TUBES_EMAXSTEPS): the lanes' own steps of a group and their budget's end
  a%atol = 1.0e-11_wp
  a%budget = 40
  a%lanes = .false.
  call ens_run(a, N, alone, NR, 0)
  call check_true('lanes: mixed orders, a step budget: some items out of steps', &
                  count(alone%st == TUBES_EMAXSTEPS) == 3)   ! items 2, 6, 10
  call check_true('lanes: mixed orders, a step budget: the others ran to their end', &
                  count(alone%st == TUBES_OK) == N - 3)
  call every_driver_width('mixed orders, a step budget, ', .false.)
  a%atol = -1
  a%budget = 0
  a%lanes = .false.
  call ens_run(a, N, alone, NR, 0)
  a%lanes = .true.
  a%width = 0                                ! the processor's width (TUBES_LANES unset, or forced)
  call ens_run(a, N, wide, NR, 0, chunk=N)
  call check_true('lanes: the processor''s width, bit for bit', same(wide, alone))
  call lane_width(w, stat, msg)
  call check_eq('lanes: lane_width status', stat, TUBES_OK)
  call check_true('lanes: lane_width is 1, 2, 4 or 8', any(w == WIDTHS))
  write (*, '(a,i0)') 'lanes: this processor''s width ', w
  call lane_driver(LANES_X86_64_V4, dw, stat, msg)
  if (stat /= TUBES_OK) then                 ! a build the processor lacks: every item TUBES_EINPUT
    a%driver = LANES_X86_64_V4
    call ens_run(a, N, wide, NR, 0, chunk=N)
    call check_true('lanes: a driver the processor cannot run: every item refused', all(wide%st == TUBES_EINPUT))
    a%driver = -1
  end if
  call finish('test_lanes')
contains
  !> Items 1..N in lanes with every build of the driver this processor runs and every width, in
  !> one chunk (and with threads in chunks of 5 over 2 threads): alone's numbers.
  subroutine every_driver_width(what, threads)
    character(*), intent(in) :: what
    logical, intent(in) :: threads
    integer :: d, k, dd, st
    character(160) :: name
    character(512) :: why
    do d = LANES_BASE, LANES_X86_64_V4
      call lane_driver(d, dd, st, why)
      if (st /= TUBES_OK) cycle
      a%driver = d
      do k = 1, size(WIDTHS)
        a%lanes = .true.
        a%width = WIDTHS(k)
        call ens_run(a, N, wide, NR, 0, chunk=N)
        write (name, '(3a,i0,a,i0,a)') 'lanes: ', what, 'driver ', d, ', width ', WIDTHS(k), &
          ', each item as a lone propagate, bit for bit'
        call check_true(trim(name), same(wide, alone))
        if (.not. threads) cycle
        call ens_run(a, N, wide, NR, 0, chunk=5, threads=2)
        write (name, '(3a,i0,a,i0,a)') 'lanes: ', what, 'driver ', d, ', width ', WIDTHS(k), &
          ' in chunks of 5 over 2 threads, bit for bit'
        call check_true(trim(name), same(wide, alone))
      end do
    end do
    a%driver = -1
  end subroutine every_driver_width

  logical function same(u, v)
    type(ens_out_t), intent(in) :: u, v
    same = all(u%r == v%r) .and. all(u%st == v%st)
  end function same

  subroutine setup(j)
    type(traj_jobs_t), intent(inout) :: j
    integer :: i, stat
    call make_model('rolling_ball', params, j%model, stat)
    call check_eq('lanes: the model', stat, TUBES_OK)
    allocate (j%x0(4, N), j%tend(N))
    do i = 1, N                                ! releases at rest at various heights, various spans
      j%x0(:, i) = [4.0_wp + 0.3_wp*i, 12.6_wp - 0.3_wp*i, 0.0_wp, 0.0_wp]
      j%tend(i) = 0.5_wp + 0.37_wp*i
    end do
  end subroutine setup
end program test_lanes
