!> Gauss-Legendre implicit Runge-Kutta methods: collocation at the s Gauss nodes of [0, 1],
!> order 2s (s = 2, 3, 4: "gauss4", "gauss6", "gauss8"). They are symplectic and symmetric for
!> any Hamiltonian, separable or not (the rolling ball is not), so the energy error stays
!> bounded over long times, and they conserve quadratic invariants exactly.
!> Fixed step ig%h; the stage equations are solved by simplified Newton (LAPACK LU of
!> I - h A (x) J, J at the step start) or by fixed-point iteration, from a guess extrapolated
!> from the previous step's collocation polynomial. Dense output is that polynomial (degree s).
!> Notes and measured numbers: docs/integrators-gauss.md.
module tubes_gauss
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
  use tubes_kinds, only: wp, i8
  use tubes_lapack, only: dgesv, dgetrf, dgetrs
  use tubes_integrator, only: integrator_t
  use tubes_status, only: TUBES_OK, TUBES_EINPUT, TUBES_EMODEL, TUBES_ENOCONV
  implicit none
  private

  public :: gauss_tableau, collocation_tableau

  integer, parameter :: MIN_STAGES = 2, MAX_STAGES = 4
  integer, parameter :: NEWTON_MAX_ITER = 10        !! default max_iter for 'newton'
  integer, parameter :: FIXED_POINT_MAX_ITER = 100  !! default max_iter for 'fixed_point'
  !> The extrapolated guess is used only if the new step is at most this many times the last
  !> one: further out the previous polynomial is a worse guess than zero (e.g. after the
  !> sliver step that lands on tmax).
  real(wp), parameter :: MAX_EXTRAP_RATIO = 4.0_wp


  !> Gauss-Legendre collocation with s stages, fixed step h (> 0) taken from integrator_t.
  type, extends(integrator_t), public :: gauss_t
    integer :: stages = 2                       !! s = 2, 3 or 4: order 2s
    character(len=12) :: solver = 'newton'      !! 'newton' (simplified) or 'fixed_point'
    integer :: max_iter = 0                     !! iterations per step; 0: the solver's default,
                                                !!   10 (newton) or 100 (fixed_point)
    real(wp) :: newton_tol = 10*epsilon(1.0_wp) !! both solvers: converged when the max-norm of
                                                !!   the stage increment is <= newton_tol times
                                                !!   max|x, stage values| (+ tiny) [1]
    logical :: extrapolate = .true.             !! start the stage iteration from the previous
                                                !!   step's collocation polynomial (else zero)
    integer(i8) :: njac = 0                     !! Jacobian evaluations (newton: one per step);
                                                !!   zeroed with the others by init (at the
                                                !!   first step, when nfev = niter = nsteps = 0)
    real(wp), allocatable, private :: a(:, :)   !! Runge-Kutta matrix (s, s)
    real(wp), allocatable, private :: b(:)      !! weights (s)
    real(wp), allocatable, private :: c(:)      !! nodes (s)
    real(wp), allocatable, private :: q(:, :)   !! q_j(theta) = sum_k q(j, k) theta^k, the
                                                !!   integrated Lagrange basis on the nodes (s, s)
    real(wp), allocatable, private :: x_old(:)  !! state at t_old
    real(wp), allocatable, private :: x_new(:)  !! state at t
    real(wp), allocatable, private :: fs(:, :)  !! f at the stages of the last accepted step (n, s)
    real(wp), allocatable, private :: z(:, :), dz(:, :), fz(:, :)   !! iteration work (n, s)
    real(wp), allocatable, private :: jac(:, :), m(:, :)            !! Jacobian, iteration matrix
    integer, allocatable, private :: ipiv(:)
    real(wp), private :: h_used = 0             !! signed size of the last accepted step [s]
    real(wp), private :: t_comp = 0             !! compensated summation of t: lost low part [s]
    real(wp), private :: t_mark = 0             !! t as last set here (t_comp is void otherwise) [s]
    integer, private :: s_tab = 0               !! stage count the tableau was built for
    logical, private :: have_prev = .false.     !! fs, x_new and h_used hold an accepted step
  contains
    procedure :: step => gauss_step
    procedure :: interp => gauss_interp
  end type gauss_t

