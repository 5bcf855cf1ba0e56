!> Test items for test_lanes: trajectories of the ball from a list of states, each to a time of
!> its own, with a section (non-terminal, logged) and, for every third item, a terminal one.
module test_lanes_jobs
  use tubes_kinds, only: wp
  use tubes_hamiltonian, only: hamiltonian_t
  use tubes_integrator, only: plane_t
  use tubes_lanes, only: lane_t, lane_jobs_t
  use tubes_status, only: TUBES_OK
  implicit none
  private
  public :: traj_jobs_t

  type, extends(lane_jobs_t) :: traj_jobs_t
    class(hamiltonian_t), allocatable :: model
    real(wp), allocatable :: x0(:, :), tend(:)
    real(wp) :: tol = 1.0e-12_wp
    real(wp), allocatable :: x(:, :), t(:), tx(:, :)   !! results: final state and time, crossing times
    integer, allocatable :: stat(:), nx(:)
  contains
    procedure :: start => traj_start
    procedure :: finish => traj_finish
  end type traj_jobs_t

contains

  subroutine traj_start(self, k, lane, stat)
    class(traj_jobs_t), intent(inout) :: self
    integer, intent(in) :: k
    type(lane_t), intent(inout) :: lane
    integer, intent(out) :: stat
    stat = TUBES_OK
    lane%x = self%x0(:, k)
    call lane%ig%init(self%model, 0.0_wp)
    lane%ig%rtol = self%tol
    lane%ig%atol = self%tol
    lane%tend = self%tend(k)
    allocate (lane%event, source=plane_t(k=2, c=9.0_wp, terminal=mod(k, 3) == 0))
    lane%use_log = .true.
    lane%log%max_crossings = 50
  end subroutine traj_start

  subroutine traj_finish(self, k, lane)
    class(traj_jobs_t), intent(inout) :: self
    integer, intent(in) :: k
    type(lane_t), intent(inout) :: lane
    integer :: n
    self%stat(k) = lane%stat
    self%x(:, k) = lane%x
    self%t(k) = lane%ig%t
    n = min(lane%log%n, size(self%tx, 1))
    self%nx(k) = lane%log%n
    self%tx(:, k) = 0
    self%tx(1:n, k) = lane%log%t(1:n)
  end subroutine traj_finish
end module test_lanes_jobs

!> The Taylor method's lanes (src/integrators/tubes_lanes.f90): every item's final state, time,
!> status and section crossings are those of a lone propagate call of the same integrator, bit
!> for bit, whatever lane it falls in and whatever the other items (the items in another order,
!> and a lone item); items that end early (a terminal crossing) hand their lane to the next.
program test_lanes
  use tubes_kinds, only: wp
  use tubes_check, only: check_true, check_eq, finish
  use tubes_status, only: TUBES_OK, TUBES_EVENT
  use tubes_models, only: make_model, MAX_PARAMS
  use tubes_hamiltonian, only: hamiltonian_t
  use tubes_taylor, only: taylor_t
  use tubes_integrator, only: propagate, plane_t, crossing_log_t
  use tubes_lanes, only: run_lanes, LANES
  use test_lanes_jobs, only: traj_jobs_t
  implicit none
  integer, parameter :: N = 11                 ! not a multiple of LANES: a lane idles at the end
  type(traj_jobs_t) :: a, b
  type(taylor_t) :: ig
  type(crossing_log_t) :: log
  real(wp) :: params(MAX_PARAMS), x(4)
  integer :: k, stat, perm(N), nsame
  params = 0
  params(1:7) = [0.07_wp, 1.017_wp, 15.103_wp, 0.00656_wp, 12.065_wp, 981.0_wp, 0.0_wp]
  call setup(a)
  call setup(b)
  call run_lanes(a, [(k, k = 1, N)])
  perm = [(N + 1 - k, k = 1, N)]
  perm(1:2) = perm([2, 1])
  call run_lanes(b, perm)
  nsame = 0
  do k = 1, N
    if (all(a%x(:, k) == b%x(:, k)) .and. a%t(k) == b%t(k) .and. a%stat(k) == b%stat(k) .and. &
        a%nx(k) == b%nx(k) .and. all(a%tx(:, k) == b%tx(:, k))) nsame = nsame + 1
  end do
  call check_eq('lanes: the same numbers in another order of the items', nsame, N)
  nsame = 0
  do k = 1, N                                  ! each item alone, by propagate
    call ig%init(a%model, 0.0_wp)
    ig%rtol = a%tol
    ig%atol = a%tol
    x = a%x0(:, k)
    call log%clear()
    log%max_crossings = 50
    call propagate(ig, x, a%tend(k), stat, event=plane_t(k=2, c=9.0_wp, terminal=mod(k, 3) == 0), crossings=log)
    if (all(x == a%x(:, k)) .and. ig%t == a%t(k) .and. stat == a%stat(k) .and. log%n == a%nx(k)) then
      if (all(log%t(1:min(log%n, 50)) == a%tx(1:min(log%n, 50), k))) nsame = nsame + 1
    end if
  end do
  call check_eq('lanes: each item as a lone propagate, bit for bit', nsame, N)
  call check_true('lanes: terminal items stopped at a crossing', all(a%stat(3:N:3) == TUBES_EVENT))
  call check_true('lanes: the others ran to their end', all(pack(a%stat, [(mod(k, 3) /= 0, k = 1, N)]) == TUBES_OK))
  call check_true('lanes: crossings found', sum(a%nx) > N)
  call check_true('lanes: LANES > 1', LANES > 1)
  call finish('test_lanes')

contains

  subroutine setup(j)
    type(traj_jobs_t), intent(inout) :: j
    integer :: i
    call make_model('rolling_ball', params, j%model, stat)
    allocate (j%x0(4, N), j%tend(N), j%x(4, N), j%t(N), j%tx(50, N), j%stat(N), j%nx(N))
    do i = 1, N                                ! releases at rest at various heights, various spans
      j%x0(:, i) = [4.0_wp + 0.3_wp*i, 12.6_wp - 0.3_wp*i, 0.0_wp, 0.0_wp]
      j%tend(i) = 0.5_wp + 0.37_wp*i
    end do
  end subroutine setup
end program test_lanes
