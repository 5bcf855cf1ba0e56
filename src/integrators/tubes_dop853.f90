!> DOP853: Hairer's explicit Runge-Kutta 8(5,3) with step-size control and 7th-order dense
!> output. With h > 0 it takes fixed steps of h without error control (used to measure order).
module tubes_dop853
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
  use tubes_kinds, only: wp, i8
  use tubes_integrator, only: integrator_t, start_step
  use tubes_status, only: TUBES_OK, TUBES_EINPUT, TUBES_ESTEP, TUBES_EMODEL
  use tubes_dop853_tableau, only: NS, NSX, C, tableau_a, tableau_e3, tableau_e5, tableau_d
  implicit none
  private

  real(wp), parameter :: SAFETY = 0.9_wp, FAC_MIN = 0.333_wp, FAC_MAX = 6.0_wp

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
    real(wp) :: dir, h, hmin, err, err3, err5, den, fac, xnew(size(x)), sk, xs(size(x)), e3, e5
    integer :: i, j, n, r, fs
    logical :: last, reject_prev
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
      h = self%h
    else if (self%h_next > 0) then
      h = self%h_next
    else
      call start_step(self%f, self%t, x, self%f_cur, dir, self%rtol, self%atol, 7, h, self%nfev)
    end if
    reject_prev = .false.
    self%k(:, 1) = self%f_cur
    self%dense_ready = .false.
    do
      hmin = max(16*epsilon(1.0_wp)*max(abs(self%t), abs(tmax)), tiny(1.0_wp))   ! never subnormal
      if (self%h > 0) then
        ! fixed step: end on the grid t_grid0 + k h (no drift of t), the last step on tmax
        h = abs(self%t_grid0 + dir*(self%k_grid + 1)*self%h - self%t)
        last = h*(1 + 64*epsilon(1.0_wp)) >= abs(tmax - self%t)
      else
        last = h*(1 + 64*epsilon(1.0_wp)) >= abs(tmax - self%t)   ! absorb roundoff drift of t
      end if
      if (last) h = abs(tmax - self%t)
      if (h < hmin .and. .not. last) then
        stat = TUBES_ESTEP
        return
      end if
      ! stages 2..12 and the 8th-order solution
      do i = 2, NS
        call combine(x, self%k, self%at(:, i), i - 1, dir*h, xs)
        call self%f%eval(self%t + dir*C(i)*h, xs, self%k(:, i), fs)
        if (fs /= 0) exit
      end do
      self%nfev = self%nfev + (i - 2 + merge(0, 1, fs == 0))   ! stages 2..i-1, and i if it failed
      if (fs == 0) then
        call combine(x, self%k, self%at(:, NS + 1), NS, dir*h, xnew)
        call self%f%eval(self%t + dir*h, xnew, self%k(:, NS + 1), fs)
        self%nfev = self%nfev + 1
      end if
      if (fs < 0) then
        stat = TUBES_EMODEL
        return
      end if
      if (fs > 0 .and. self%h > 0) then   ! fixed step cannot honour a request to shrink
        stat = TUBES_ESTEP
        return
      end if
      if (fs > 0) then            ! the model asks for a smaller step
        h = h/4
        self%nrejected = self%nrejected + 1
        reject_prev = .true.
        cycle
      end if
      if (self%h > 0) exit        ! fixed step: no error control
      err5 = 0          ! the error estimates, component by component
      err3 = 0
      do r = 1, n
        sk = self%atol + self%rtol*max(abs(x(r)), abs(xnew(r)))
        e5 = 0
        e3 = 0
        do j = 1, size(self%i5)         ! the non-zero weights, in order
          e5 = e5 + self%e5(self%i5(j))*self%k(r, self%i5(j))
        end do
        do j = 1, size(self%i3)
          e3 = e3 + self%e3(self%i3(j))*self%k(r, self%i3(j))
        end do
        e5 = e5/sk
        e3 = e3/sk
        err5 = err5 + e5**2
        err3 = err3 + e3**2
      end do
      den = err5 + 0.01_wp*err3
      if (den > 0) then
        err = h*err5/sqrt(den*n)
      else
        err = 0
      end if
      if (.not. (err <= huge(1.0_wp))) then   ! NaN in the estimate
        stat = TUBES_EMODEL
        return
      end if
      if (err <= 1) then
        fac = min(FAC_MAX, max(FAC_MIN, SAFETY*err**(-1.0_wp/8)))
        if (err == 0) fac = FAC_MAX
        if (reject_prev) fac = min(1.0_wp, fac)
        self%h_next = h*fac
        exit
      end if
      self%nrejected = self%nrejected + 1
      reject_prev = .true.
      h = h*max(FAC_MIN, SAFETY*err**(-1.0_wp/8))
    end do
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

  !> y = x + h sum_{j <= m} w_j k(:, j): a stage, without temporaries. Four components at a
  !> time in independent chains (the adds' latency hidden); each sum in the order of j.
  pure subroutine combine(x, k, w, m, h, y)
    real(wp), intent(in) :: x(:), k(:, :), w(:)
    real(wp), intent(in) :: h
    integer, intent(in) :: m
    real(wp), intent(out) :: y(:)
    real(wp) :: a1, a2, a3, a4, acc1
    integer :: i, j, n4
    n4 = size(x) - mod(size(x), 4)
    do i = 1, n4, 4
      a1 = 0
      a2 = 0
      a3 = 0
      a4 = 0
      do j = 1, m
        a1 = a1 + w(j)*k(i, j)
        a2 = a2 + w(j)*k(i + 1, j)
        a3 = a3 + w(j)*k(i + 2, j)
        a4 = a4 + w(j)*k(i + 3, j)
      end do
      y(i) = x(i) + h*a1
      y(i + 1) = x(i + 1) + h*a2
      y(i + 2) = x(i + 2) + h*a3
      y(i + 3) = x(i + 3) + h*a4
    end do
    do i = n4 + 1, size(x)
      acc1 = 0
      do j = 1, m
        acc1 = acc1 + w(j)*k(i, j)
      end do
      y(i) = x(i) + h*acc1
    end do
  end subroutine combine

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
