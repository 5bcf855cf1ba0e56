!> SUNDIALS 6.4 backends of integrator_t, through the F2003 interfaces (no C shim):
!>   cvode_t  ("cvode_adams"): CVODE, variable-order Adams-Moulton (orders 1..12, nonstiff);
!>            fixed-point corrector by default, or Newton with the dense linear solver and the
!>            model's Jacobian (nonlinear = 'newton'); measured choice in
!>            docs/integrators-backends.md.
!>   arkode_t ("arkode_erk8"): ARKODE ERKStep with the ARKODE_FEHLBERG_13_7_8 table (padded
!>            with one inert stage to avoid a SUNDIALS 6.4.1 bug: set_fehlberg_table).
!> step is one internal step of the solver in one-step mode with the stop time at tmax, so it
!> never passes tmax and lands on it. interp is the solver's own dense output: CVodeGetDky (the
!> Nordsieck polynomial of the current order) or ERKStepGetDky (ARKODE's Hermite interpolant of
!> degree interp_degree). h > 0 is taken as the first step to try, not as a fixed step. Each
!> instance owns its SUNContext, vectors and solver memory, and the C callbacks reach the
!> model through a context passed as user_data (no module state), so instances are
!> independent: two may run at once in different threads. Free the memory with destroy (the
!> final procedure does it as well). An instance that holds solver memory must not be copied
!> (the copy would share the C handles): copy before the first step, or destroy first.
module tubes_sundials
  use, intrinsic :: iso_c_binding, only: c_int, c_long, c_int64_t, c_double, c_char, c_ptr, &
                                         c_null_ptr, c_loc, c_funloc, c_f_pointer, &
                                         c_associated
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan, ieee_is_finite
  use tubes_kinds, only: wp, i8
  use tubes_cstrings, only: c_to_f
  use tubes_field, only: vector_field_t
  use tubes_integrator, only: integrator_t, start_step
  use tubes_status, only: callback_status, TUBES_OK, TUBES_EINPUT, TUBES_ESTEP, TUBES_EMODEL, TUBES_ENOCONV
  use fsundials_context_mod, only: FSUNContext_Create, FSUNContext_Free
  use fsundials_nvector_mod, only: N_Vector, FN_VGetArrayPointer, FN_VDestroy
  use fsundials_matrix_mod, only: SUNMatrix, FSUNMatDestroy
  use fsundials_linearsolver_mod, only: SUNLinearSolver, FSUNLinSolFree
  use fsundials_nonlinearsolver_mod, only: SUNNonlinearSolver, FSUNNonlinSolFree
  use fnvector_serial_mod, only: FN_VNew_Serial
  use fsunmatrix_dense_mod, only: FSUNDenseMatrix, FSUNDenseMatrix_Data
  use fsunlinsol_dense_mod, only: FSUNLinSol_Dense
  use fsunnonlinsol_fixedpoint_mod, only: FSUNNonlinSol_FixedPoint
  use fcvode_mod, only: CV_ADAMS, CV_ONE_STEP, CV_TOO_MUCH_WORK, CV_TOO_MUCH_ACC, &
                        CV_ERR_FAILURE, CV_CONV_FAILURE, CV_LSETUP_FAIL, CV_LSOLVE_FAIL, &
                        CV_RHSFUNC_FAIL, CV_FIRST_RHSFUNC_ERR, CV_REPTD_RHSFUNC_ERR, &
                        CV_UNREC_RHSFUNC_ERR, CV_NLS_FAIL, CV_TOO_CLOSE, &
                        FCVodeCreate, FCVodeInit, FCVodeReInit, FCVodeSStolerances, &
                        FCVodeSetUserData, FCVodeSetErrHandlerFn, FCVodeSetNonlinearSolver, &
                        FCVodeSetLinearSolver, FCVodeSetJacFn, FCVodeSetStopTime, &
                        FCVodeSetInitStep, FCVode, FCVodeGetDky, FCVodeGetNumErrTestFails, &
                        FCVodeGetNumStepSolveFails, FCVodeGetNumNonlinSolvIters, &
                        FCVodeGetNumRhsEvals, FCVodeFree
  use farkode_mod, only: ARK_ONE_STEP, ARKODE_FEHLBERG_13_7_8, FARKodeButcherTable_LoadERK, &
                         FARKodeButcherTable_Create, FARKodeButcherTable_Free
  use farkode_erkstep_mod, only: FERKStepCreate, FERKStepReInit, &
                                 FERKStepSetTable, FERKStepSStolerances, FERKStepSetUserData, &
                                 FERKStepSetErrHandlerFn, FERKStepSetStopTime, &
                                 FERKStepSetInitStep, FERKStepSetInterpolantDegree, &
                                 FERKStepEvolve, FERKStepGetDky, FERKStepGetNumErrTestFails, &
                                 FERKStepGetNumRhsEvals, FERKStepFree
  implicit none
  private

  integer, parameter :: MSG_LEN = 256
  integer, parameter :: KIND_CVODE = 1, KIND_ARKODE = 2

  !> What the C callbacks see (user_data): a private copy of the model and counters.
  type :: rhs_ctx_t
    class(vector_field_t), allocatable :: f   !! the model (copied at each (re)start)
    integer :: n = 0                          !! state dimension
    integer(i8) :: nfev = 0                   !! right-hand-side calls not yet harvested
    integer(i8) :: njev = 0                   !! Jacobian calls (Newton only)
    integer :: model_stat = 0                 !! last nonzero status returned by the model
    character(len=MSG_LEN) :: msg = ''        !! last message of the solver's error handler
  end type rhs_ctx_t

  !> Solver memory of one instance (a pointer component: its address, passed to C as
  !> user_data, stays fixed while the instance lives).
  type :: sun_mem_t
    type(rhs_ctx_t) :: ctx
    integer :: kind = 0                          !! KIND_CVODE or KIND_ARKODE
    logical :: newton = .false.                  !! CVODE: Newton corrector (else fixed point)
    integer :: interp_degree = -1                !! ARKODE: degree of the Hermite interpolant
    type(c_ptr) :: sunctx = c_null_ptr           !! SUNContext of this instance
    type(c_ptr) :: solver = c_null_ptr           !! cvode_mem / arkode_mem
    type(N_Vector), pointer :: y => null()       !! state vector handed to the solver
    type(N_Vector), pointer :: dky => null()     !! dense output
    type(SUNNonlinearSolver), pointer :: nls => null()
    type(SUNMatrix), pointer :: a => null()
    type(SUNLinearSolver), pointer :: ls => null()
    real(c_double), pointer :: yd(:) => null()   !! data of y
    real(c_double), pointer :: dkyd(:) => null() !! data of dky
    integer :: n = 0
    real(wp) :: dir = 0                          !! direction of integration since the start
    real(wp) :: rtol = -1, atol = -1             !! tolerances the solver currently has
    integer(c_long) :: nrej0 = 0, nni0 = 0       !! solver totals already added to the counters
    integer(i8) :: nsince = 0                    !! steps accepted since the last (re)start
    logical :: sliver = .false.                  !! last step was a roundoff-size sliver
  end type sun_mem_t

  !> struct ARKodeButcherTableMem (arkode/arkode_butcher.h), to read a loaded table.
  type, bind(C) :: butcher_mem_t
    integer(c_int) :: q, p, stages
    type(c_ptr) :: a, c, b, d   ! realtype **A (row pointers), *c, *b, *d
  end type butcher_mem_t

  !> What the two backends share: the solver memory, the last failure, one step in one-step mode,
  !> the dense output; the solver calls themselves are dispatched by the kind (below).
  type, extends(integrator_t), public :: sun_t
    integer :: solver_flag = 0                      !! the solver's return flag of the last failure
    character(len=MSG_LEN) :: solver_msg = ''       !! its name and the solver's own message
    type(sun_mem_t), pointer, private :: mem => null()
  contains
    procedure :: step => sun_step
    procedure :: interp => sun_interp
    procedure :: destroy => sun_destroy
    procedure :: solver_rhs_evals => sun_rhs_evals
  end type sun_t

  !> CVODE, Adams-Moulton (method name "cvode_adams").
  type, extends(sun_t), public :: cvode_t
    character(len=16) :: nonlinear = 'fixedpoint'   !! corrector: 'fixedpoint' or 'newton'
    integer(i8) :: njev = 0                         !! Jacobian evaluations (Newton only)
  contains
    final :: cvode_final
  end type cvode_t

  !> ARKODE ERKStep, Fehlberg 13-stage 8(7) (method name "arkode_erk8").
  type, extends(sun_t), public :: arkode_t
    integer :: interp_degree = 4                    !! degree of ARKODE's Hermite dense output,
                                                    !! 0..5 (4: 1 f-evaluation per interp call,
                                                    !! 5: 4; docs/integrators-backends.md)
  contains
    final :: arkode_final
  end type arkode_t

