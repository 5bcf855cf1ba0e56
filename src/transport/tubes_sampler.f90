!> Observer that samples the dense output on the grid t0 + k dt (k = 0, 1, ...) and, given the
!> integration's end, at the end itself: the grid's points before it (a point within 1e-9 dt of
!> the end is the end's: t_end/dt = 3 need not give 3 dt <= t_end in floating point), then t_end.
module tubes_sampler
  use tubes_kinds, only: wp
  use tubes_integrator, only: integrator_t, observer_t
  implicit none
  private

  type, extends(observer_t), public :: sampler_t
    real(wp) :: t0 = 0                 !! first sample time [s]
    real(wp) :: dt = 1                 !! sample spacing [s] (sign = direction)
    integer :: n = 0                   !! samples taken
    real(wp), allocatable :: t(:)      !! sample times [s]
    real(wp), allocatable :: x(:, :)   !! samples (dim, nmax)
    integer :: count = 0               !! steps seen
    logical :: has_end = .false.       !! the end is sampled
    real(wp) :: t_end = 0              !! the integration's end [s] (has_end)
  contains
    procedure :: on_step => sampler_on_step
    procedure :: start => sampler_start
  end type sampler_t

contains

  !> Reset with room for nmax samples; records the initial state as sample 1. With t_end, the
  !> integration's end is a sample too (the grid's points up to it, then the end).
  subroutine sampler_start(self, t0, dt, x0, nmax, t_end)
    class(sampler_t), intent(inout) :: self
    real(wp), intent(in) :: t0, dt, x0(:)
    integer, intent(in) :: nmax
    real(wp), intent(in), optional :: t_end
    if (allocated(self%t)) deallocate (self%t, self%x)
    allocate (self%t(nmax), self%x(size(x0), nmax))
    self%t0 = t0
    self%dt = dt
    self%n = 1
    self%t(1) = t0
    self%x(:, 1) = x0
    self%count = 0
    self%has_end = present(t_end)
    if (present(t_end)) self%t_end = t_end
  end subroutine sampler_start

  subroutine sampler_on_step(self, ig, t_hi)
    class(sampler_t), intent(inout) :: self
    class(integrator_t), intent(inout) :: ig
    real(wp), intent(in) :: t_hi
    real(wp) :: ts
    do while (self%n < size(self%t))
      ts = self%t0 + self%n*self%dt
      if (self%dt*(ts - t_hi) > 0) exit
      if (self%has_end) then
        if (self%dt*(self%t_end - ts) <= 1.0e-9_wp*abs(self%dt)) exit   ! the end's sample, below
      end if
      self%n = self%n + 1
      self%t(self%n) = ts
      call ig%interp(ts, self%x(:, self%n))
    end do
    if (self%has_end .and. t_hi == self%t_end .and. self%n < size(self%t)) then
      if (self%t(self%n) /= self%t_end) then
        self%n = self%n + 1
        self%t(self%n) = self%t_end
        call ig%interp(self%t_end, self%x(:, self%n))
      end if
    end if
    self%count = self%count + 1
  end subroutine sampler_on_step
end module tubes_sampler
