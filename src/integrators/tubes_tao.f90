!> Tao's explicit symplectic integrators for non-separable Hamiltonians (M. Tao, Phys. Rev. E
!> 94, 043303, 2016), orders 2, 4 and 6, fixed step, cubic Hermite dense output.
!>
!> The state is canonical z = (q, p), dimension 2m, and the model's vector field is
!> f(z) = (dH/dp, -dH/dq) of an autonomous Hamiltonian H. The phase space is doubled with
!> copies (x, y) of (q, p), and the augmented Hamiltonian
!>   Hbar(q, p, x, y) = H(q, y) + H(x, p) + omega (|q - x|^2 + |p - y|^2)/2
!>                    = H_A + H_B + omega H_C
!> is split into three exactly solvable flows, each written with f at a mixed point:
!>   phi_A^d: p <- p + d f_p(q, y),  x <- x + d f_q(q, y)         (H_A = H(q, y))
!>   phi_B^d: q <- q + d f_q(x, p),  y <- y + d f_p(x, p)         (H_B = H(x, p))
!>   phi_C^d: (q - x, p - y) rotated by the angle 2 omega d, (q + x, p + y) kept
!> (Hamilton's equations of omega H_C: d(q - x)/dt = 2 omega (p - y),
!>  d(p - y)/dt = -2 omega (q - x), d(q + x)/dt = d(p + y)/dt = 0.)
!> Order 2 is the symmetric Strang composition A(h/2) B(h/2) C(h) B(h/2) A(h/2); orders 4
!> and 6 are Yoshida's triple jump phi_{l+2}(h) = phi_l(g h) phi_l((1 - 2 g) h) phi_l(g h),
!> g = 1/(2 - 2^(1/(l+1))). Adjacent flows of the same kind are merged (A(a) A(b) = A(a + b)),
!> so a step costs 4 (tao2), 10 (tao4) or 28 (tao6) evaluations of the model.
!> The copies persist between steps; they are reset to (q, p) on a fresh start or when the
!> state was changed from outside. Only (q, p) is returned. H must be autonomous: the model
!> is evaluated at mixed points that belong to no single time (t is passed as the step's
!> start). omega must exceed a model-dependent threshold and 2 omega h should stay below
!> ~1: see docs/integrators-tao.md for both limits and the measurements behind the default.
module tubes_tao
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
  use tubes_kinds, only: wp, i8
  use tubes_field, only: vector_field_t
  use tubes_integrator, only: integrator_t, step_grid_t, stale_state, hermite, all_finite
  use tubes_status, only: TUBES_OK, TUBES_EINPUT, TUBES_ESTEP
  implicit none
  private

  integer, parameter :: FLOW_A = 1, FLOW_B = 2, FLOW_C = 3
  integer, parameter :: MAXFLOW = 64   ! tao6 needs 37 flows after merging

  !> Default binding constant omega [1/s], measured on the rolling ball (docs/integrators-tao.md).
  real(wp), parameter, public :: TAO_OMEGA_DEFAULT = 200.0_wp

  !> Tao's augmented-Hamiltonian splitting method.
  type, extends(integrator_t), public :: tao_t
    integer :: order = 2                          !! 2, 4 or 6 ("tao2", "tao4", "tao6")
    real(wp) :: omega_bind = TAO_OMEGA_DEFAULT    !! binding constant omega [1/s] (>= 0); q and
                                                  !! p enter |.|^2 as numbers in the model's
                                                  !! units (cm and cm/s for the ball)
    real(wp), allocatable :: x_copy(:)            !! Tao's x: the copy of q
    real(wp), allocatable :: y_copy(:)            !! Tao's y: the copy of p
    real(wp), allocatable :: z_old(:)             !! (q, p) at t_old
    real(wp), allocatable :: z_new(:)             !! (q, p) at t
    real(wp), allocatable :: f_old(:)             !! f(z_old), when f_old_ready
    real(wp), allocatable :: f_new(:)             !! f(z_new), when f_new_ready
    logical :: f_old_ready = .false.              !! f_old holds f(z_old)
    logical :: f_new_ready = .false.              !! f_new holds f(z_new)
    real(wp) :: h_used = 0                        !! signed size of the last accepted step [s]
    type(step_grid_t) :: grid          !! the step grid (tubes_integrator)
    integer :: nflow = 0                          !! length of the composition
    integer :: built_order = 0                    !! order the composition was built for
    integer :: flow_kind(MAXFLOW) = 0             !! FLOW_A, FLOW_B or FLOW_C
    real(wp) :: flow_coef(MAXFLOW) = 0            !! its time as a fraction of the step [1]
  contains
    procedure :: step => tao_step
    procedure :: interp => tao_interp
  end type tao_t

  public :: tao_flow_c, tao_composition

