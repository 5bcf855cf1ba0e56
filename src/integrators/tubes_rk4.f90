!> Classical fourth-order Runge-Kutta with a fixed step and cubic Hermite dense output.
!> The step is ig%h (> 0, required); the last step is shortened to land exactly on tmax.
!> f at the end of a step is the first stage of the next one (FSAL-like reuse), so a step
!> costs 4 evaluations of the model, plus 1 when the stepper (re)starts. Works in either
!> direction; step times lie on the grid t0 + k h (no drift of t, no sliver last step).
!> See docs/integrators-tao.md.
module tubes_rk4
  use tubes_kinds, only: wp, i8
  use tubes_integrator, only: integrator_t, hermite, step_grid_t, stale_state, all_finite
  use tubes_status, only: TUBES_OK, TUBES_EINPUT, TUBES_ESTEP, TUBES_EMODEL
  implicit none
  private

  !> Classical RK4 (Kutta 1901): c = (0, 1/2, 1/2, 1), b = (1, 2, 2, 1)/6.
  type, extends(integrator_t), public :: rk4_t
    real(wp), allocatable :: f_cur(:)   !! f(t, x) at the current point (next step's stage 1)
    real(wp), allocatable :: f_old(:)   !! f at the start of the last accepted step
    real(wp), allocatable :: x_old(:)   !! state at t_old
    real(wp), allocatable :: x_new(:)   !! state at t (the value returned by the last step)
    real(wp) :: h_used = 0              !! signed size of the last accepted step [s]
    type(step_grid_t) :: grid          !! the step grid (tubes_integrator)
  contains
    procedure :: step => rk4_step
    procedure :: interp => rk4_interp
  end type rk4_t

contains

  !> (Re)start: storage for dimension n and f at the current point.
  subroutine setup(self, x, stat)
    class(rk4_t), intent(inout) :: self
    real(wp), intent(in) :: x(:)
    integer, intent(out) :: stat
    integer :: n
    n = size(x)
    if (allocated(self%f_cur)) then
      if (size(self%f_cur) /= n) deallocate (self%f_cur, self%f_old, self%x_old, self%x_new)
    end if
    if (.not. allocated(self%f_cur)) allocate (self%f_cur(n), self%f_old(n), self%x_old(n), &
                                               self%x_new(n))
    call self%f%eval(self%t, x, self%f_cur, stat)
    self%nfev = self%nfev + 1
    if (stat /= 0 .or. .not. all_finite(self%f_cur)) then
      stat = TUBES_EMODEL
      return
    end if
    stat = TUBES_OK
    self%x_new = x
    self%grid%hs = 0
    self%fresh = .false.
  end subroutine setup

  !> One RK4 step of ig%h (the last one shortened to land on tmax), in either direction.
  !> A model that asks for a smaller step (stat > 0) gets h/4 for this step (counted in
  !> nrejected; TUBES_ESTEP below 16 eps |t|); stat < 0, NaN or Inf give TUBES_EMODEL.
  !> On failure t and x stay at the last accepted step.
  subroutine rk4_step(self, x, tmax, stat)
    class(rk4_t), intent(inout) :: self
    real(wp), intent(inout) :: x(:)   !! state at t on entry, at the new t on return
    real(wp), intent(in) :: tmax      !! never step past this time [s]
    integer, intent(out) :: stat
    real(wp) :: dir, h, hs, t, t_full
    real(wp), dimension(size(x)) :: k2, k3, k4, xs, xnew, fnew
    integer :: fs
    logical :: last
    stat = TUBES_OK
    if (.not. (self%h > 0) .or. tmax == self%t) then
      stat = TUBES_EINPUT
      return
    end if
    if (stale_state(self%fresh, self%x_new, x)) then   ! the stored f(t, x) is stale
      call setup(self, x, stat)
      if (stat /= TUBES_OK) return
    end if
    call self%grid%begin(self%t, tmax, self%h, t, dir, h)
    do
      call self%grid%trial(t, tmax, dir, h, t_full, hs, last, stat)
      if (stat /= TUBES_OK) return
      xs = x + (hs/2)*self%f_cur
      call self%f%eval(t + hs/2, xs, k2, fs)
      self%nfev = self%nfev + 1
      if (fs == 0) then
        xs = x + (hs/2)*k2
        call self%f%eval(t + hs/2, xs, k3, fs)
        self%nfev = self%nfev + 1
      end if
      if (fs == 0) then
        xs = x + hs*k3
        call self%f%eval(t + hs, xs, k4, fs)
        self%nfev = self%nfev + 1
      end if
      if (fs == 0) then
        xnew = x + (hs/6)*(self%f_cur + 2*(k2 + k3) + k4)
        ! f at the new point: the Hermite end slope and the next step's first stage
        call self%f%eval(t + hs, xnew, fnew, fs)
        self%nfev = self%nfev + 1
        if (fs == 0 .and. .not. (all_finite(xnew) .and. all_finite(fnew))) fs = -1
      end if
      if (.not. self%grid%retry(fs, h, self%nrejected, stat)) exit   ! fs > 0: h/4, off the grid
    end do
    if (stat /= TUBES_OK) return
    self%x_old = x
    self%f_old = self%f_cur
    self%x_new = xnew
    self%f_cur = fnew
    self%t_old = t
    self%t = self%grid%finish(last, tmax, t_full)
    self%h_used = hs
    x = xnew
    self%nsteps = self%nsteps + 1
  end subroutine rk4_step

  !> Cubic Hermite interpolation from x and f at both ends of the last accepted step:
  !> local error O(h^4), continuous with a continuous derivative across steps.
  subroutine rk4_interp(self, s, xs)
    class(rk4_t), intent(inout) :: self
    real(wp), intent(in) :: s       !! time in [t_old, t] [s]
    real(wp), intent(out) :: xs(:)  !! state at s
    call hermite(self%x_old, self%f_old, self%x_new, self%f_cur, self%t_old, self%h_used, s, xs)
  end subroutine rk4_interp

end module tubes_rk4
