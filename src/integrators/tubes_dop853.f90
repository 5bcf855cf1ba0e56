!> DOP853: Hairer's explicit Runge-Kutta 8(5,3) with step-size control and 7th-order dense
!> output. With h > 0 it takes fixed steps of h without error control (used to measure order).
module tubes_dop853
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
  use tubes_kinds, only: wp, i8
  use tubes_integrator, only: integrator_t, start_step
  use tubes_status, only: TUBES_OK, TUBES_EINPUT, TUBES_ESTEP, TUBES_EMODEL
  use tubes_dop853_tableau, only: NS, NSX, C, tableau_a, tableau_e3, tableau_e5, tableau_d, &
                                  DOP853_SAFETY, DOP853_FAC_MIN, DOP853_FAC_MAX
  use tubes_field, only: field_rk => vector_field_t
  implicit none
  private

  integer, parameter :: rk = wp   ! the kind of the kind-generic source included below

  type, extends(integrator_t), public :: dop853_t
    real(wp), allocatable :: k(:, :)      !! stages of the last accepted step (n, NSX)
    real(wp), allocatable :: f_cur(:)     !! f(t, x) at the current point (FSAL)
    real(wp), allocatable :: x_old(:)     !! state at t_old
    real(wp), allocatable :: x_new(:)     !! state at t
    real(wp), allocatable :: dense(:, :)  !! interpolant coefficients (n, 7)
    real(wp), allocatable :: a(:, :)      !! Runge-Kutta matrix (NSX, NSX)
    real(wp), allocatable :: at(:, :)     !! its transpose: row i of a is the contiguous at(:, i)
    real(wp), allocatable :: e3(:), e5(:), d(:, :)
    integer, allocatable :: i3(:), i5(:)  !! the stages with non-zero e3, e5 weights
    real(wp) :: h_used = 0                !! size of the last accepted step [s]
    real(wp) :: t_grid0 = 0               !! fixed-step mode: steps end on t_grid0 + k h
    integer(i8) :: k_grid = 0             !! fixed-step mode: steps taken since t_grid0
    logical :: dense_ready = .false.
  contains
    procedure :: step => dop853_step
    procedure :: interp => dop853_interp
  end type dop853_t