contains

  !> The exact flow of omega H_C over time d: rotation of (q - x, p - y) by the angle
  !> 2 omega d, (q + x, p + y) unchanged (Tao 2016, eq. for phi_{omega H_C}^d).
  pure subroutine tao_flow_c(omega, d, q, p, x, y)
    real(wp), intent(in) :: omega            !! binding constant [1/s]
    real(wp), intent(in) :: d                !! time [s] (either sign)
    real(wp), intent(inout) :: q(:), p(:)    !! the state
    real(wp), intent(inout) :: x(:), y(:)    !! its copies
    real(wp) :: c, s
    real(wp) :: u(size(q)), v(size(q)), sq(size(q)), sp(size(q))
    c = cos(2*omega*d)
    s = sin(2*omega*d)
    sq = q + x
    sp = p + y
    u = q - x
    v = p - y
    q = (sq + (c*u + s*v))/2
    x = (sq - (c*u + s*v))/2
    p = (sp + (c*v - s*u))/2
    y = (sp - (c*v - s*u))/2
  end subroutine tao_flow_c

  !> The flow sequence of one step of Tao's method of the given order (2, 4, 6): kinds
  !> (1 = A, 2 = B, 3 = C) and times as fractions of the step, adjacent equal kinds merged.
  !> n = 0 for an unsupported order.
  pure subroutine tao_composition(order, kinds, coefs, n)
    integer, intent(in) :: order               !! 2, 4 or 6
    integer, intent(out) :: kinds(:)           !! flow kinds in the order they are applied
                                               !! (size >= 37 for order 6)
    real(wp), intent(out) :: coefs(:)          !! their time fractions (size as kinds)
    integer, intent(out) :: n                  !! number of flows
    integer :: l, k, j, m, kk(MAXFLOW)
    real(wp) :: g, w(3), cc(MAXFLOW)
    kinds = 0
    coefs = 0
    n = 0
    if (order /= 2 .and. order /= 4 .and. order /= 6) return
    if (min(size(kinds), size(coefs)) < merge(5, merge(13, 37, order == 4), order == 2)) return
    n = 5
    kinds(1:5) = [FLOW_A, FLOW_B, FLOW_C, FLOW_B, FLOW_A]
    coefs(1:5) = [0.5_wp, 0.5_wp, 1.0_wp, 0.5_wp, 0.5_wp]
    do l = 2, order - 2, 2
      g = 1/(2 - 2**(1.0_wp/(l + 1)))
      w = [g, 1 - 2*g, g]
      m = 0
      do j = 1, 3
        do k = 1, n
          if (m > 0) then
            if (kk(m) == kinds(k)) then      ! phi_X(a) phi_X(b) = phi_X(a + b)
              cc(m) = cc(m) + w(j)*coefs(k)
              cycle
            end if
          end if
          m = m + 1
          kk(m) = kinds(k)
          cc(m) = w(j)*coefs(k)
        end do
      end do
      n = m
      kinds(1:n) = kk(1:n)
      coefs(1:n) = cc(1:n)
    end do
  end subroutine tao_composition

  !> (Re)start: storage for dimension n, copies set to the state.
  subroutine setup(self, z)
    class(tao_t), intent(inout) :: self
    real(wp), intent(in) :: z(:)
    integer :: n, m
    n = size(z)
    m = n/2
    if (allocated(self%z_new)) then
      if (size(self%z_new) /= n) deallocate (self%x_copy, self%y_copy, self%z_old, self%z_new, &
                                             self%f_old, self%f_new)
    end if
    if (.not. allocated(self%z_new)) allocate (self%x_copy(m), self%y_copy(m), self%z_old(n), &
                                               self%z_new(n), self%f_old(n), self%f_new(n))
    self%x_copy = z(1:m)
    self%y_copy = z(m + 1:n)
    self%z_new = z
    self%f_new_ready = .false.
    self%f_old_ready = .false.
    self%grid%hs = 0
    self%fresh = .false.
  end subroutine setup

  !> One step of ig%h (the last one shortened to land on tmax), in either direction.
  !> TUBES_EINPUT: h <= 0, order not 2/4/6, omega_bind < 0, odd dimension, tmax = t.
  !> A model that asks for a smaller step (stat > 0) gets h/4 for this step (counted in
  !> nrejected; TUBES_ESTEP below 16 eps |t|); stat < 0, NaN or Inf give TUBES_EMODEL.
  !> On failure t, x and the copies stay at the last accepted step.
  subroutine tao_step(self, x, tmax, stat)
    class(tao_t), intent(inout) :: self
    real(wp), intent(inout) :: x(:)   !! (q, p) at t on entry, at the new t on return
    real(wp), intent(in) :: tmax      !! never step past this time [s]
    integer, intent(out) :: stat
    real(wp) :: dir, h, hs, t, t_full, d
    real(wp) :: q(size(x)/2), p(size(x)/2), xc(size(x)/2), yc(size(x)/2)
    integer :: fs, k, m, n
    logical :: last
    stat = TUBES_OK
    n = size(x)
    m = n/2
    if (.not. (self%h > 0) .or. tmax == self%t .or. .not. (self%omega_bind >= 0) .or. &
        mod(n, 2) /= 0 .or. n == 0) then
      stat = TUBES_EINPUT
      return
    end if
    if (self%built_order /= self%order .or. self%nflow == 0) then
      call tao_composition(self%order, self%flow_kind, self%flow_coef, self%nflow)
      if (self%nflow == 0) then
        self%built_order = 0      ! nothing valid is stored: rebuild on the next call
        stat = TUBES_EINPUT
        return
      end if
      self%built_order = self%order
    end if
    if (stale_state(self%fresh, self%z_new, x)) call setup(self, x)
    call self%grid%begin(self%t, tmax, self%h, t, dir, h)
    do
      call self%grid%trial(t, tmax, dir, h, t_full, hs, last, stat)
      if (stat /= TUBES_OK) return
      q = x(1:m)
      p = x(m + 1:n)
      xc = self%x_copy
      yc = self%y_copy
      fs = 0
      do k = 1, self%nflow
        d = self%flow_coef(k)*hs
        select case (self%flow_kind(k))
        case (FLOW_A)          ! H(q, y): p and x move
          call tao_flow_f(self%f, t, d, q, yc, xc, p, self%nfev, fs)
          if (fs /= 0) exit
        case (FLOW_B)          ! H(x, p): q and y move
          call tao_flow_f(self%f, t, d, xc, p, q, yc, self%nfev, fs)
          if (fs /= 0) exit
        case default           ! omega H_C
          call tao_flow_c(self%omega_bind, d, q, p, xc, yc)
        end select
      end do
      if (fs == 0 .and. .not. (all_finite(q) .and. all_finite(p) .and. all_finite(xc) .and. &
                               all_finite(yc))) fs = -1
      if (.not. self%grid%retry(fs, h, self%nrejected, stat)) exit   ! fs > 0: h/4, off the grid
    end do
    if (stat /= TUBES_OK) return
    self%z_old = x
    self%f_old_ready = self%f_new_ready
    if (self%f_new_ready) self%f_old = self%f_new
    self%f_new_ready = .false.
    x(1:m) = q
    x(m + 1:n) = p
    self%z_new = x
    self%x_copy = xc
    self%y_copy = yc
    self%t_old = t
    self%t = self%grid%finish(last, tmax, t_full)
    self%h_used = hs
    self%nsteps = self%nsteps + 1
  end subroutine tao_step

  !> Flow A or B over d: with f = f(t, (a, b)) at the mixed point (one evaluation, counted in
  !> nfev), u <- u + d f_q and v <- v + d f_p; unchanged if the model refuses (fs /= 0).
  !> phi_A is (a, b, u, v) = (q, y, x, p), phi_B is (x, p, q, y).
  subroutine tao_flow_f(f, t, d, a, b, u, v, nfev, fs)
    class(vector_field_t), intent(in) :: f
    real(wp), intent(in) :: t, d, a(:), b(:)
    real(wp), intent(inout) :: u(:), v(:)
    integer(i8), intent(inout) :: nfev
    integer, intent(out) :: fs
    real(wp) :: fm(2*size(a))
    integer :: m
    m = size(a)
    call f%eval(t, [a, b], fm, fs)
    nfev = nfev + 1
    if (fs /= 0) return
    u = u + d*fm(1:m)
    v = v + d*fm(m + 1:2*m)
  end subroutine tao_flow_f

  !> Cubic Hermite interpolation from (q, p) and f at both ends of the last accepted step;
  !> the two slopes are evaluated on first use (f at the end is kept for the next step).
  !> If the model refuses either end, xs is NaN (never interpolate silently).
  subroutine tao_interp(self, s, xs)
    class(tao_t), intent(inout) :: self
    real(wp), intent(in) :: s       !! time in [t_old, t] [s]
    real(wp), intent(out) :: xs(:)  !! (q, p) at s
    integer :: fs
    call slope_at(self%f, self%t_old, self%z_old, self%f_old, self%f_old_ready, self%nfev, fs)
    if (fs == 0) call slope_at(self%f, self%t, self%z_new, self%f_new, self%f_new_ready, self%nfev, fs)
    if (fs /= 0) then
      xs = ieee_value(1.0_wp, ieee_quiet_nan)
      return
    end if
    call hermite(self%z_old, self%f_old, self%z_new, self%f_new, self%t_old, self%h_used, s, xs)
  end subroutine tao_interp

  !> fz = f(t, z) unless ready already (then ready, and nfev counts the evaluation); fs the model's
  !> status.
  subroutine slope_at(f, t, z, fz, ready, nfev, fs)
    class(vector_field_t), intent(in) :: f
    real(wp), intent(in) :: t, z(:)
    real(wp), intent(inout) :: fz(:)
    logical, intent(inout) :: ready
    integer(i8), intent(inout) :: nfev
    integer, intent(out) :: fs
    fs = 0
    if (ready) return
    call f%eval(t, z, fz, fs)
    nfev = nfev + 1
    ready = fs == 0
  end subroutine slope_at
end module tubes_tao