contains

  !> Gauss-Legendre tableau with s = 2, 3 or 4 stages. Closed forms for s = 2, 3; for s = 4
  !> closed-form nodes and weights, and a_ij = int_0^c_i l_j (the collocation conditions)
  !> by Gauss quadrature. stat: TUBES_EINPUT for another s or arrays of the wrong size.
  subroutine gauss_tableau(s, a, b, c, stat)
    integer, intent(in) :: s            !! number of stages
    real(wp), intent(out) :: a(:, :)    !! Runge-Kutta matrix (s, s)
    real(wp), intent(out) :: b(:)       !! weights (s)
    real(wp), intent(out) :: c(:)       !! nodes in (0, 1), ascending (s)
    integer, intent(out) :: stat
    real(wp), parameter :: R3 = sqrt(3.0_wp), R15 = sqrt(15.0_wp), R30 = sqrt(30.0_wp)
    real(wp) :: u2, w
    integer :: i, j, k
    stat = TUBES_EINPUT
    if (size(a, 1) /= s .or. size(a, 2) /= s .or. size(b) /= s .or. size(c) /= s) return
    stat = TUBES_OK
    select case (s)
    case (2)
      c = [0.5_wp - R3/6, 0.5_wp + R3/6]
      b = [0.5_wp, 0.5_wp]
      a(1, :) = [0.25_wp, 0.25_wp - R3/6]
      a(2, :) = [0.25_wp + R3/6, 0.25_wp]
    case (3)
      c = [0.5_wp - R15/10, 0.5_wp, 0.5_wp + R15/10]
      b = [5.0_wp/18, 4.0_wp/9, 5.0_wp/18]
      a(1, :) = [5.0_wp/36, 2.0_wp/9 - R15/15, 5.0_wp/36 - R15/30]
      a(2, :) = [5.0_wp/36 + R15/24, 2.0_wp/9, 5.0_wp/36 - R15/24]
      a(3, :) = [5.0_wp/36 + R15/30, 2.0_wp/9 + R15/15, 5.0_wp/36]
    case (4)
      ! Legendre P4 roots on [-1, 1]: u^2 = 3/7 -+ (2/7) sqrt(6/5); node (1 -+ u)/2. The
      ! small nodes are written (1 - u^2)/(2 (1 + u)) to avoid the cancellation in 1 - u.
      do i = 1, 2
        u2 = 3.0_wp/7 + (3 - 2*i)*(2.0_wp/7)*sqrt(6.0_wp/5)   ! i = 1: outer, i = 2: inner
        w = sqrt(u2)
        c(i) = (1 - u2)/(2*(1 + w))
        c(5 - i) = (1 + w)/2
      end do
      ! Gauss weights (18 -+ sqrt 30)/36 on [-1, 1], halved: outer nodes carry the minus sign
      b = [18 - R30, 18 + R30, 18 + R30, 18 - R30]/72
      ! a_ij = int_0^c_i l_j by this same 4-point Gauss rule mapped to [0, c_i] (exact: l_j
      ! has degree 3), with l_j in product form: a few ulps, against ~cond(V) ulps from the
      ! Vandermonde solve of collocation_tableau (which the tests compare with it)
      do j = 1, 4
        do i = 1, 4
          a(i, j) = c(i)*sum([(b(k)*lagrange(c, j, c(i)*c(k)), k = 1, 4)])
        end do
      end do
    case default
      stat = TUBES_EINPUT
    end select
  end subroutine gauss_tableau

  !> Collocation Runge-Kutta tableau for any distinct nodes c: a_ij = int_0^c_i l_j,
  !> b_j = int_0^1 l_j with l_j the Lagrange basis on c, i.e. the solution of
  !> sum_j a_ij c_j^(k-1) = c_i^k/k and sum_j b_j c_j^(k-1) = 1/k, k = 1..s (LAPACK dgesv).
  subroutine collocation_tableau(c, a, b, stat)
    real(wp), intent(in) :: c(:)       !! nodes (s)
    real(wp), intent(out) :: a(:, :)   !! Runge-Kutta matrix (s, s)
    real(wp), intent(out) :: b(:)      !! weights (s)
    integer, intent(out) :: stat       !! TUBES_EINPUT: wrong sizes; TUBES_ENOCONV: repeated nodes
    real(wp) :: q(size(c), size(c))
    integer :: i, j
    stat = TUBES_EINPUT
    if (size(a, 1) /= size(c) .or. size(a, 2) /= size(c) .or. size(b) /= size(c)) return
    call collocation_dense(c, q, stat)
    if (stat /= TUBES_OK) return
    do j = 1, size(c)
      do i = 1, size(c)
        a(i, j) = poly_eval(q(j, :), c(i))
      end do
      b(j) = sum(q(j, :))
    end do
  end subroutine collocation_tableau

  !> Integrated Lagrange basis on the nodes c: q_j(theta) = int_0^theta l_j = sum_k q(j, k)
  !> theta^k, k = 1..s. The collocation polynomial of a step of size h from x0 with stage
  !> derivatives F_j is u(theta) = x0 + h sum_j F_j q_j(theta).
  subroutine collocation_dense(c, q, stat)
    real(wp), intent(in) :: c(:)                    !! nodes (s)
    real(wp), intent(out) :: q(size(c), size(c))    !! monomial coefficients (basis j, power k)
    integer, intent(out) :: stat                    !! TUBES_ENOCONV: singular (repeated nodes)
    real(wp) :: v(size(c), size(c)), rhs(size(c), size(c))
    integer :: ipiv(size(c)), info, i, k, s
    s = size(c)
    ! l_j(tau) = sum_k L(j, k) tau^(k-1) with l_j(c_i) = delta_ij: V L^T = I, V(i, k) = c_i^(k-1)
    do k = 1, s
      v(:, k) = c**(k - 1)
    end do
    rhs = 0
    do i = 1, s
      rhs(i, i) = 1
    end do
    call dgesv(s, s, v, s, ipiv, rhs, s, info)   ! rhs <- L^T
    if (info /= 0) then
      q = 0
      stat = TUBES_ENOCONV
      return
    end if
    do k = 1, s
      q(:, k) = rhs(k, :)/k
    end do
    stat = TUBES_OK
  end subroutine collocation_dense

  !> Lagrange basis polynomial l_j(tau) on the nodes c (l_j(c_i) = delta_ij), product form.
  pure real(wp) function lagrange(c, j, tau) result(y)
    real(wp), intent(in) :: c(:), tau
    integer, intent(in) :: j
    integer :: k
    y = 1
    do k = 1, size(c)
      if (k /= j) y = y*(tau - c(k))/(c(j) - c(k))
    end do
  end function lagrange

  !> sum_k p(k) theta^k, k = 1..size(p) (no constant term), by Horner.
  pure real(wp) function poly_eval(p, theta) result(y)
    real(wp), intent(in) :: p(:), theta
    integer :: k
    y = 0
    do k = size(p), 1, -1
      y = (y + p(k))*theta
    end do
  end function poly_eval

  !> Values q_j(theta), j = 1..s, of the integrated Lagrange basis.
  pure function basis(q, theta) result(y)
    real(wp), intent(in) :: q(:, :), theta
    real(wp) :: y(size(q, 1))
    integer :: j
    do j = 1, size(q, 1)
      y(j) = poly_eval(q(j, :), theta)
    end do
  end function basis

  !> Check the settings, build the tableau and the work arrays when needed.
  subroutine setup(self, n, stat)
    class(gauss_t), intent(inout) :: self
    integer, intent(in) :: n
    integer, intent(out) :: stat
    integer :: s
    s = self%stages
    stat = TUBES_EINPUT
    if (s < MIN_STAGES .or. s > MAX_STAGES) return
    if (.not. (self%h > 0 .and. self%h <= huge(1.0_wp))) return
    if (.not. (self%newton_tol > 0)) return
    if (self%max_iter < 0) return
    if (n /= self%f%dim()) return
    select case (trim(adjustl(self%solver)))
    case ('newton', 'fixed_point')
    case default
      return
    end select
    if (self%s_tab /= s) then
      if (allocated(self%a)) deallocate (self%a, self%b, self%c, self%q)
      allocate (self%a(s, s), self%b(s), self%c(s), self%q(s, s))
      call gauss_tableau(s, self%a, self%b, self%c, stat)
      if (stat == TUBES_OK) call collocation_dense(self%c, self%q, stat)
      if (stat /= TUBES_OK) then
        self%s_tab = 0
        return
      end if
      self%s_tab = s
      self%have_prev = .false.
    end if
    if (allocated(self%z)) then
      if (size(self%z, 1) /= n .or. size(self%z, 2) /= s) then
        deallocate (self%z, self%dz, self%fz, self%fs, self%x_old, self%x_new, self%jac, self%m, &
                    self%ipiv)
        self%have_prev = .false.
        self%h_used = 0   ! the dense output of the last step is gone
      end if
    end if
    if (.not. allocated(self%z)) then
      allocate (self%z(n, s), self%dz(n, s), self%fz(n, s), self%fs(n, s), self%x_old(n), &
                self%x_new(n), self%jac(n, n), self%m(n*s, n*s), self%ipiv(n*s))
      self%have_prev = .false.
    end if
    stat = TUBES_OK
  end subroutine setup

  !> One step of the fixed size ig%h towards tmax (the last one shortened to land on tmax).
  !> stat: TUBES_EINPUT (bad settings: stages, solver, h <= 0, newton_tol <= 0, tmax = t),
  !> TUBES_EMODEL (the model failed at a stage or in its Jacobian), TUBES_ENOCONV (the stage
  !> iteration did not converge in max_iter iterations, diverged, or the Newton matrix is
  !> singular). On failure t, x and the dense output stay at the last accepted step.
  subroutine gauss_step(self, x, tmax, stat)
    class(gauss_t), intent(inout) :: self
    real(wp), intent(inout) :: x(:)
    real(wp), intent(in) :: tmax
    integer, intent(out) :: stat
    real(wp) :: dir, h, hs, err, err_min, thr, ratio, w(MAX_STAGES), w1(MAX_STAGES), dt, tn
    integer :: n, s, i, j, it, maxit, fstat, info
    logical :: last, newton, converged
    n = size(x)
    call setup(self, n, stat)
    if (stat /= TUBES_OK) return
    if (.not. (tmax /= self%t)) then
      stat = TUBES_EINPUT
      return
    end if
    s = self%stages
    newton = trim(adjustl(self%solver)) == 'newton'
    maxit = self%max_iter
    if (maxit == 0) maxit = merge(NEWTON_MAX_ITER, FIXED_POINT_MAX_ITER, newton)
    if (self%nfev == 0 .and. self%niter == 0 .and. self%nsteps == 0) self%njac = 0   ! after init
    if (self%fresh) then
      self%have_prev = .false.
      self%fresh = .false.
    end if
    ! the previous polynomial continues this step only if x is where that step ended
    if (self%have_prev) self%have_prev = all(x == self%x_new)

    if (self%t /= self%t_mark) self%t_comp = 0   ! t was set from outside (init, event)
    dir = sign(1.0_wp, tmax - self%t)
    h = self%h
    ! absorb roundoff drift of t: of h itself (as tubes_dop853), and of the rounded t, which
    ! compensated summation keeps within ~1 ulp of t + m h, with h itself rounded to ulp(h)/2
    ! (m h ulp(h)/2 <~ ulp(tmax - t)): a remainder within 4 ulps of max(|t|, |tmax|) is
    ! absorbed instead of becoming a sliver step
    last = h*(1 + 64*epsilon(1.0_wp)) + 4*spacing(max(abs(self%t), abs(tmax))) &
           >= abs(tmax - self%t)
    if (last) h = abs(tmax - self%t)
    hs = dir*h

    ! initial guess for the stage increments Z_i = X_i - x
    self%z = 0
    if (self%extrapolate .and. self%have_prev) then
      ratio = hs/self%h_used
      if (abs(ratio) <= MAX_EXTRAP_RATIO) then
        ! u_prev(1 + c_i ratio) - u_prev(1), u_prev(theta) = x_old + h_used sum_j F_j q_j(theta)
        w1(1:s) = basis(self%q, 1.0_wp)
        do i = 1, s
          w(1:s) = basis(self%q, 1 + self%c(i)*ratio) - w1(1:s)
          do j = 1, s
            self%z(:, i) = self%z(:, i) + (self%h_used*w(j))*self%fs(:, j)
          end do
        end do
      end if
    end if

    if (newton) then
      call self%f%jacobian(self%t, x, self%jac, fstat)
      self%njac = self%njac + 1
      if (fstat /= 0) then
        stat = TUBES_EMODEL
        return
      end if
      ! M = I - hs (A (x) J); unknowns ordered stage by stage: (i - 1) n + 1 .. i n
      do j = 1, s
        do i = 1, s
          self%m((i - 1)*n + 1:i*n, (j - 1)*n + 1:j*n) = -hs*self%a(i, j)*self%jac
        end do
      end do
      do i = 1, n*s
        self%m(i, i) = self%m(i, i) + 1
      end do
      call dgetrf(n*s, n*s, self%m, n*s, self%ipiv, info)
      if (info /= 0) then
        stat = TUBES_ENOCONV
        return
      end if
    end if

    converged = .false.
    err_min = huge(1.0_wp)
    do it = 1, maxit
      do i = 1, s
        call self%f%eval(self%t + self%c(i)*hs, x + self%z(:, i), self%fz(:, i), fstat)
        self%nfev = self%nfev + 1
        if (fstat /= 0) then
          stat = TUBES_EMODEL
          return
        end if
      end do
      ! residual of Z = hs A F(Z); fixed point: Z <- hs A F; Newton: Z <- Z + M^-1 residual
      self%dz = hs*matmul(self%fz, transpose(self%a)) - self%z
      if (newton) then
        call dgetrs('N', n*s, 1, self%m, n*s, self%ipiv, self%dz, n*s, info)
      end if
      self%z = self%z + self%dz
      self%niter = self%niter + 1
      err = maxval(abs(self%dz))
      thr = self%newton_tol*max(maxval(abs(x)), maxval(abs(self%z + spread(x, 2, s)))) &
            + tiny(1.0_wp)
      if (err <= thr) then
        converged = .true.
        exit
      end if
      ! diverging: NaN/Inf, or an increment 1000x the smallest one so far. A geometric
      ! divergence gets there in a few iterations, long before it overflows in the model
      ! (which would report TUBES_EMODEL); a convergent, non-monotone iteration does not.
      if (.not. (err <= huge(1.0_wp))) exit
      if (err/1000 > err_min) exit
      err_min = min(err_min, err)
    end do
    if (.not. converged) then
      stat = TUBES_ENOCONV
      return
    end if

    ! accept: x_new = x + hs sum_i b_i F_i, with the F of the last iterate (within newton_tol)
    self%x_old = x
    self%fs = self%fz
    self%x_new = x + hs*matmul(self%fz, self%b)
    self%t_old = self%t
    if (last) then
      self%t = tmax
      self%t_comp = 0
    else   ! Kahan: t + hs with the low part lost so far
      dt = hs - self%t_comp
      tn = self%t + dt
      self%t_comp = (tn - self%t) - dt
      self%t = tn
    end if
    self%t_mark = self%t
    self%h_used = hs
    self%have_prev = .true.
    x = self%x_new
    self%nsteps = self%nsteps + 1
  end subroutine gauss_step

  !> Dense output: the collocation polynomial of the last step (degree s; through x_old, the
  !> stage values and x_new), u(theta) = x_old + h sum_j F_j q_j(theta), theta = (s - t_old)/h.
  !> NaN before the first accepted step.
  subroutine gauss_interp(self, s, xs)
    class(gauss_t), intent(inout) :: self
    real(wp), intent(in) :: s
    real(wp), intent(out) :: xs(:)
    real(wp) :: w(MAX_STAGES)
    integer :: j
    if (self%h_used == 0 .or. .not. allocated(self%fs)) then
      xs = ieee_value(1.0_wp, ieee_quiet_nan)
      return
    end if
    w(1:size(self%q, 1)) = basis(self%q, (s - self%t_old)/self%h_used)
    xs = self%x_old
    do j = 1, size(self%q, 1)
      xs = xs + (self%h_used*w(j))*self%fs(:, j)
    end do
  end subroutine gauss_interp
end module tubes_gauss
