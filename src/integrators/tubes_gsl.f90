!> GSL odeiv2 backends of integrator_t (through the C shim src/integrators/tubes_gsl_shim.c):
!>   kind = 'gsl_rk8pd':  gsl_odeiv2_step_rk8pd, Prince-Dormand 8(7), 13 stages, explicit;
!>   kind = 'gsl_rk4imp': gsl_odeiv2_step_rk4imp, 2-stage Gauss-Legendre (implicit, order 4,
!>                        symplectic), modified Newton with the model's Jacobian, error by
!>                        step doubling.
!> Step control is GSL's y_new control (gsl_odeiv2_control_y_new: accepts
!> max_i |err_i|/(atol + rtol |y_i|) <= 1.1); step is one gsl_odeiv2_evolve_apply with
!> t1 = tmax (never passes it, lands on it). h > 0 is taken as the first step to try, not as
!> a fixed step; otherwise Hairer's starting-step estimate chooses it.
!> GSL gives these steppers no dense output: interp is the cubic Hermite interpolant of x and
!> f at both ends of the step (f at the new point is evaluated by the stepper anyway, and
!> counted), so its error is O(h^4), h^4/384 max|x''''| on [t_old, t], far above the step's
!> own accuracy on long steps. Events located on it are no more accurate than that
!> (docs/integrators-backends.md has measured numbers). Each instance owns its GSL objects
!> (free them with destroy; final does it as well) and must not be copied once it holds them.
module tubes_gsl
  use, intrinsic :: iso_c_binding, only: c_int, c_long, c_size_t, c_double, c_char, c_ptr, &
                                         c_funptr, c_null_ptr, c_loc, c_funloc, &
                                         c_f_pointer, c_associated
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan, ieee_is_finite
  use tubes_kinds, only: wp, i8
  use tubes_cstrings, only: c_to_f
  use tubes_field, only: vector_field_t
  use tubes_integrator, only: integrator_t, start_step, hermite
  use tubes_status, only: callback_status, TUBES_OK, TUBES_EINPUT, TUBES_ESTEP, TUBES_EMODEL
  implicit none
  private

  integer, parameter :: MSG_LEN = 256
  integer(c_int), parameter :: GSL_SUCCESS = 0, GSL_FAILURE = -1   ! gsl_errno.h

  !> What the C callbacks see (user_data): a private copy of the model and counters.
  type :: gsl_ctx_t
    class(vector_field_t), allocatable :: f   !! the model (copied at each (re)start)
    integer :: n = 0                          !! state dimension
    integer(i8) :: nfev = 0                   !! right-hand-side calls not yet harvested
    integer(i8) :: njev = 0                   !! Jacobian calls (rk4imp)
    integer :: model_stat = 0                 !! last nonzero status returned by the model
  end type gsl_ctx_t

  !> Memory of one instance (a pointer component: its address, passed to C, stays fixed).
  type :: gsl_mem_t
    type(gsl_ctx_t) :: ctx
    type(c_ptr) :: work = c_null_ptr              !! the shim's tubes_gsl_work
    integer(c_int) :: kind = 0                    !! 1 rk8pd, 2 rk4imp
    integer :: n = 0
    real(wp) :: dir = 0                           !! direction of integration since the start
    real(wp) :: h_next = 0                        !! step proposed by GSL for the next attempt
    real(wp) :: rtol = -1, atol = -1              !! tolerances the control currently has
    integer(c_long) :: failed0 = 0                !! failed attempts already counted
    real(c_double), allocatable :: y(:)           !! work copy of the state handed to GSL
    real(wp), allocatable :: x_old(:), f_old(:)   !! Hermite data at t_old
    real(wp), allocatable :: x_new(:), f_new(:)   !! Hermite data at t
  end type gsl_mem_t

  !> GSL odeiv2 stepper with y_new control and evolve (method names "gsl_rk8pd", "gsl_rk4imp").
  type, extends(integrator_t), public :: gsl_t
    character(len=16) :: kind = 'gsl_rk8pd'    !! 'gsl_rk8pd' or 'gsl_rk4imp'
    integer(i8) :: njev = 0                    !! Jacobian evaluations (rk4imp)
    integer :: solver_flag = 0                 !! GSL status of the last failure
    character(len=MSG_LEN) :: solver_msg = ''  !! gsl_strerror of it, and what tubes made of it
    type(gsl_mem_t), pointer, private :: mem => null()
  contains
    procedure :: step => gsl_step
    procedure :: interp => gsl_interp
    procedure :: destroy => gsl_destroy
    final :: gsl_final
  end type gsl_t

  interface
    type(c_ptr) function shim_alloc(kind, n, rhs, jac, user_data, atol, rtol) &
        bind(C, name='tubes_gsl_shim_alloc')
      import :: c_ptr, c_funptr, c_int, c_size_t, c_double
      integer(c_int), value :: kind
      integer(c_size_t), value :: n
      type(c_funptr), value :: rhs, jac
      type(c_ptr), value :: user_data
      real(c_double), value :: atol, rtol
    end function shim_alloc
    integer(c_int) function shim_reset(work, atol, rtol) bind(C, name='tubes_gsl_shim_reset')
      import :: c_ptr, c_int, c_double
      type(c_ptr), value :: work
      real(c_double), value :: atol, rtol
    end function shim_reset
    integer(c_int) function shim_set_tol(work, atol, rtol) &
        bind(C, name='tubes_gsl_shim_set_tol')
      import :: c_ptr, c_int, c_double
      type(c_ptr), value :: work
      real(c_double), value :: atol, rtol
    end function shim_set_tol
    integer(c_int) function shim_apply(work, t, t1, h, y) bind(C, name='tubes_gsl_shim_apply')
      import :: c_ptr, c_int, c_double
      type(c_ptr), value :: work
      real(c_double), intent(inout) :: t, h
      real(c_double), value :: t1
      real(c_double), intent(inout) :: y(*)
    end function shim_apply
    subroutine shim_derivs(work, f_start, f_end) bind(C, name='tubes_gsl_shim_derivs')
      import :: c_ptr, c_double
      type(c_ptr), value :: work
      real(c_double), intent(out) :: f_start(*), f_end(*)
    end subroutine shim_derivs
    subroutine shim_counts(work, count, failed) bind(C, name='tubes_gsl_shim_counts')
      import :: c_ptr, c_long
      type(c_ptr), value :: work
      integer(c_long), intent(out) :: count, failed
    end subroutine shim_counts
    subroutine shim_strerror(status, buf, len) bind(C, name='tubes_gsl_shim_strerror')
      import :: c_int, c_char
      integer(c_int), value :: status
      character(kind=c_char), intent(out) :: buf(*)
      integer(c_int), value :: len
    end subroutine shim_strerror
    subroutine shim_free(work) bind(C, name='tubes_gsl_shim_free')
      import :: c_ptr
      type(c_ptr), value :: work
    end subroutine shim_free
  end interface

contains

  ! ------------------------------------------------------------------ callbacks (C -> Fortran)

  !> f(t, y): 0 ok, 1 recoverable (smaller step), -1 fatal (model failure, NaN or Inf).
  integer(c_int) function gsl_rhs(t, y, dydt, user_data) result(ierr) &
      bind(C, name='')   ! no binding label: a callback, not part of the C API
    real(c_double), value :: t
    real(c_double), intent(in) :: y(*)
    real(c_double), intent(out) :: dydt(*)
    type(c_ptr), value :: user_data
    type(gsl_ctx_t), pointer :: ctx
    integer :: stat
    call c_f_pointer(user_data, ctx)
    ctx%nfev = ctx%nfev + 1
    call ctx%f%eval(t, y(1:ctx%n), dydt(1:ctx%n), stat)
    if (stat == 0 .and. .not. all(ieee_is_finite(dydt(1:ctx%n)))) stat = -1
    ierr = int(callback_status(ctx%model_stat, stat), c_int)
  end function gsl_rhs

  !> Jacobian for rk4imp's Newton iteration: dfdy row-major (C), i.e. the transpose of the
  !> model's column-major jac; dfdt = 0 (rk4imp does not use it).
  integer(c_int) function gsl_jac(t, y, dfdy, dfdt, user_data) result(ierr) &
      bind(C, name='')   ! no binding label: a callback, not part of the C API
    real(c_double), value :: t
    real(c_double), intent(in) :: y(*)
    real(c_double), intent(out) :: dfdy(*), dfdt(*)
    type(c_ptr), value :: user_data
    type(gsl_ctx_t), pointer :: ctx
    real(wp), allocatable :: jm(:, :)
    integer :: stat, n
    call c_f_pointer(user_data, ctx)
    n = ctx%n
    allocate (jm(n, n))
    ctx%njev = ctx%njev + 1
    call ctx%f%jacobian(t, y(1:n), jm, stat)
    if (stat == 0 .and. .not. all(ieee_is_finite(jm))) stat = -1
    if (stat == 0) dfdy(1:n*n) = reshape(transpose(jm), [n*n])
    dfdt(1:n) = 0
    ierr = int(callback_status(ctx%model_stat, stat), c_int)
  end function gsl_jac

  ! ------------------------------------------------------------------ stepping

  !> One gsl_odeiv2_evolve_apply from (t, x) towards tmax; a new start when fresh.
  subroutine gsl_step(self, x, tmax, stat)
    class(gsl_t), intent(inout) :: self
    real(wp), intent(inout) :: x(:)
    real(wp), intent(in) :: tmax
    integer, intent(out) :: stat
    real(c_double) :: t, h
    integer(c_int) :: flag
    integer(c_long) :: count, failed
    stat = TUBES_OK
    if (.not. (abs(tmax - self%t) > 0)) then   ! also rejects NaN
      stat = TUBES_EINPUT
      return
    end if
    if (restart_needed(self, size(x), tmax)) then
      call gsl_start(self, x, tmax, stat)
      if (stat /= TUBES_OK) return
    end if
    associate (m => self%mem)
      if (self%rtol /= m%rtol .or. self%atol /= m%atol) then
        flag = shim_set_tol(m%work, self%atol, self%rtol)
        if (flag /= GSL_SUCCESS) then
          call gsl_fail(self, flag, TUBES_EINPUT, stat)
          return
        end if
        m%rtol = self%rtol
        m%atol = self%atol
      end if
      m%y = x
      t = self%t
      h = m%dir*m%h_next
      m%ctx%model_stat = 0
      flag = shim_apply(m%work, t, tmax, h, m%y)
      self%nfev = self%nfev + m%ctx%nfev
      self%njev = self%njev + m%ctx%njev
      m%ctx%nfev = 0
      m%ctx%njev = 0
      call shim_counts(m%work, count, failed)
      self%nrejected = self%nrejected + (failed - m%failed0)
      m%failed0 = failed
      if (flag /= GSL_SUCCESS) then
        if (m%ctx%model_stat < 0) then
          call gsl_fail(self, flag, TUBES_EMODEL, stat, 'the model failed (status < 0)')
        else if (m%ctx%model_stat > 0) then
          call gsl_fail(self, flag, TUBES_ESTEP, stat, 'the model refused every trial '// &
                        'state (status > 0) down to a roundoff-size step')
        else
          call gsl_fail(self, flag, TUBES_ESTEP, stat, 'the step fails (error test, or '// &
                        'the Newton iteration of rk4imp) down to a roundoff-size step')
        end if
        return
      end if
      if (.not. all(ieee_is_finite(m%y))) then
        call gsl_fail(self, GSL_SUCCESS, TUBES_EMODEL, stat, &
                      'the step produced a non-finite state')
        return
      end if
      m%x_old = x
      m%x_new = m%y
      call shim_derivs(m%work, m%f_old, m%f_new)
      if (abs(h) > 0) m%h_next = abs(h)   ! unchanged on the last step to tmax (GSL keeps h)
      self%t_old = self%t
      self%t = t
      x = m%y
      self%nsteps = self%nsteps + 1
    end associate
  end subroutine gsl_step

  !> The GSL objects must be (re)started: fresh, none yet, or another n, kind or direction.
  logical function restart_needed(self, n, tmax)
    class(gsl_t), intent(in) :: self
    integer, intent(in) :: n
    real(wp), intent(in) :: tmax
    restart_needed = self%fresh .or. .not. associated(self%mem)
    if (restart_needed) return
    restart_needed = self%mem%n /= n .or. self%mem%kind /= kind_code(self%kind) .or. &
                     self%mem%dir /= sign(1.0_wp, tmax - self%t)
  end function restart_needed

  pure integer(c_int) function kind_code(kind)
    character(*), intent(in) :: kind
    select case (kind)
    case ('gsl_rk8pd');  kind_code = 1
    case ('gsl_rk4imp'); kind_code = 2
    case default;        kind_code = 0
    end select
  end function kind_code

  pure integer function method_order(kind)
    integer(c_int), intent(in) :: kind
    method_order = merge(8, 4, kind == 1)
  end function method_order

  !> Create (or reset) the GSL objects at (self%t, x) and choose the first step.
  subroutine gsl_start(self, x, tmax, stat)
    class(gsl_t), intent(inout) :: self
    real(wp), intent(in) :: x(:)
    real(wp), intent(in) :: tmax
    integer, intent(out) :: stat
    integer(c_int) :: flag, kind
    integer :: n
    stat = TUBES_OK
    if (self%nsteps == 0 .and. self%nfev == 0) then   ! counters reset by init: ours too
      self%njev = 0
      self%solver_flag = 0
      self%solver_msg = ''
    end if
    n = size(x)
    kind = kind_code(self%kind)
    if (kind == 0 .or. n < 1) then
      stat = TUBES_EINPUT
      self%solver_flag = 0
      self%solver_msg = 'gsl_t%kind must be ''gsl_rk8pd'' or ''gsl_rk4imp'''
      return
    end if
    if (associated(self%mem)) then
      if (self%mem%n /= n .or. self%mem%kind /= kind) call gsl_destroy(self)
    end if
    if (.not. associated(self%mem)) then
      allocate (self%mem)
      associate (m => self%mem)
        m%kind = kind
        m%n = n
        m%ctx%n = n
        allocate (m%y(n), m%x_old(n), m%f_old(n), m%x_new(n), m%f_new(n))
        m%work = shim_alloc(kind, int(n, c_size_t), c_funloc(gsl_rhs), c_funloc(gsl_jac), &
                            c_loc(m%ctx), self%atol, self%rtol)
        if (.not. c_associated(m%work)) then
          call gsl_destroy(self)
          stat = TUBES_EINPUT
          self%solver_flag = 0
          self%solver_msg = 'GSL could not create the stepper (negative tolerance?)'
          return
        end if
        flag = GSL_SUCCESS
      end associate
    else
      flag = shim_reset(self%mem%work, self%atol, self%rtol)
    end if
    associate (m => self%mem)
      if (flag /= GSL_SUCCESS) then
        call gsl_fail(self, flag, TUBES_EINPUT, stat)
        return
      end if
      if (allocated(m%ctx%f)) deallocate (m%ctx%f)
      allocate (m%ctx%f, source=self%f)
      m%ctx%nfev = 0
      m%ctx%njev = 0
      m%ctx%model_stat = 0
      m%rtol = self%rtol
      m%atol = self%atol
      m%failed0 = 0
      m%dir = sign(1.0_wp, tmax - self%t)
      if (self%h > 0) then
        m%h_next = self%h
      else
        call initial_step(m, self%t, x, m%dir, self%rtol, self%atol, m%h_next, stat)
        self%nfev = self%nfev + m%ctx%nfev
        m%ctx%nfev = 0
        if (stat /= TUBES_OK) then
          self%solver_flag = 0
          self%solver_msg = 'the model failed at the initial state'
          return
        end if
      end if
    end associate
    self%fresh = .false.
  end subroutine gsl_start

  !> Hairer's starting step (Solving ODEs I, II.4) for a method of order p: from |x|, |f| and
  !> one trial Euler step; two evaluations of f (counted in ctx%nfev).
  subroutine initial_step(m, t, x, dir, rtol, atol, h0, stat)
    type(gsl_mem_t), intent(inout) :: m
    real(wp), intent(in) :: t, x(:), dir, rtol, atol
    real(wp), intent(out) :: h0
    integer, intent(out) :: stat
    real(wp) :: f0(size(x))
    integer :: p
    p = method_order(m%kind)
    call m%ctx%f%eval(t, x, f0, stat)
    m%ctx%nfev = m%ctx%nfev + 1
    if (stat /= 0 .or. .not. all(ieee_is_finite(f0))) then
      stat = TUBES_EMODEL
      return
    end if
    stat = TUBES_OK
    call start_step(m%ctx%f, t, x, f0, dir, rtol, atol, p, h0, m%ctx%nfev)
  end subroutine initial_step

  !> Record a failure: GSL's status and its text (plus what tubes made of it), the TUBES code.
  subroutine gsl_fail(self, flag, code, stat, why)
    class(gsl_t), intent(inout) :: self
    integer(c_int), intent(in) :: flag       !! GSL status
    integer, intent(in) :: code              !! TUBES_* code
    integer, intent(out) :: stat
    character(*), intent(in), optional :: why
    character(kind=c_char) :: buf(MSG_LEN)
    character(len=MSG_LEN) :: text
    stat = code
    self%solver_flag = flag
    call shim_strerror(flag, buf, int(MSG_LEN, c_int))
    text = c_to_f(buf)
    if (present(why) .and. flag == GSL_SUCCESS) then
      self%solver_msg = why
    else if (present(why)) then
      self%solver_msg = trim(text)//': '//why
    else
      self%solver_msg = text
    end if
    self%fresh = .true.   ! restart from the last accepted (t, x) if stepping resumes
  end subroutine gsl_fail

  !> Cubic Hermite interpolant on [t_old, t] (Hairer's form, Solving ODEs I, II.6).
  subroutine gsl_interp(self, s, xs)
    class(gsl_t), intent(inout) :: self
    real(wp), intent(in) :: s
    real(wp), intent(out) :: xs(:)
    if (.not. associated(self%mem) .or. self%nsteps == 0 .or. self%t == self%t_old) then
      xs = ieee_value(1.0_wp, ieee_quiet_nan)
      return
    end if
    associate (m => self%mem)
      call hermite(m%x_old, m%f_old, m%x_new, m%f_new, self%t_old, self%t - self%t_old, s, xs)
    end associate
  end subroutine gsl_interp

  !> Free all GSL memory; the instance can be initialised and used again.
  subroutine gsl_destroy(self)
    class(gsl_t), intent(inout) :: self
    if (.not. associated(self%mem)) return
    if (c_associated(self%mem%work)) call shim_free(self%mem%work)
    deallocate (self%mem)
    self%fresh = .true.
  end subroutine gsl_destroy

  !> Finalizer: destroy.
  subroutine gsl_final(self)
    type(gsl_t), intent(inout) :: self
    call gsl_destroy(self)
  end subroutine gsl_final
end module tubes_gsl
