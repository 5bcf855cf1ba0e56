!> The Taylor method (docs/integrators-taylor.md): each step computes the solution's normalised
!> Taylor coefficients x_k (x(t + s) = sum_k x_k s^k) with a kernel generated from the model's
!> formula (python/tubes/jetgen.py, compiled and cached by src/io/tubes_expr.c), chooses order and
!> step in the manner of Jorba & Zou (2005) and of heyoka, and keeps the polynomial as its dense
!> output. Events that are affine in the state (every section of tubes) are found on the step's
!> polynomial by root isolation (Descartes' rule of signs with bisection), every crossing in a
!> step (tubes_integrator's scan_step asks `event_samples`).
!>
!> Order and step: with eps = atol where rtol |x|_inf <= atol (absolute) and eps = rtol otherwise
!> (relative), order p = ceil(-ln(eps)/2 + 1); from the last two coefficients' norms (relative:
!> divided by |x|_inf) the radius rho = min(|x_{p-1}|^(-1/(p-1)), |x_p|^(-1/p)) and the step
!> h = rho exp(-2 - 0.7/(p - 1)). No step is rejected: the step is chosen from the series itself.
module tubes_taylor
  use, intrinsic :: iso_c_binding, only: c_int, c_double, c_char, c_null_char, c_funptr, c_null_funptr, &
                                         c_associated, c_f_procpointer
  use tubes_kinds, only: wp
  use tubes_cstrings, only: c_to_f
  use tubes_field, only: jet_spec_t, vector_field_t
  use tubes_integrator, only: integrator_t, event_t, observer_t, integrator_init
  use tubes_status, only: TUBES_OK, TUBES_EINPUT, TUBES_EMODEL, TUBES_ESTEP, TUBES_ENOJET
  implicit none
  private

  integer, parameter, public :: TAYLOR_MAX_ORDER = 60   !! the kernels' largest order
  integer, parameter :: MAXDEPTH = 40                     ! root isolation: bisections at most
  integer, parameter :: JET_VARIATIONAL = 1, JET_ACTION = 2, JET_TANGENT = 4   ! include/tubes.h TUBES_JET_*

  abstract interface
    !> include/tubes.h tubes_jet_fn
    integer(c_int) function jet_fn_i(order, par, tc, w) bind(C)
      import :: c_int, c_double
      integer(c_int), value :: order
      real(c_double), intent(in) :: par(*)
      real(c_double), intent(inout) :: tc(*)
      real(c_double), intent(inout) :: w(*)
    end function jet_fn_i
  end interface

  interface
    integer(c_int) function jet_get(model, order, lanes, flags, fn, dim, nwork, msg, lmsg) &
        bind(C, name='tubes_jet_get')
      import :: c_int, c_char, c_funptr
      character(kind=c_char), intent(in) :: model(*)
      integer(c_int), value :: order, lanes, flags, lmsg
      type(c_funptr), intent(out) :: fn
      integer(c_int), intent(out) :: dim, nwork
      character(kind=c_char), intent(out) :: msg(*)
    end function jet_get
  end interface

  !> A kernel of one order (or, for an extended state, of any order).
  type, public :: kernel_t
    integer :: order = -1                                  !! its order (0: any)
    integer :: nwork = 0                                   !! scratch series
    integer :: dim = 0                                     !! the state's dimension
    procedure(jet_fn_i), pointer, nopass :: fn => null()
  end type kernel_t

  type, extends(integrator_t), public :: taylor_t
    integer :: order = 0                   !! 0: from the tolerances (above); else fixed
    integer :: p = 0                       !! order of the last step
    integer :: n = 0                       !! state dimension
    real(wp) :: hs = 0                     !! signed size of the last step [time]
    real(wp) :: t_next = 0                 !! the step's end, t + hs exactly (taylor_size)
    real(wp) :: xn = 0                     !! |x|_inf at the step's start
    real(wp) :: eps_last = -1              !! the tolerance of the last order chosen
    integer :: p_last = 0                  !! and that order
    logical :: relative = .false.          !! the step's error control is relative
    integer :: ik = 0                      !! the kernel of order p in kernels (0: none yet)
    real(wp) :: rule(3) = 0                !! 1/(p - 1), 1/p, (-2 - 0.7/(p - 1))/ln 2 of order p
    real(wp) :: rxn = 0                    !! 1/xn (relative control)
    real(wp) :: dir = 1                    !! the step's direction, sign(tmax - t)
    real(wp) :: left = 0                   !! |tmax - t| at the step's start [time]
    real(wp) :: slack = 0                  !! what may be left of it: 64 ulps of max(|t|, |tmax|)
    real(wp) :: par(2) = 0                 !! the kernel's parameters: the damping rate, the rolling drag
    integer :: nq = 0                      !! the model refuses |x(1:nq)|_1 > q_bound (jet_spec_t)
    real(wp) :: q_bound = huge(1.0_wp)
    character(:), allocatable :: spec      !! the model's formula (jet_spec_t%text)
    integer :: flags = 0                   !! include/tubes.h TUBES_JET_* of the field
    type(kernel_t) :: kernels(2)           !! the kernels of the (at most two) orders in use
    real(wp), allocatable :: tc(:)         !! the last step's coefficients at t_old
    real(wp), allocatable :: x_end(:)      !! the last step's new state, tc's polynomial at hs
    logical :: end_ok = .false.            !! x_end is that of tc, t_old and hs (taylor_interp)
    real(wp), allocatable :: w(:)          !! the kernel's scratch
    character(512) :: msg = ''             !! why the last kernel could not be had
  contains
    procedure :: init => taylor_init
    procedure :: step => taylor_step
    procedure :: interp => taylor_interp
    procedure :: event_samples => taylor_event_samples
    procedure :: event_clear => taylor_event_clear
  end type taylor_t

  !> Every step of a Taylor integration, its polynomial: the dense output of the whole
  !> integration, to be evaluated anywhere in it afterwards (an observer of propagate).
  type, extends(observer_t), public :: taylor_record_t
    integer :: n = 0                       !! steps recorded
    integer :: dim = 0                     !! the state's dimension
    real(wp), allocatable :: t0(:)         !! each step's start [time]
    real(wp), allocatable :: hs(:)         !! and signed size
    integer, allocatable :: p(:), off(:)   !! its order, and where its coefficients start in c
    real(wp), allocatable :: c(:)          !! the coefficients, step after step
  contains
    procedure :: on_step => record_on_step
    procedure :: eval => record_eval
  end type taylor_record_t

  public :: taylor_order, isolate_roots, taylor_check, taylor_begin, taylor_end, taylor_size, taylor_advance, &
            jet_kernel, taylor_prepare, taylor_rule, step_sizes

contains

  !> Keep the step's polynomial (Taylor steps only: another method's step is not recorded).
  subroutine record_on_step(self, ig, t_hi)
    class(taylor_record_t), intent(inout) :: self
    class(integrator_t), intent(inout) :: ig
    real(wp), intent(in) :: t_hi
    integer :: m, need
    select type (ig)
    class is (taylor_t)
      if (.not. allocated(self%t0)) then
        allocate (self%t0(64), self%hs(64), self%p(64), self%off(64), self%c(64*ig%n*(ig%p + 1)))
        self%n = 0
        self%dim = ig%n
      end if
      m = ig%n*(ig%p + 1)
      need = 1
      if (self%n > 0) need = self%off(self%n) + self%dim*(self%p(self%n) + 1)
      if (self%n == size(self%t0)) then
        self%t0 = [self%t0, self%t0]
        self%hs = [self%hs, self%hs]
        self%p = [self%p, self%p]
        self%off = [self%off, self%off]
      end if
      if (need + m - 1 > size(self%c)) self%c = [self%c, self%c, self%c(1:m)]
      self%n = self%n + 1
      self%t0(self%n) = ig%t_old
      self%hs(self%n) = ig%t - ig%t_old
      self%p(self%n) = ig%p
      self%off(self%n) = need
      self%c(need:need + m - 1) = ig%tc(1:m)
    end select
  end subroutine record_on_step

  !> The recorded integration's state at t (within its span): stat TUBES_EINPUT outside it.
  subroutine record_eval(self, t, z, stat)
    class(taylor_record_t), intent(in) :: self
    real(wp), intent(in) :: t
    real(wp), intent(out) :: z(:)
    integer, intent(out) :: stat
    real(wp) :: ds, dir
    integer :: lo, hi, mid, j, i, k, s, o
    stat = TUBES_EINPUT
    z = 0
    if (self%n < 1 .or. size(z) /= self%dim) return
    dir = sign(1.0_wp, self%hs(1))
    if (dir*(t - self%t0(1)) < 0 .or. dir*(t - (self%t0(self%n) + self%hs(self%n))) > 0) return
    lo = 1                               ! the last step starting at or before t
    hi = self%n
    do while (lo < hi)
      mid = (lo + hi + 1)/2
      if (dir*(t - self%t0(mid)) >= 0) then
        lo = mid
      else
        hi = mid - 1
      end if
    end do
    j = lo
    ds = t - self%t0(j)
    s = self%p(j) + 1
    o = self%off(j)
    do i = 1, self%dim
      z(i) = self%c(o + (i - 1)*s + s - 1)
      do k = self%p(j) - 1, 0, -1
        z(i) = z(i)*ds + self%c(o + (i - 1)*s + k)
      end do
    end do
    stat = TUBES_OK
  end subroutine record_eval

  !> The order for tolerance eps (Jorba & Zou): ceil(-ln(eps)/2 + 1), within 2..TAYLOR_MAX_ORDER.
  pure integer function taylor_order(eps)
    real(wp), intent(in) :: eps
    taylor_order = max(2, min(TAYLOR_MAX_ORDER, ceiling(-log(max(eps, tiny(1.0_wp)))/2 + 1)))
  end function taylor_order

  !> Can the Taylor method integrate `field` at relative tolerance eps? Gets (builds, if it must)
  !> the kernel of that order: stat TUBES_OK, or TUBES_ENOJET with the reason in msg. A driver
  !> calls it before its scenes, so that a missing compiler or SymPy is reported up front.
  subroutine taylor_check(field, eps, msg, stat)
    class(vector_field_t), intent(in) :: field
    real(wp), intent(in) :: eps
    character(*), intent(out) :: msg
    integer, intent(out) :: stat
    type(taylor_t) :: ig
    integer :: k
    msg = ''
    call ig%init(field, 0.0_wp)
    call taylor_setup(ig, field%dim(), stat)
    if (stat == TUBES_OK) call kernel_of(ig, taylor_order(eps), k, stat)
    if (stat /= TUBES_OK) msg = ig%msg
  end subroutine taylor_check

  !> The kernel of order p for `lanes` lanes of the model text spec (TUBES_JET_* flags), from the
  !> loader; stat TUBES_ENOJET with the reason in msg if it cannot be had.
  subroutine jet_kernel(spec, p, lanes, flags, k, msg, stat)
    character(*), intent(in) :: spec
    integer, intent(in) :: p, lanes, flags
    type(kernel_t), intent(out) :: k
    character(*), intent(out) :: msg
    integer, intent(out) :: stat
    type(c_funptr) :: fp
    integer(c_int) :: dim, nwork
    character(kind=c_char) :: cmsg(512)
    msg = ''
    stat = int(jet_get(spec // c_null_char, p, lanes, flags, fp, dim, nwork, cmsg, 512))
    if (stat /= TUBES_OK .or. .not. c_associated(fp)) then
      msg = c_to_f(cmsg)
      stat = TUBES_ENOJET
      return
    end if
    k%order = p
    k%nwork = nwork
    k%dim = dim
    call c_f_procpointer(fp, k%fn)
  end subroutine jet_kernel

  !> The kernel of order p (0: an extended state's loop kernel), from the two kept or the loader.
  subroutine kernel_of(self, p, k, stat)
    class(taylor_t), intent(inout) :: self
    integer, intent(in) :: p
    integer, intent(out) :: k
    integer, intent(out) :: stat
    type(kernel_t) :: kn
    stat = TUBES_OK
    do k = 1, 2
      if (self%kernels(k)%order == p) return
    end do
    call jet_kernel(self%spec, p, 1, self%flags, kn, self%msg, stat)
    if (stat /= TUBES_OK) return
    if (kn%dim /= self%n) then
      self%msg = 'the Taylor kernel is not of this state''s dimension'
      stat = TUBES_ENOJET
      return
    end if
    k = 1
    if (self%kernels(1)%order >= 0) k = 2
    if (k == 2 .and. self%kernels(2)%order >= 0) self%kernels(1) = self%kernels(2)   ! the older one goes
    self%kernels(k) = kn
  end subroutine kernel_of

  !> Set up on the first step: the model's formula and the state's size.
  subroutine taylor_setup(self, n, stat)
    class(taylor_t), intent(inout) :: self
    integer, intent(in) :: n
    integer, intent(out) :: stat
    type(jet_spec_t) :: js
    integer :: flags
    stat = TUBES_OK
    js = self%f%jet_spec()
    if (.not. allocated(js%text)) then
      self%msg = 'the model is not written as a formula (method = ''taylor'' needs one)'
      stat = TUBES_ENOJET
      return
    end if
    flags = merge(JET_ACTION, 0, js%action) + merge(JET_VARIATIONAL, 0, js%variational) + &
            merge(JET_TANGENT, 0, js%tangent)
    if (allocated(self%spec)) then
      if (self%spec /= js%text .or. self%flags /= flags) self%kernels = kernel_t()
    end if
    self%ik = 0          ! the next step takes its kernel, storage and constants afresh
    self%spec = js%text
    self%flags = flags
    self%par(1) = js%damping
    self%par(2) = js%rolling
    self%nq = min(js%nq, n)
    self%q_bound = js%q_bound
    self%n = n
    if (allocated(self%x_end)) deallocate (self%x_end)
    allocate (self%x_end(n))
    self%end_ok = .false.
  end subroutine taylor_setup

  !> A copy of the model and a new integration (integrator_t%init); the model's formula is read
  !> again on the first step (a restart of the same model does not read it: taylor_begin).
  subroutine taylor_init(self, f, t0)
    class(taylor_t), intent(inout) :: self
    class(vector_field_t), intent(in) :: f
    real(wp), intent(in) :: t0
    call integrator_init(self, f, t0)
    self%n = -1
    self%end_ok = .false.
  end subroutine taylor_init

  !> One step from (t, x) towards tmax (never past it).
  subroutine taylor_step(self, x, tmax, stat)
    class(taylor_t), intent(inout) :: self
    real(wp), intent(inout) :: x(:)
    real(wp), intent(in) :: tmax
    integer, intent(out) :: stat
    integer :: ik
    call taylor_begin(self, x, tmax, ik, stat)
    if (stat /= TUBES_OK) return
    if (self%kernels(ik)%fn(self%p, self%par, self%tc, self%w) /= 0) then
      stat = TUBES_EMODEL
      return
    end if
    call taylor_end(self, x, tmax, stat)
  end subroutine taylor_step

  !> The step rule's constants of order p: 1/(p - 1), 1/p, (-2 - 0.7/(p - 1))/ln 2 (step_size).
  pure function taylor_rule(p) result(r)
    integer, intent(in) :: p
    real(wp) :: r(3)
    r = [1.0_wp/(p - 1), 1.0_wp/p, (-2 - 0.7_wp/(p - 1))/log(2.0_wp)]
  end function taylor_rule

  !> Set up for a state of size n if not yet (a new model, taylor_init): the model's formula, its
  !> parameters and bounds. stat TUBES_ENOJET if the model is not written as a formula.
  subroutine taylor_prepare(self, n, stat)
    class(taylor_t), intent(inout) :: self
    integer, intent(in) :: n
    integer, intent(out) :: stat
    stat = TUBES_OK
    if (.not. allocated(self%spec) .or. self%n /= n) call taylor_setup(self, n, stat)
  end subroutine taylor_prepare

  !> The first half of a step: the order and its kernel (ik, in self%kernels; its order is
  !> self%p), the coefficients' storage, x as the coefficients of order 0. The kernel then fills
  !> self%tc (taylor_step, or the lanes' driver for several integrations at once).
  subroutine taylor_begin(self, x, tmax, ik, stat)
    class(taylor_t), intent(inout) :: self
    real(wp), intent(in) :: x(:)
    real(wp), intent(in) :: tmax
    integer, intent(out) :: ik
    integer, intent(out) :: stat
    real(wp) :: eps
    integer :: p, i, s
    stat = TUBES_OK
    ik = 1
    call taylor_prepare(self, size(x), stat)
    if (stat /= TUBES_OK) return
    self%fresh = .false.
    self%end_ok = .false.            ! (the coefficients are about to change)
    self%xn = maxval(abs(x))
    self%relative = self%rtol*self%xn > self%atol
    eps = merge(self%rtol, self%atol, self%relative)
    if (.not. eps > 0) then
      stat = TUBES_EINPUT
      return
    end if
    p = self%order
    if (p <= 0) then                 ! the order of eps (kept: a log per step otherwise)
      if (eps /= self%eps_last) then
        self%eps_last = eps
        self%p_last = taylor_order(eps)
      end if
      p = self%p_last
    end if
    if (p /= self%p .or. self%ik == 0) then   ! another order (the kernel, storage, constants)
      if (p < 2 .or. p > TAYLOR_MAX_ORDER) then
        stat = TUBES_EINPUT
        return
      end if
      call kernel_of(self, merge(0, p, self%flags /= 0), ik, stat)   ! extras: the loop kernel
      if (stat /= TUBES_OK) return
      s = p + 1
      if (.not. allocated(self%tc)) allocate (self%tc(0))
      if (size(self%tc) < self%n*s) then
        deallocate (self%tc)
        allocate (self%tc(self%n*s))
      end if
      if (.not. allocated(self%w)) allocate (self%w(0))
      if (size(self%w) < self%kernels(ik)%nwork*s) then
        deallocate (self%w)
        allocate (self%w(self%kernels(ik)%nwork*s))
      end if
      self%rule = taylor_rule(p)                                     ! not a division per step
      self%p = p
      self%ik = ik
    end if
    ik = self%ik
    s = p + 1
    ! what taylor_end needs and the coefficients do not decide, computed here, where the kernel's
    ! time hides it (after the kernel each step's work waits for the one before)
    if (self%relative) self%rxn = 1/self%xn
    self%dir = sign(1.0_wp, tmax - self%t)
    self%left = abs(tmax - self%t)
    self%slack = 64*epsilon(1.0_wp)*max(abs(self%t), abs(tmax))
    do i = 1, self%n
      self%tc((i - 1)*s + 1) = x(i)
    end do
    self%nfev = self%nfev + 1
  end subroutine taylor_begin

  !> The second half of a step, the coefficients in self%tc: the step size from the last two
  !> orders, the new state by Horner's scheme, the new time.
  subroutine taylor_end(self, x, tmax, stat)
    class(taylor_t), intent(inout) :: self
    real(wp), intent(inout) :: x(:)
    real(wp), intent(in) :: tmax
    integer, intent(out) :: stat
    call taylor_end_from(self, self%tc, 1, x, tmax, stat)
    if (stat == TUBES_OK) then       ! the new state, for an observer's taylor_interp at t
      self%x_end(1:self%n) = x
      self%end_ok = .true.
    end if
  end subroutine taylor_end

  !> taylor_end with the step's coefficients in tc, coefficient k of component i at
  !> tc(1 + ((i - 1)(p + 1) + k) ld): self%tc (ld = 1), or one lane of the lanes' kernel array
  !> (ld the lanes' width), read in place. In three parts: taylor_size, Horner's scheme,
  !> taylor_advance (the lanes' driver, tubes_lanes, does the middle one for all its lanes at
  !> once, horner_lanes in src/integrators/tubes_lanes_run.f90).
  subroutine taylor_end_from(self, tc, ld, x, tmax, stat)
    class(taylor_t), intent(inout) :: self
    real(wp), intent(in) :: tc(*)
    integer, intent(in) :: ld
    real(wp), intent(inout) :: x(:)
    real(wp), intent(in) :: tmax
    integer, intent(out) :: stat
    logical :: last
    call taylor_size(self, tc, ld, last, stat)
    if (stat /= TUBES_OK) return
    call horner(tc, ld, self%p + 1, self%n, self%p, self%hs, x)
    call taylor_advance(self, tc, ld, x, tmax, last, stat)
  end subroutine taylor_end_from

  !> The step's size from its coefficients (tc, ld: as taylor_end_from): self%hs (signed) and
  !> self%t_old; last: the step reaches tmax. stat TUBES_ESTEP if it is too small to be taken.
  subroutine taylor_size(self, tc, ld, last, stat)
    class(taylor_t), intent(inout) :: self
    real(wp), intent(in) :: tc(*)
    integer, intent(in) :: ld
    logical, intent(out) :: last
    integer, intent(out) :: stat
    real(wp) :: n1(1), n2(1), h, hv(1), hmin
    integer :: p, s, i
    stat = TUBES_OK
    p = self%p
    s = p + 1
    n1 = 0      ! the largest |coefficient| of orders p - 1 and p over the components
    n2 = 0
    do i = 1, self%n
      n1 = max(n1, abs(tc(1 + ((i - 1)*s + p - 1)*ld)))
      n2 = max(n2, abs(tc(1 + (i*s - 1)*ld)))
    end do
    if (self%relative) then
      n1 = n1*self%rxn
      n2 = n2*self%rxn
    end if
    call step_sizes(1, n1, n2, self%rule(1:1), self%rule(2:2), self%rule(3:3), hv)   ! rho e^(-2-0.7/(p-1))
    h = hv(1)
    if (self%h > 0) h = min(h, self%h)              ! &integrator h: the largest step
    ! the last step: it reaches tmax, or would leave less than 64 ulps of it (no sliver of a step)
    last = h >= self%left - self%slack
    if (last) h = self%left
    hmin = 16*epsilon(1.0_wp)*max(abs(self%t), tiny(1.0_wp))
    if (.not. last .and. h < hmin) then
      stat = TUBES_ESTEP
      return
    end if
    ! the step on the time grid: hs = fl(t + dir h) - t, so that the new state, the polynomial at
    ! hs, is also its value at the new time t_next (taylor_interp there: the same point)
    if (last) then
      self%hs = self%dir*h
    else
      self%t_next = self%t + self%dir*h
      self%hs = self%t_next - self%t
    end if
    self%t_old = self%t
  end subroutine taylor_size

  !> The end of a step whose new state x is the step's polynomial at self%hs (taylor_size, then
  !> Horner's scheme): refused (x back to the step's start, stat TUBES_EMODEL) if the model would
  !> refuse it, else the new time (tmax on the last step).
  subroutine taylor_advance(self, tc, ld, x, tmax, last, stat)
    class(taylor_t), intent(inout) :: self
    real(wp), intent(in) :: tc(*)
    integer, intent(in) :: ld
    real(wp), intent(inout) :: x(:)
    real(wp), intent(in) :: tmax
    logical, intent(in) :: last
    integer, intent(out) :: stat
    integer :: s, i
    stat = TUBES_OK
    s = self%p + 1
    ! a state the model refuses (not finite, or escaped: as its eval would): the step is not taken
    if (.not. (all(abs(x) <= huge(1.0_wp)) .and. sum(abs(x(1:self%nq))) <= self%q_bound)) then
      do i = 1, self%n
        x(i) = tc(1 + (i - 1)*s*ld)
      end do
      stat = TUBES_EMODEL
      return
    end if
    if (last) then
      self%t = tmax
    else
      self%t = self%t_next
    end if
    self%nsteps = self%nsteps + 1
  end subroutine taylor_advance

  include 'tubes_step_size.inc'

  !> x = sum_k tc(1, k, :) ds^k by Horner's scheme, four components at a time in four independent
  !> chains (a chain's multiply-add waits for its last one: four in flight hide that latency);
  !> every component's arithmetic is the plain scheme's. ld: the coefficients' stride (1, or a
  !> lane of the lanes' array).
  pure subroutine horner(tc, ld, s, n, p, ds, x)
    integer, intent(in) :: ld, s, n, p
    real(wp), intent(in) :: tc(ld, s, n), ds
    real(wp), intent(out) :: x(n)
    real(wp) :: a1, a2, a3, a4
    integer :: i, k
    do i = 1, n - 3, 4
      a1 = tc(1, p + 1, i)
      a2 = tc(1, p + 1, i + 1)
      a3 = tc(1, p + 1, i + 2)
      a4 = tc(1, p + 1, i + 3)
      do k = p, 1, -1
        a1 = a1*ds + tc(1, k, i)
        a2 = a2*ds + tc(1, k, i + 1)
        a3 = a3*ds + tc(1, k, i + 2)
        a4 = a4*ds + tc(1, k, i + 3)
      end do
      x(i) = a1
      x(i + 1) = a2
      x(i + 2) = a3
      x(i + 3) = a4
    end do
    do i = 4*(n/4) + 1, n
      a1 = tc(1, p + 1, i)
      do k = p, 1, -1
        a1 = a1*ds + tc(1, k, i)
      end do
      x(i) = a1
    end do
  end subroutine horner

  !> The step's polynomial at s in [t_old, t].
  subroutine taylor_interp(self, s, xs)
    class(taylor_t), intent(inout) :: self
    real(wp), intent(in) :: s
    real(wp), intent(out) :: xs(:)
    real(wp) :: ds
    ds = s - self%t_old
    if (self%end_ok) then            ! at the step's end (an observer, every step): its new state,
      if (ds == self%hs) then        ! the same polynomial at the same point, computed once
        xs = self%x_end(1:self%n)
        return
      end if
    end if
    call horner(self%tc, 1, self%p + 1, self%n, self%p, ds, xs)
  end subroutine taylor_interp

  !> Interior sample times of the last step for an event's scan: for an event affine in the state
  !> (g = w . x - c), the ends of the intervals that isolate the roots of g's polynomial on the
  !> step, so that each sign change of g between consecutive samples is one crossing and every
  !> crossing of odd multiplicity is seen; otherwise the event's nsub equally spaced points.
  subroutine taylor_event_samples(self, event, ts, m)
    class(taylor_t), intent(inout) :: self
    class(event_t), intent(in) :: event
    real(wp), allocatable, intent(out) :: ts(:)   !! in the order of integration
    integer, intent(out) :: m
    real(wp) :: a(0:self%p)
    integer :: i
    logical :: ok
    call event_polynomial(self, event, a, ok)
    if (.not. ok) then
      allocate (ts(event%nsub))
      m = event%nsub
      do i = 1, m
        ts(i) = self%t_old + (self%t - self%t_old)*(real(i, wp)/(m + 1))
      end do
      return
    end if
    call isolate_roots(a, self%t - self%t_old, ts, m)
    ts(1:m) = self%t_old + ts(1:m)
  end subroutine taylor_event_samples

  !> Whether an affine event's g surely has no root in the last step: isolate_roots' first test
  !> (root_free), the same arithmetic, so that where it holds event_samples finds no sample.
  logical function taylor_event_clear(self, event) result(clear)
    class(taylor_t), intent(inout) :: self
    class(event_t), intent(in) :: event
    real(wp) :: a(0:self%p), q(0:self%p)
    logical :: ok
    call event_polynomial(self, event, a, ok)
    clear = .false.
    if (.not. ok) return
    call scaled_to_step(a, self%t - self%t_old, q)
    clear = root_free(q)
  end function taylor_event_clear

  !> g(t_old + s) = sum_k a(k) s^k on the last step for an affine event g = w . x - c (ok), from
  !> the step's coefficients.
  subroutine event_polynomial(self, event, a, ok)
    class(taylor_t), intent(in) :: self
    class(event_t), intent(in) :: event
    real(wp), intent(out) :: a(0:self%p)
    logical, intent(out) :: ok
    real(wp) :: w(self%n), c
    integer :: i, k, s
    call event%affine(self%n, w, c, ok)
    if (.not. ok) return
    s = self%p + 1
    a = 0
    do i = 1, self%n                      ! (each a(k) summed over i in order, as written out)
      if (w(i) == 0) cycle
      do k = 0, self%p
        a(k) = a(k) + w(i)*self%tc((i - 1)*s + k + 1)
      end do
    end do
    a(0) = a(0) - c
  end subroutine event_polynomial

  !> q(k) = a(k) h^k: the polynomial in u = s/h on [0, 1].
  pure subroutine scaled_to_step(a, h, q)
    real(wp), intent(in) :: a(0:), h
    real(wp), intent(out) :: q(0:)
    real(wp) :: hk
    integer :: k
    hk = 1
    do k = 0, size(a) - 1
      q(k) = a(k)*hk
      hk = hk*h
    end do
  end subroutine scaled_to_step

  !> No root in [0, 1] when |q(0)| > sum |q(k)| (|P(u)| >= |q(0)| - sum |q(k)| u^k > 0); with a
  !> margin far above the sums' rounding. Most steps are far from the event: this O(d) test
  !> spares them the bisection's O(d^2) shifts, and finds nothing the bisection would have.
  pure logical function root_free(q) result(clear)
    real(wp), intent(in) :: q(0:)
    real(wp) :: tail
    integer :: k
    tail = 0
    do k = 1, size(q) - 1
      tail = tail + abs(q(k))
    end do
    clear = abs(q(0)) > tail*(1 + 1.0e-3_wp)
  end function root_free

  !> Points 0 < |s_1| < ... < |s_m| < |h| (the sign of h) that isolate the real roots of
  !> P(s) = sum_k a(k) s^k in (0, h): each root of odd multiplicity lies in an interval between
  !> consecutive points (0 and h included) that holds no other root. Descartes' rule of signs on
  !> [0, 1] after s = h u, with bisection (the Vincent-Collins-Akritas method); an interval still
  !> holding several roots after MAXDEPTH halvings (a root of even multiplicity, or roots closer
  !> than h 2^-40) is left as it is.
  subroutine isolate_roots(a, h, ts, m)
    real(wp), intent(in) :: a(0:)
    real(wp), intent(in) :: h
    real(wp), allocatable, intent(out) :: ts(:)
    integer, intent(out) :: m
    real(wp) :: q(0:size(a) - 1), ends(2*size(a))
    integer :: k, ne
    call scaled_to_step(a, h, q)
    if (root_free(q)) then
      allocate (ts(0))
      m = 0
      return
    end if
    ne = 0
    call isolate(q, 0.0_wp, 1.0_wp, 0)
    ! the interior ends, sorted and without repeats, scaled to s
    call sort(ends(1:ne))
    allocate (ts(ne))
    m = 0
    do k = 1, ne
      if (ends(k) <= 0 .or. ends(k) >= 1) cycle
      if (m > 0) then
        if (ends(k) == ts(m)) cycle
      end if
      m = m + 1
      ts(m) = ends(k)
    end do
    ts(1:m) = ts(1:m)*h
  contains
    recursive subroutine isolate(qq, lo, hi, depth)
      real(wp), intent(in) :: qq(0:), lo, hi
      integer, intent(in) :: depth
      real(wp) :: ql(0:size(qq) - 1), qr(0:size(qq) - 1), mid
      integer :: v, j
      v = sign_variations_01(qq)
      if (v == 0) return
      if (v == 1 .or. depth >= MAXDEPTH .or. ne + 2 > size(ends)) then
        ends(ne + 1) = lo
        ends(ne + 2) = hi
        ne = ne + 2
        return
      end if
      mid = lo + (hi - lo)/2
      do j = 0, size(qq) - 1            ! left half: q(u/2)
        ql(j) = qq(j)*0.5_wp**j
      end do
      qr = ql
      call taylor_shift(qr)             ! right half: q((1 + u)/2)
      call isolate(ql, lo, mid, depth + 1)
      call isolate(qr, mid, hi, depth + 1)
    end subroutine isolate
  end subroutine isolate_roots

  !> An upper bound (Descartes) on the number of roots of q in (0, 1), exact when 0 or 1: the
  !> sign variations of the coefficients of (1 + x)^d q(1/(1 + x)).
  pure integer function sign_variations_01(q) result(v)
    real(wp), intent(in) :: q(0:)
    real(wp) :: r(0:size(q) - 1), last
    integer :: d, j
    d = size(q) - 1
    do j = 0, d
      r(j) = q(d - j)
    end do
    call taylor_shift(r)
    v = 0
    last = 0
    do j = 0, d
      if (r(j) == 0) cycle
      if (last /= 0 .and. sign(1.0_wp, r(j)) /= sign(1.0_wp, last)) v = v + 1
      last = r(j)
    end do
  end function sign_variations_01

  !> Coefficients of q(x + 1) from those of q(x) (Horner's scheme, in place).
  pure subroutine taylor_shift(q)
    real(wp), intent(inout) :: q(0:)
    integer :: d, i, j
    d = size(q) - 1
    do i = 0, d - 1
      do j = d - 1, i, -1
        q(j) = q(j) + q(j + 1)
      end do
    end do
  end subroutine taylor_shift

  !> Insertion sort (a handful of values).
  pure subroutine sort(v)
    real(wp), intent(inout) :: v(:)
    real(wp) :: t
    integer :: i, j
    do i = 2, size(v)
      t = v(i)
      j = i - 1
      do while (j >= 1)
        if (v(j) <= t) exit
        v(j + 1) = v(j)
        j = j - 1
      end do
      v(j + 1) = t
    end do
  end subroutine sort
end module tubes_taylor