contains

  subroutine setup(self, n, x, stat)
    class(dop853_t), intent(inout) :: self
    integer, intent(in) :: n
    real(wp), intent(in) :: x(:)
    integer, intent(out) :: stat
    integer :: i
    if (.not. allocated(self%a)) then
      allocate (self%a(NSX, NSX), self%at(NSX, NSX), self%e3(NS + 1), self%e5(NS + 1), self%d(4, NSX))
      self%a = tableau_a()
      self%at = transpose(self%a)
      self%e3 = tableau_e3()
      self%e5 = tableau_e5()
      self%d = tableau_d()
      self%i3 = pack([(i, i = 1, NS + 1)], self%e3 /= 0)
      self%i5 = pack([(i, i = 1, NS + 1)], self%e5 /= 0)
    end if
    if (allocated(self%k)) then
      if (size(self%k, 1) /= n) deallocate (self%k, self%f_cur, self%x_old, self%x_new, self%dense)
    end if
    if (.not. allocated(self%k)) allocate (self%k(n, NSX), self%f_cur(n), self%x_old(n), &
                                           self%x_new(n), self%dense(n, 7))
    call self%f%eval(self%t, x, self%f_cur, stat)
    self%nfev = self%nfev + 1
    if (stat /= 0) stat = TUBES_EMODEL
    self%fresh = .false.
  end subroutine setup

  subroutine dop853_step(self, x, tmax, stat)
    class(dop853_t), intent(inout) :: self
    real(wp), intent(inout) :: x(:)
    real(wp), intent(in) :: tmax
    integer, intent(out) :: stat
    real(wp) :: dir, h, h_next, xnew(size(x))
    integer :: n
    logical :: last
    n = size(x)
    stat = TUBES_OK
    if (self%fresh .or. .not. allocated(self%k)) then
      call setup(self, n, x, stat)
      if (stat /= TUBES_OK) return
      self%h_next = 0
      self%t_grid0 = self%t
      self%k_grid = 0
    end if
    dir = sign(1.0_wp, tmax - self%t)
    if (tmax == self%t) then
      stat = TUBES_EINPUT
      return
    end if
    if (self%h > 0) then
      ! fixed step: end on the grid t_grid0 + k h (no drift of t), the last step on tmax
      h = abs(self%t_grid0 + dir*(self%k_grid + 1)*self%h - self%t)
    else if (self%h_next > 0) then
      h = self%h_next
    else
      call start_step(self%f, self%t, x, self%f_cur, dir, self%rtol, self%atol, 7, h, self%nfev)
    end if
    self%k(:, 1) = self%f_cur
    self%dense_ready = .false.
    call dop853_attempt(self%f, self%t, tmax, dir, x, self%k, self%at, C, self%e3, self%e5, &
                        self%i3, self%i5, self%rtol, self%atol, self%h > 0, h, last, xnew, &
                        h_next, self%nfev, self%nrejected, stat)
    if (stat /= TUBES_OK) return
    if (.not. self%h > 0) self%h_next = h_next
    self%x_old = x
    self%x_new = xnew
    self%t_old = self%t
    if (last) then
      self%t = tmax
    else if (self%h > 0) then
      self%t = self%t_grid0 + dir*(self%k_grid + 1)*self%h
    else
      self%t = self%t + dir*h
    end if
    self%k_grid = self%k_grid + 1
    self%h_used = dir*h
    x = xnew
    self%f_cur = self%k(:, NS + 1)   ! FSAL: f(t_new, x_new) starts the next step
    self%nsteps = self%nsteps + 1
  end subroutine dop853_step

  include 'tubes_dop853_step.inc'   ! dop853_attempt and combine in real(wp)

  !> 7th-order continuous extension; the 3 extra stages are computed on first use in a step.
  !> Each component's sums run in the tableau's order (the same bits as whole-array matmul).
  subroutine dop853_interp(self, s, xs)
    class(dop853_t), intent(inout) :: self
    real(wp), intent(in) :: s
    real(wp), intent(out) :: xs(:)
    real(wp) :: h, th, th1, dx, y(size(xs)), a1, a2, a3, a4
    integer :: i, j, r, fs
    h = self%h_used
    if (.not. self%dense_ready) then
      do i = NS + 2, NSX
        call combine(self%x_old, self%k, self%at(:, i), i - 1, h, y)
        call self%f%eval(self%t_old + C(i)*h, y, self%k(:, i), fs)
        self%nfev = self%nfev + 1
        if (fs /= 0) then   ! the model refused a dense-output stage: never interpolate silently
          xs = ieee_value(1.0_wp, ieee_quiet_nan)
          return
        end if
      end do
      do r = 1, size(xs)
        dx = self%x_new(r) - self%x_old(r)
        self%dense(r, 1) = dx
        self%dense(r, 2) = h*self%k(r, 1) - dx
        self%dense(r, 3) = 2*dx - h*(self%k(r, NS + 1) + self%k(r, 1))
        a1 = 0
        a2 = 0
        a3 = 0
        a4 = 0
        do j = 1, NSX
          a1 = a1 + self%d(1, j)*self%k(r, j)
          a2 = a2 + self%d(2, j)*self%k(r, j)
          a3 = a3 + self%d(3, j)*self%k(r, j)
          a4 = a4 + self%d(4, j)*self%k(r, j)
        end do
        self%dense(r, 4) = h*a1
        self%dense(r, 5) = h*a2
        self%dense(r, 6) = h*a3
        self%dense(r, 7) = h*a4
      end do
      self%dense_ready = .true.
    end if
    th = (s - self%t_old)/h
    th1 = 1 - th
    do r = 1, size(xs)
      dx = 0          ! Hairer's nesting: th and 1 - th alternate from the inside out
      dx = (dx + self%dense(r, 7))*th
      dx = (dx + self%dense(r, 6))*th1
      dx = (dx + self%dense(r, 5))*th
      dx = (dx + self%dense(r, 4))*th1
      dx = (dx + self%dense(r, 3))*th
      dx = (dx + self%dense(r, 2))*th1
      dx = (dx + self%dense(r, 1))*th
      xs(r) = self%x_old(r) + dx
    end do
  end subroutine dop853_interp
end module tubes_dop853