contains

  ! ------------------------------------------------------------------ callbacks (C -> Fortran)

  !> f(t, y) for CVODE and ARKODE. 0 ok, 1 recoverable (the model asked for a smaller step),
  !> -1 fatal (the model failed, or returned NaN/Inf).
  integer(c_int) function sun_rhs(t, y, ydot, user_data) result(ierr) &
      bind(C, name='')   ! no binding label: a callback, not part of the C API
    real(c_double), value :: t
    type(N_Vector) :: y, ydot
    type(c_ptr), value :: user_data
    type(rhs_ctx_t), pointer :: ctx
    real(c_double), pointer :: yv(:), fv(:)
    integer :: stat
    call c_f_pointer(user_data, ctx)
    yv => FN_VGetArrayPointer(y)
    fv => FN_VGetArrayPointer(ydot)
    ctx%nfev = ctx%nfev + 1
    call ctx%f%eval(t, yv, fv, stat)
    if (stat == 0 .and. .not. all(ieee_is_finite(fv))) stat = -1
    ierr = int(callback_status(ctx%model_stat, stat), c_int)
  end function sun_rhs

  !> Dense Jacobian df/dy for CVODE's Newton corrector, from the model's jacobian.
  integer(c_int) function sun_jac(t, y, fy, jac, user_data, tmp1, tmp2, tmp3) result(ierr) &
      bind(C, name='')
    real(c_double), value :: t
    type(N_Vector) :: y, fy, tmp1, tmp2, tmp3
    type(SUNMatrix) :: jac
    type(c_ptr), value :: user_data
    type(rhs_ctx_t), pointer :: ctx
    real(c_double), pointer :: yv(:), jd1(:), jd(:, :)
    integer :: stat
    call c_f_pointer(user_data, ctx)
    yv => FN_VGetArrayPointer(y)
    ! SUNDIALS 6.4.1's FSUNDenseMatrix_Data returns a pointer of extent 1 (not n*n): take the
    ! address of the column-major n x n data and give it its shape here
    jd1 => FSUNDenseMatrix_Data(jac)
    call c_f_pointer(c_loc(jd1(1)), jd, [ctx%n, ctx%n])
    ctx%njev = ctx%njev + 1
    call ctx%f%jacobian(t, yv, jd, stat)
    if (stat == 0 .and. .not. all(ieee_is_finite(jd))) stat = -1
    ierr = int(callback_status(ctx%model_stat, stat), c_int)
  end function sun_jac

  !> Error handler: keeps "module:function: message" instead of printing it.
  subroutine sun_err(error_code, module, function, msg, user_data) bind(C, name='')
    integer(c_int), value :: error_code
    character(kind=c_char), intent(in) :: module(*), function(*), msg(*)
    type(c_ptr), value :: user_data
    type(rhs_ctx_t), pointer :: ctx
    call c_f_pointer(user_data, ctx)
    ctx%msg = c_to_f(module(1:MSG_LEN)) // ':' // c_to_f(function(1:MSG_LEN)) // ': ' // &
              c_to_f(msg(1:MSG_LEN))
  end subroutine sun_err

  ! ------------------------------------------------------------------ CVODE

  !> Create (or re-initialise) CVODE at (self%t, x).
  subroutine cvode_start(self, x, tmax, stat)
    class(cvode_t), intent(inout) :: self
    real(wp), intent(in) :: x(:)
    real(wp), intent(in) :: tmax
    integer, intent(out) :: stat
    integer(c_int) :: flag
    type(sun_mem_t), pointer :: m
    logical :: created
    stat = TUBES_OK
    if (self%nsteps == 0 .and. self%nfev == 0) self%njev = 0   ! counters reset by init: ours too
    if (self%nonlinear /= 'fixedpoint' .and. self%nonlinear /= 'newton') then
      stat = TUBES_EINPUT
      self%solver_flag = 0
      self%solver_msg = 'cvode_t%nonlinear must be ''fixedpoint'' or ''newton'''
      return
    end if
    call sun_prepare(self, x, tmax, KIND_CVODE, created, stat)
    if (stat /= TUBES_OK) return
    m => self%mem
    if (created) then
      m%newton = self%nonlinear == 'newton'
      m%solver = FCVodeCreate(CV_ADAMS, m%sunctx)
      call sun_created(self, 'CVodeCreate', stat)
      if (stat /= TUBES_OK) return
      flag = FCVodeInit(m%solver, c_funloc(sun_rhs), self%t, m%y)
      if (flag >= 0) flag = FCVodeSetUserData(m%solver, c_loc(m%ctx))
      if (flag >= 0) flag = FCVodeSetErrHandlerFn(m%solver, c_funloc(sun_err), c_loc(m%ctx))
      if (flag >= 0) then
        if (m%newton) then
          m%a => FSUNDenseMatrix(int(m%n, c_int64_t), int(m%n, c_int64_t), m%sunctx)
          m%ls => FSUNLinSol_Dense(m%y, m%a, m%sunctx)
          flag = FCVodeSetLinearSolver(m%solver, m%ls, m%a)
          if (flag >= 0) flag = FCVodeSetJacFn(m%solver, c_funloc(sun_jac))
        else
          m%nls => FSUNNonlinSol_FixedPoint(m%y, 0_c_int, m%sunctx)
          flag = FCVodeSetNonlinearSolver(m%solver, m%nls)
        end if
      end if
    else
      flag = FCVodeReInit(m%solver, self%t, m%y)
    end if
    if (flag >= 0) flag = FCVodeSStolerances(m%solver, self%rtol, self%atol)
    if (flag >= 0) flag = FCVodeSetInitStep(m%solver, m%dir*max(self%h, 0.0_wp))
    call sun_started(self, flag, stat)
  end subroutine cvode_start

  !> Finalizer: destroy.
  subroutine cvode_final(self)
    type(cvode_t), intent(inout) :: self
    call sun_destroy(self)
  end subroutine cvode_final

  ! ------------------------------------------------------------------ ARKODE ERKStep

  !> Create (or re-initialise) ERKStep at (self%t, x) and choose the first step.
  subroutine arkode_start(self, x, tmax, stat)
    class(arkode_t), intent(inout) :: self
    real(wp), intent(in) :: x(:)
    real(wp), intent(in) :: tmax
    integer, intent(out) :: stat
    real(wp) :: h0
    integer(c_int) :: flag
    type(sun_mem_t), pointer :: m
    logical :: created
    call sun_prepare(self, x, tmax, KIND_ARKODE, created, stat)
    if (stat /= TUBES_OK) return
    m => self%mem
    if (created) then
      m%solver = FERKStepCreate(c_funloc(sun_rhs), self%t, m%y, m%sunctx)
      call sun_created(self, 'ERKStepCreate', stat)
      if (stat /= TUBES_OK) return
      flag = FERKStepSetErrHandlerFn(m%solver, c_funloc(sun_err), c_loc(m%ctx))
      if (flag >= 0) flag = FERKStepSetUserData(m%solver, c_loc(m%ctx))
      if (flag >= 0) call set_fehlberg_table(m%solver, flag)
      m%interp_degree = self%interp_degree
      if (flag >= 0) flag = FERKStepSetInterpolantDegree(m%solver, &
                                                         int(self%interp_degree, c_int))
    else
      flag = FERKStepReInit(m%solver, c_funloc(sun_rhs), self%t, m%y)
    end if
    if (flag >= 0) flag = FERKStepSStolerances(m%solver, self%rtol, self%atol)
    if (self%h > 0) then
      h0 = self%h
    else
      call initial_step(m%ctx, self%t, x, m%dir, self%rtol, self%atol, 8, h0, stat)
      if (stat /= TUBES_OK) then
        call sun_harvest(self)
        self%solver_flag = 0
        self%solver_msg = 'the model failed at the initial state'
        self%fresh = .true.
        return
      end if
    end if
    if (flag >= 0) flag = FERKStepSetInitStep(m%solver, m%dir*h0)
    call sun_started(self, flag, stat)
  end subroutine arkode_start

  !> Finalizer: destroy.
  subroutine arkode_final(self)
    type(arkode_t), intent(inout) :: self
    call sun_destroy(self)
  end subroutine arkode_final

  ! ------------------------------------------------------------------ shared pieces

  !> One internal step of the solver (one-step mode, stop time tmax) from (t, x); a new start
  !> when fresh.
  subroutine sun_step(self, x, tmax, stat)
    class(sun_t), intent(inout) :: self
    real(wp), intent(inout) :: x(:)
    real(wp), intent(in) :: tmax
    integer, intent(out) :: stat
    real(c_double) :: tret(1)
    integer(c_int) :: flag
    logical :: restart, reuse
    integer :: kind
    select type (self)
    type is (cvode_t)
      kind = KIND_CVODE
    class default
      kind = KIND_ARKODE
    end select
    call begin_step(self%mem, self%fresh, self%t, tmax, size(x), kind, restart, stat)
    if (stat /= TUBES_OK) return
    if (restart) then
      if (associated(self%mem)) then   ! the solver memory cannot be reused for these
        reuse = self%mem%n == size(x)
        select type (self)
        type is (cvode_t)
          reuse = reuse .and. (self%mem%newton .eqv. (self%nonlinear == 'newton'))
        type is (arkode_t)
          reuse = reuse .and. self%mem%interp_degree == self%interp_degree
        end select
        if (.not. reuse) call sun_destroy(self)
      end if
      select type (self)
      type is (cvode_t)
        call cvode_start(self, x, tmax, stat)
      type is (arkode_t)
        call arkode_start(self, x, tmax, stat)
      end select
      if (stat /= TUBES_OK) return
    end if
    if (sliver(self%mem, self%t, tmax)) then
      call take_sliver(self%mem, self%t_old, self%t, self%nsteps, self%fresh, tmax)
      return
    end if
    if (self%rtol /= self%mem%rtol .or. self%atol /= self%mem%atol) then
      if (kind == KIND_CVODE) then
        flag = FCVodeSStolerances(self%mem%solver, self%rtol, self%atol)
      else
        flag = FERKStepSStolerances(self%mem%solver, self%rtol, self%atol)
      end if
      if (flag < 0) then
        call sun_fail(self, flag, stat)
        return
      end if
      self%mem%rtol = self%rtol
      self%mem%atol = self%atol
    end if
    self%mem%ctx%model_stat = 0
    select type (self)
    type is (cvode_t)
      flag = FCVodeSetStopTime(self%mem%solver, tmax)
      if (flag >= 0) flag = FCVode(self%mem%solver, tmax, self%mem%y, tret, CV_ONE_STEP)
      call sun_harvest(self)
      if (flag >= 0 .and. self%mem%ctx%model_stat < 0) then
        ! The model failed (stat < 0) at a trial state, yet CVODE went on: its fixed-point
        ! corrector (SUNDIALS 6.4.1) treats any failure of f inside the iteration as a
        ! convergence failure and retries with a smaller step, so a model that fails past some
        ! point makes the steps shrink towards it forever. tubes stops at the first fatal
        ! status, as DOP853 does; the step CVODE took is not accepted.
        flag = CV_RHSFUNC_FAIL
        self%mem%ctx%msg = 'the model returned a fatal status (< 0) inside the corrector '// &
                           'iteration; CVODE retried with a smaller step, tubes stops'
      end if
    type is (arkode_t)
      flag = FERKStepSetStopTime(self%mem%solver, tmax)
      if (flag >= 0) flag = FERKStepEvolve(self%mem%solver, tmax, self%mem%y, tret, ARK_ONE_STEP)
      call sun_harvest(self)
      if (flag >= 0 .and. self%mem%ctx%model_stat < 0) then   ! as with CVODE
        flag = -8   ! ARK_RHSFUNC_FAIL
        self%mem%ctx%msg = 'the model returned a fatal status (< 0); ARKODE went on, tubes stops'
      end if
    end select
    if (flag < 0) then
      call sun_fail(self, flag, stat)
      return
    end if
    call accept(self%mem, self%t_old, self%t, self%nsteps, x, tret(1), self%fresh, stat)
    if (stat /= TUBES_OK) then
      self%solver_flag = 0
      self%solver_msg = 'the solver returned a non-finite state'
    end if
  end subroutine sun_step

  !> The failure of flag: the flag kept, with its name and the solver's message, and mapped to
  !> a TUBES_* code; stepping, if it resumes, restarts from the last accepted (t, x).
  subroutine sun_fail(self, flag, stat)
    class(sun_t), intent(inout) :: self
    integer(c_int), intent(in) :: flag
    integer, intent(out) :: stat
    self%solver_flag = flag
    select type (self)
    type is (cvode_t)
      self%solver_msg = flag_name('CV', flag)//': '//trim(self%mem%ctx%msg)
      select case (flag)
      case (CV_RHSFUNC_FAIL, CV_FIRST_RHSFUNC_ERR, CV_REPTD_RHSFUNC_ERR, CV_UNREC_RHSFUNC_ERR)
        stat = TUBES_EMODEL
      case (CV_LSETUP_FAIL, CV_LSOLVE_FAIL)   ! the Jacobian callback failed, or a singular matrix
        stat = merge(TUBES_EMODEL, TUBES_ENOCONV, self%mem%ctx%model_stat < 0)
      case (CV_CONV_FAILURE, CV_NLS_FAIL)
        stat = TUBES_ENOCONV
      case (CV_ERR_FAILURE, CV_TOO_MUCH_ACC, CV_TOO_MUCH_WORK, CV_TOO_CLOSE)
        stat = TUBES_ESTEP
      case default                            ! illegal input, memory: setup problems
        stat = TUBES_EINPUT
      end select
    class default
      self%solver_msg = flag_name('ARK', flag)//': '//trim(self%mem%ctx%msg)
      ! ARKODE uses CVODE's numbering for these (arkode.h): -8..-11 right-hand side failures,
      ! -1 too much work, -2 too much accuracy, -3 error test failures, -27 too close
      select case (flag)
      case (-11:-8)
        stat = TUBES_EMODEL
      case (-3:-1, -27)
        stat = TUBES_ESTEP
      case default
        stat = TUBES_EINPUT
      end select
      if (self%mem%ctx%model_stat < 0) stat = TUBES_EMODEL
    end select
    self%fresh = .true.
  end subroutine sun_fail

  !> Move the evaluation counts and the solver's statistics (CVODE: error-test and corrector
  !> failures, corrector iterations; ERKStep: error-test failures) into the integrator's counters.
  subroutine sun_harvest(self)
    class(sun_t), intent(inout) :: self
    integer(c_long) :: netf(1), nsf(1), nni(1)
    integer(c_int) :: flag
    self%nfev = self%nfev + self%mem%ctx%nfev
    self%mem%ctx%nfev = 0
    select type (self)
    type is (cvode_t)
      self%njev = self%njev + self%mem%ctx%njev
      self%mem%ctx%njev = 0
      flag = FCVodeGetNumErrTestFails(self%mem%solver, netf)
      flag = FCVodeGetNumStepSolveFails(self%mem%solver, nsf)
      flag = FCVodeGetNumNonlinSolvIters(self%mem%solver, nni)
      self%nrejected = self%nrejected + (netf(1) + nsf(1) - self%mem%nrej0)
      self%niter = self%niter + (nni(1) - self%mem%nni0)
      self%mem%nrej0 = netf(1) + nsf(1)
      self%mem%nni0 = nni(1)
    class default
      flag = FERKStepGetNumErrTestFails(self%mem%solver, netf)
      self%nrejected = self%nrejected + (netf(1) - self%mem%nrej0)
      self%mem%nrej0 = netf(1)
    end select
  end subroutine sun_harvest

  !> After the solver's Create call (what): if it returned no memory, stat = TUBES_EINPUT and
  !> the instance's memory destroyed.
  subroutine sun_created(self, what, stat)
    class(sun_t), intent(inout) :: self
    character(*), intent(in) :: what
    integer, intent(out) :: stat
    stat = TUBES_OK
    if (c_associated(self%mem%solver)) return
    call sun_destroy(self)
    stat = TUBES_EINPUT
    self%solver_msg = what // ' failed'
  end subroutine sun_created

  !> The end of a (re)start: the failure of flag if it is one, else the tolerances the solver now
  !> has, its totals counted from zero, and the counters of the new start harvested (zero after
  !> Init/ReInit).
  subroutine sun_started(self, flag, stat)
    class(sun_t), intent(inout) :: self
    integer(c_int), intent(in) :: flag
    integer, intent(out) :: stat
    if (flag < 0) then
      call sun_fail(self, flag, stat)
      return
    end if
    stat = TUBES_OK
    self%mem%rtol = self%rtol
    self%mem%atol = self%atol
    self%mem%nrej0 = 0
    self%mem%nni0 = 0
    call sun_harvest(self)
    self%fresh = .false.
  end subroutine sun_started

  !> The solver's dense output on [t_old, t] (CVodeGetDky: the Nordsieck polynomial;
  !> ERKStepGetDky: the Hermite interpolant, which may evaluate f); NaN outside: never
  !> extrapolates.
  subroutine sun_interp(self, s, xs)
    class(sun_t), intent(inout) :: self
    real(wp), intent(in) :: s
    real(wp), intent(out) :: xs(:)
    integer(c_int) :: flag
    if (.not. associated(self%mem)) then
      xs = ieee_value(1.0_wp, ieee_quiet_nan)
    else if (self%mem%sliver) then
      xs = self%mem%yd
    else
      if (self%mem%kind == KIND_CVODE) then
        flag = FCVodeGetDky(self%mem%solver, s, 0_c_int, self%mem%dky)
      else
        flag = FERKStepGetDky(self%mem%solver, s, 0_c_int, self%mem%dky)
        self%nfev = self%nfev + self%mem%ctx%nfev     ! the interpolant's evaluations
        self%mem%ctx%nfev = 0
      end if
      if (flag < 0) then
        xs = ieee_value(1.0_wp, ieee_quiet_nan)
      else
        xs = self%mem%dkyd
      end if
    end if
  end subroutine sun_interp

  !> Right-hand-side evaluations the solver itself counted since its last (re)start.
  integer(i8) function sun_rhs_evals(self) result(nfe)
    class(sun_t), intent(in) :: self
    integer(c_long) :: n(1)
    integer(c_int) :: flag
    nfe = -1
    if (.not. associated(self%mem)) return
    if (self%mem%kind == KIND_CVODE) then
      flag = FCVodeGetNumRhsEvals(self%mem%solver, n)
    else
      flag = FERKStepGetNumRhsEvals(self%mem%solver, n)
    end if
    if (flag >= 0) nfe = n(1)
  end function sun_rhs_evals

  !> Free all solver memory; the instance can be initialised and used again.
  subroutine sun_destroy(self)
    class(sun_t), intent(inout) :: self
    if (.not. associated(self%mem)) return
    if (c_associated(self%mem%solver)) then
      if (self%mem%kind == KIND_CVODE) then
        call FCVodeFree(self%mem%solver)
      else
        call FERKStepFree(self%mem%solver)
      end if
    end if
    call free_mem(self%mem)
    self%fresh = .true.
  end subroutine sun_destroy

  !> Name of a CVODE (prefix 'CV') or ARKODE ('ARK') return flag; the two number their
  !> common failures alike (cvode.h, arkode.h). (C*GetReturnFlagName would do, but through
  !> the F2003 interface of SUNDIALS 6.4.1 every call leaks the C string.)
  pure function flag_name(prefix, flag) result(name)
    character(*), intent(in) :: prefix
    integer(c_int), intent(in) :: flag
    character(:), allocatable :: name
    character(12) :: num
    select case (flag)
    case (-1); name = prefix//'_TOO_MUCH_WORK'
    case (-2); name = prefix//'_TOO_MUCH_ACC'
    case (-3); name = prefix//'_ERR_FAILURE'
    case (-4); name = prefix//'_CONV_FAILURE'
    case (-5); name = prefix//'_LINIT_FAIL'
    case (-6); name = prefix//'_LSETUP_FAIL'
    case (-7); name = prefix//'_LSOLVE_FAIL'
    case (-8); name = prefix//'_RHSFUNC_FAIL'
    case (-9); name = prefix//'_FIRST_RHSFUNC_ERR'
    case (-10); name = prefix//'_REPTD_RHSFUNC_ERR'
    case (-11); name = prefix//'_UNREC_RHSFUNC_ERR'
    case (-16)
      if (prefix == 'CV') then
        name = 'CV_NLS_FAIL'
      else
        name = prefix//'_MASSSOLVE_FAIL'
      end if
    case (-20); name = prefix//'_MEM_FAIL'
    case (-21); name = prefix//'_MEM_NULL'
    case (-22); name = prefix//'_ILL_INPUT'
    case (-23); name = prefix//'_NO_MALLOC'
    case (-25); name = prefix//'_BAD_T'
    case (-27); name = prefix//'_TOO_CLOSE'
    case default
      write (num, '(i0)') flag
      name = prefix//' flag '//trim(num)
    end select
  end function flag_name

  !> Checks before a step; restart = the solver must be (re)initialised at (t, x).
  subroutine begin_step(mem, fresh, t, tmax, n, kind, restart, stat)
    type(sun_mem_t), pointer, intent(in) :: mem
    logical, intent(in) :: fresh
    real(wp), intent(in) :: t, tmax
    integer, intent(in) :: n, kind
    logical, intent(out) :: restart
    integer, intent(out) :: stat
    stat = TUBES_OK
    restart = fresh .or. .not. associated(mem)
    if (.not. (abs(tmax - t) > 0) .or. n < 1) then   ! also rejects NaN
      stat = TUBES_EINPUT
      return
    end if
    if (.not. restart) restart = mem%n /= n .or. mem%kind /= kind .or. &
                                 mem%dir /= sign(1.0_wp, tmax - t)
  end subroutine begin_step

  !> Allocate the context and vectors (created = .true.), or reuse them for a restart;
  !> in both cases load the model and x.
  !> The start both backends share: a new init (no step, no evaluation yet) clears the failure
  !> record; the solver memory is prepared at (self%t, x) (created: made now; else the solver
  !> is re-initialised by the caller). On failure the memory is destroyed and the record says why.
  subroutine sun_prepare(self, x, tmax, kind, created, stat)
    class(sun_t), intent(inout) :: self
    real(wp), intent(in) :: x(:), tmax
    integer, intent(in) :: kind               !! KIND_CVODE or KIND_ARKODE
    logical, intent(out) :: created
    integer, intent(out) :: stat
    if (self%nsteps == 0 .and. self%nfev == 0) then
      self%solver_flag = 0
      self%solver_msg = ''
    end if
    call prepare_mem(self%mem, self%f, x, tmax - self%t, kind, created, stat)
    if (stat /= TUBES_OK) then
      call sun_destroy(self)
      self%solver_flag = 0
      self%solver_msg = 'SUNDIALS could not allocate its context or vectors'
    end if
  end subroutine sun_prepare

  subroutine prepare_mem(mem, f, x, dt, kind, created, stat)
    type(sun_mem_t), pointer, intent(inout) :: mem
    class(vector_field_t), intent(in) :: f
    real(wp), intent(in) :: x(:), dt
    integer, intent(in) :: kind
    logical, intent(out) :: created
    integer, intent(out) :: stat
    integer(c_int) :: ierr
    stat = TUBES_OK
    created = .false.
    if (.not. associated(mem)) then   ! (the callers destroy memory of another n first)
      created = .true.
      allocate (mem)
      mem%kind = kind
      mem%n = size(x)
      ierr = FSUNContext_Create(c_null_ptr, mem%sunctx)
      if (ierr /= 0) then
        stat = TUBES_EINPUT
        return
      end if
      mem%y => FN_VNew_Serial(int(mem%n, c_int64_t), mem%sunctx)
      mem%dky => FN_VNew_Serial(int(mem%n, c_int64_t), mem%sunctx)
      if (.not. (associated(mem%y) .and. associated(mem%dky))) then
        stat = TUBES_EINPUT
        return
      end if
      mem%yd => FN_VGetArrayPointer(mem%y)
      mem%dkyd => FN_VGetArrayPointer(mem%dky)
    end if
    if (allocated(mem%ctx%f)) deallocate (mem%ctx%f)
    allocate (mem%ctx%f, source=f)
    mem%ctx%n = mem%n
    mem%ctx%nfev = 0
    mem%ctx%njev = 0
    mem%ctx%model_stat = 0
    mem%ctx%msg = ''
    mem%dir = sign(1.0_wp, dt)
    mem%sliver = .false.
    mem%nsince = 0
    mem%yd = x
  end subroutine prepare_mem

  !> Give ERKStep ARKODE_FEHLBERG_13_7_8 with one inert 14th stage appended (c = 0, zero row,
  !> zero weights b and d): the same method. Reason: SUNDIALS 6.4.1's ERKStep takes any table
  !> whose last node is c_s = 1 for first-same-as-last and reuses f of the last stage as
  !> f(y_n+1) (llnl/sundials#311, fixed by PR #324 in a later release). Fehlberg's table has
  !> c_13 = 1 but b /= A(13, :), so unpadded every step starts from a wrong first stage:
  !> measured on x'' = -x, the steps then differ from the Fehlberg map by up to 7e-8 at
  !> tol 1e-5 and their local error no longer scales like h^9. With c_14 = 0 ERKStep
  !> evaluates f(y_n+1) as it should; the price is one wasted evaluation (the inert stage):
  !> 14 per step instead of 13.
  subroutine set_fehlberg_table(solver, flag)
    type(c_ptr), intent(in) :: solver
    integer(c_int), intent(out) :: flag
    type(c_ptr) :: tab, padded
    type(butcher_mem_t), pointer :: bt
    type(c_ptr), pointer :: rows(:)
    real(c_double), pointer :: row(:), cv(:), bv(:), dv(:)
    real(c_double), allocatable :: a(:), c(:), b(:), d(:)
    integer :: s, i
    flag = -22   ! ARK_ILL_INPUT unless the table loads
    tab = FARKodeButcherTable_LoadERK(ARKODE_FEHLBERG_13_7_8)
    if (.not. c_associated(tab)) return
    call c_f_pointer(tab, bt)
    s = bt%stages
    allocate (a((s + 1)**2), c(s + 1), b(s + 1), d(s + 1))
    a = 0
    c = 0
    b = 0
    d = 0
    call c_f_pointer(bt%a, rows, [s])
    call c_f_pointer(bt%c, cv, [s])
    call c_f_pointer(bt%b, bv, [s])
    call c_f_pointer(bt%d, dv, [s])
    do i = 1, s
      call c_f_pointer(rows(i), row, [s])
      a((i - 1)*(s + 1) + 1:(i - 1)*(s + 1) + s) = row   ! row-major (s+1) x (s+1)
    end do
    c(1:s) = cv
    b(1:s) = bv
    d(1:s) = dv
    padded = FARKodeButcherTable_Create(int(s + 1, c_int), bt%q, bt%p, c, a, b, d)
    if (c_associated(padded)) then
      flag = FERKStepSetTable(solver, padded)   ! ERKStep keeps a copy
      call FARKodeButcherTable_Free(padded)
    end if
    call FARKodeButcherTable_Free(tab)
  end subroutine set_fehlberg_table

  !> Hairer's starting step (Solving ODEs I, II.4) for a method of order p, from |x|, |f| and
  !> one trial Euler step: two evaluations of f (counted in ctx%nfev). ARKODE's own estimate
  !> is far more cautious (3e-10 s on the oscillator at tol 1e-8, then 13 steps of growth by
  !> at most 5x), and tubes restarts the solver at every event.
  subroutine initial_step(ctx, t, x, dir, rtol, atol, p, h0, stat)
    type(rhs_ctx_t), intent(inout) :: ctx
    real(wp), intent(in) :: t, x(:), dir, rtol, atol
    integer, intent(in) :: p
    real(wp), intent(out) :: h0
    integer, intent(out) :: stat
    real(wp) :: f0(size(x))
    integer :: fs
    call ctx%f%eval(t, x, f0, fs)
    ctx%nfev = ctx%nfev + 1
    if (fs /= 0 .or. .not. all(ieee_is_finite(f0))) then
      stat = TUBES_EMODEL
      h0 = 0
      return
    end if
    stat = TUBES_OK
    call start_step(ctx%f, t, x, f0, dir, rtol, atol, p, h0, ctx%nfev)
  end subroutine initial_step

  !> Everything but the solver memory itself (freed by the caller first).
  subroutine free_mem(mem)
    type(sun_mem_t), pointer, intent(inout) :: mem
    integer(c_int) :: ierr
    if (associated(mem%nls)) ierr = FSUNNonlinSolFree(mem%nls)
    if (associated(mem%ls)) ierr = FSUNLinSolFree(mem%ls)
    if (associated(mem%a)) call FSUNMatDestroy(mem%a)
    if (associated(mem%y)) call FN_VDestroy(mem%y)
    if (associated(mem%dky)) call FN_VDestroy(mem%dky)
    if (c_associated(mem%sunctx)) ierr = FSUNContext_Free(mem%sunctx)
    deallocate (mem)
  end subroutine free_mem

  !> The first step after a (re)start whose length is at the roundoff level of t: the solvers
  !> refuse it (CV_TOO_CLOSE, ARK_TOO_CLOSE). x stays as it is (its change is below roundoff),
  !> and the solver restarts at the next step.
  logical function sliver(mem, t, tmax)
    type(sun_mem_t), intent(in) :: mem
    real(wp), intent(in) :: t, tmax
    sliver = mem%nsince == 0 .and. abs(tmax - t) <= 16*epsilon(1.0_wp)*max(abs(t), abs(tmax))
  end function sliver

  !> Take such a sliver step: t = tmax, x unchanged.
  subroutine take_sliver(mem, t_old, t, nsteps, fresh, tmax)
    type(sun_mem_t), intent(inout) :: mem
    real(wp), intent(inout) :: t_old, t
    integer(i8), intent(inout) :: nsteps
    logical, intent(out) :: fresh
    real(wp), intent(in) :: tmax
    mem%sliver = .true.   ! mem%yd holds x since the start: the dense output is that constant
    t_old = t
    t = tmax
    nsteps = nsteps + 1
    fresh = .true.
  end subroutine take_sliver

  !> Accept the solver's step: x, t_old, t, counters; refuse a non-finite state.
  subroutine accept(mem, t_old, t, nsteps, x, tret, fresh, stat)
    type(sun_mem_t), pointer, intent(inout) :: mem
    real(wp), intent(inout) :: t_old, t
    integer(i8), intent(inout) :: nsteps
    real(wp), intent(inout) :: x(:)
    real(c_double), intent(in) :: tret
    logical, intent(inout) :: fresh
    integer, intent(out) :: stat
    stat = TUBES_OK
    if (.not. all(ieee_is_finite(mem%yd))) then
      stat = TUBES_EMODEL
      fresh = .true.
      return
    end if
    mem%sliver = .false.
    mem%nsince = mem%nsince + 1
    t_old = t
    t = tret
    x = mem%yd
    nsteps = nsteps + 1
  end subroutine accept
end module tubes_sundials
