!> One integration as the program and the Python layer run it: the model from the parameter
!> vector, a method with its options, sampling on a time grid, and optionally every crossing of
!> a section. The C API (src/capi/tubes_capi.f90) and f2py (python/tubes_f2py.f90) both call this.
module tubes_run
  use, intrinsic :: iso_c_binding, only: c_intptr_t, c_loc, c_f_pointer, c_null_ptr
  use tubes_kinds, only: wp, i8
  use tubes_status, only: TUBES_OK, TUBES_EINPUT, TUBES_EVENT, TUBES_EMODEL, TUBES_FULL
  use tubes_field, only: vector_field_t
  use tubes_models, only: make_field, make_model
  use tubes_hamiltonian, only: hamiltonian_t
  use tubes_integrator, only: integrator_t, event_t, plane_t, crossing_log_t, propagate
  use tubes_methods, only: new_integrator, method_opts_t, integ_choice_t, uses_taylor, make_integrator, noisy, noise_stream
  use tubes_lanes, only: lane_t, lane_jobs_t
  use tubes_ensemble, only: ens_out_t, ens_run
  use tubes_sampler, only: sampler_t
  use tubes_section_events, only: theta_line_t
  implicit none
  private

  integer, parameter, public :: SECTION_NONE = 0   !! no section
  integer, parameter, public :: SECTION_THETA = 1  !! ray theta = level [rad]; dir = sign(p_theta)
  integer, parameter, public :: SECTION_X = 2      !! line x = level [cm]; dir = sign(dx/dt)
  integer, parameter, public :: SECTION_Y = 3      !! line y = level [cm]; dir = sign(dy/dt)

  !> A section request (dir = 0: both orientations).
  type, public :: section_spec_t
    integer :: kind = SECTION_NONE
    real(wp) :: level = 0
    integer :: dir = 0
    logical :: stop_at_first = .false.
    integer :: max_crossings = 10000
  end type section_spec_t

  public :: run_integration, run_trajectory, run_ensemble
  public :: open_integrator, propagate_kept, close_integrator, trajectory_kept
  public :: sized_model, field_rates
  !> dx/dt at one state (x(:)) or at each column of x(:, :)
  interface field_rates
    module procedure field_rates_one, field_rates_many
  end interface field_rates

  !> An integrator kept between calls (Python's tubes.Integrator, as heyoka's taylor_adaptive):
  !> the model's field, the method and, for the Taylor method, its kernel set up once; each
  !> propagate_kept a fresh integration from t = 0, the same bits as a new integrator's. The
  !> caller owns it by its address (open_integrator, close_integrator).
  type :: kept_integrator_t
    class(integrator_t), allocatable :: ig
    class(hamiltonian_t), allocatable :: cons   !! the conservative model: a trajectory's energies
  end type kept_integrator_t

  !> Items of an ensemble per call of run_lanes (an OpenMP thread's unit of work)
  integer, parameter :: ENSEMBLE_CHUNK = 64

  !> run_ensemble's states as an ensemble (tubes_ensemble; in lanes with the Taylor method,
  !> tubes_lanes): item k's end state and its number of steps (dim + 1 reals).
  type, extends(lane_jobs_t) :: ensemble_jobs_t
    class(vector_field_t), allocatable :: field
    real(wp), allocatable :: x0(:, :)
    real(wp) :: t_end = 0, rtol = 0, atol = 0, h = 0
    integer(i8) :: max_steps = 0
    integer :: method = 0
    type(method_opts_t) :: mopts
  contains
    procedure :: item => ensemble_item
    procedure :: start => ensemble_start
    procedure :: finish => ensemble_finish
  end type ensemble_jobs_t

contains

  !> Integrate the model (system, params) from x0 at t = 0 to t_end with method (and opts), sampling
  !> into obs (already started by the caller) and recording crossings of sec into log.
  !> stat: TUBES_OK, or < 0 (the samples and crossings up to the failure are kept).
  !> counters = [nfev, nsteps, nrejected, niter]; c_damp = the damping rate used [1/s].
  subroutine run_integration(system, params, x0, t_end, method, rtol, atol, h, max_steps, mopts, &
                             sec, obs, log, counters, c_damp, stat)
    character(*), intent(in) :: system
    real(wp), intent(in) :: params(:), x0(:), t_end, rtol, atol, h
    integer, intent(in) :: method
    integer(i8), intent(in) :: max_steps
    type(method_opts_t), intent(in) :: mopts
    type(section_spec_t), intent(in) :: sec
    class(sampler_t), intent(inout) :: obs
    type(crossing_log_t), intent(inout) :: log
    integer(i8), intent(out) :: counters(4)
    real(wp), intent(out) :: c_damp
    integer, intent(out) :: stat
    class(integrator_t), allocatable :: ig
    counters = 0
    call setup_integration(system, params, method, rtol, atol, h, max_steps, mopts, ig, c_damp, stat)
    if (stat /= TUBES_OK) return
    call integrate_with(ig, x0, t_end, sec, obs, log, counters, stat)
  end subroutine run_integration

  !> run_integration's integration with an integrator set up at t = 0 (a new one, or a kept one
  !> restarted).
  subroutine integrate_with(ig, x0, t_end, sec, obs, log, counters, stat)
    class(integrator_t), intent(inout) :: ig
    real(wp), intent(in) :: x0(:), t_end
    type(section_spec_t), intent(in) :: sec
    class(sampler_t), intent(inout) :: obs
    type(crossing_log_t), intent(inout) :: log
    integer(i8), intent(out) :: counters(4)
    integer, intent(out) :: stat
    class(event_t), allocatable :: ev
    real(wp) :: x(size(x0))
    counters = 0
    stat = TUBES_OK
    if (size(x0) /= ig%f%dim()) then
      stat = TUBES_EINPUT
      return
    end if
    x = x0
    log%max_crossings = sec%max_crossings
    select case (sec%kind)
    case (SECTION_THETA)
      if (size(x0) /= 4) then      ! the polar ray needs a planar (x, y, px, py) state
        stat = TUBES_EINPUT
        return
      end if
      allocate (ev, source=theta_line_t(theta0=sec%level, branch=sec%dir, terminal=sec%stop_at_first))
    case (SECTION_X)
      allocate (ev, source=plane_t(k=1, c=sec%level, direction=sec%dir, terminal=sec%stop_at_first))
    case (SECTION_Y)
      allocate (ev, source=plane_t(k=2, c=sec%level, direction=sec%dir, terminal=sec%stop_at_first))
    case (SECTION_NONE)
    case default
      stat = TUBES_EINPUT
      return
    end select
    if (t_end > 0) then
      if (allocated(ev)) then
        call propagate(ig, x, t_end, stat, event=ev, observer=obs, crossings=log)
      else
        call propagate(ig, x, t_end, stat, observer=obs)
      end if
    end if
    if (stat == TUBES_EVENT) stat = TUBES_OK
    counters = [ig%nfev, ig%nsteps, ig%nrejected, ig%niter]
  end subroutine integrate_with
  !> The model's field (c_damp: its damping rate [1/s]) and the method's integrator on it at t = 0.
  subroutine setup_integration(system, params, method, rtol, atol, h, max_steps, mopts, ig, c_damp, stat)
    character(*), intent(in) :: system
    real(wp), intent(in) :: params(:), rtol, atol, h
    integer, intent(in) :: method
    integer(i8), intent(in) :: max_steps
    type(method_opts_t), intent(in) :: mopts
    class(integrator_t), allocatable, intent(out) :: ig
    real(wp), intent(out) :: c_damp
    integer, intent(out) :: stat
    class(vector_field_t), allocatable :: field
    c_damp = 0
    call make_field(system, params, field, c_damp, stat)
    if (stat /= TUBES_OK) return
    if (noisy(field)) then          ! the stochastic method (tubes_sde), whatever the method asked
      call make_integrator(integ_choice_t(method=method, h=h, opts=mopts), ig, stat, f=field)
    else
      call new_integrator(method, ig, stat, mopts)
      if (stat /= TUBES_OK) return
      call ig%init(field, 0.0_wp)
      ig%h = h
    end if
    if (stat /= TUBES_OK) return
    ig%rtol = rtol
    ig%atol = atol
    ig%max_steps = max_steps
  end subroutine setup_integration

  !> A kept integrator (as run_integration's, without events); handle: its address (0 on failure).
  subroutine open_integrator(system, params, method, rtol, atol, h, max_steps, mopts, handle, stat)
    character(*), intent(in) :: system
    real(wp), intent(in) :: params(:), rtol, atol, h
    integer, intent(in) :: method
    integer(i8), intent(in) :: max_steps
    type(method_opts_t), intent(in) :: mopts
    integer(c_intptr_t), intent(out) :: handle
    integer, intent(out) :: stat
    class(integrator_t), allocatable :: ig
    type(kept_integrator_t), pointer :: kept
    real(wp) :: c_damp
    handle = 0
    call setup_integration(system, params, method, rtol, atol, h, max_steps, mopts, ig, c_damp, stat)
    if (stat /= TUBES_OK) return
    allocate (kept)
    call move_alloc(ig, kept%ig)
    call make_model(system, params, kept%cons, stat)
    if (stat /= TUBES_OK) then
      deallocate (kept)
      return
    end if
    handle = transfer(c_loc(kept), handle)
  end subroutine open_integrator

  !> Integrate x from t = 0 to t_end with the kept integrator at `handle` (x: the state reached,
  !> also on failure); counters = [nfev, nsteps, nrejected, niter] of this call.
  subroutine propagate_kept(handle, x, t_end, counters, stat)
    integer(c_intptr_t), intent(in) :: handle
    real(wp), intent(inout) :: x(:)
    real(wp), intent(in) :: t_end
    integer(i8), intent(out) :: counters(4)
    integer, intent(out) :: stat
    type(kept_integrator_t), pointer :: kept
    counters = 0
    stat = TUBES_EINPUT
    if (handle == 0) return
    call c_f_pointer(transfer(handle, c_null_ptr), kept)
    if (size(x) /= kept%ig%f%dim() .or. .not. t_end >= 0) return
    stat = TUBES_OK
    call kept%ig%restart(0.0_wp)
    if (t_end > 0) call propagate(kept%ig, x, t_end, stat)
    counters = [kept%ig%nfev, kept%ig%nsteps, kept%ig%nrejected, kept%ig%niter]
  end subroutine propagate_kept

  !> Free the kept integrator at `handle` (0: nothing).
  subroutine close_integrator(handle)
    integer(c_intptr_t), intent(in) :: handle
    type(kept_integrator_t), pointer :: kept
    if (handle == 0) return
    call c_f_pointer(transfer(handle, c_null_ptr), kept)
    deallocate (kept)
  end subroutine close_integrator

  !> The trajectory scene's whole integration, for the C API and f2py alike: checks, the model,
  !> run_integration into obs (a sampler the caller may extend, e.g. with a progress callback),
  !> then the samples (t, state, the conservative energy of each) and the first crossings copied
  !> out. Arrays are sized by the caller: nmax samples, max(max_cross, 1) crossings.
  subroutine run_trajectory(system, params, x0, t_end, dt_out, method, rtol, atol, h, max_steps, &
                            mopts, sec, obs, n, t, state, energy, n_cross, cross_t, cross_x, &
                            cross_dir, counters, c_damp, stat)
    character(*), intent(in) :: system
    real(wp), intent(in) :: params(:), x0(:), t_end, dt_out, rtol, atol, h
    integer, intent(in) :: method
    integer(i8), intent(in) :: max_steps
    type(method_opts_t), intent(in) :: mopts
    type(section_spec_t), intent(in) :: sec
    class(sampler_t), intent(inout) :: obs
    integer, intent(out) :: n, n_cross
    real(wp), intent(out) :: t(:), state(:, :), energy(:), cross_t(:), cross_x(:, :)
    integer, intent(out) :: cross_dir(:)
    integer(i8), intent(out) :: counters(4)
    real(wp), intent(out) :: c_damp
    integer, intent(out) :: stat
    class(hamiltonian_t), allocatable :: cons
    class(integrator_t), allocatable :: ig
    integer :: k
    n = 0; n_cross = 0; counters = 0; c_damp = 0
    t = 0; state = 0; energy = 0; cross_t = 0; cross_x = 0; cross_dir = 0
    if (.not. dt_out > 0 .or. .not. t_end >= 0 .or. size(t) < 2 .or. sec%max_crossings < 0) then
      stat = TUBES_EINPUT
      return
    end if
    call make_model(system, params, cons, stat)
    if (stat /= TUBES_OK) return
    if (size(x0) /= cons%dim()) then
      stat = TUBES_EINPUT
      return
    end if
    call setup_integration(system, params, method, rtol, atol, h, max_steps, mopts, ig, c_damp, stat)
    if (stat /= TUBES_OK) then          ! no integrator (no Taylor kernel, ...): the start sample alone
      call obs%start(0.0_wp, dt_out, x0, size(t), t_end=t_end)
      n = obs%n
      t(1:n) = obs%t(1:n)
      state(:, 1:n) = obs%x(:, 1:n)
      do k = 1, n
        energy(k) = cons%energy(state(:, k))
      end do
      return
    end if
    call trajectory_with(ig, cons, x0, t_end, dt_out, sec, obs, n, t, state, energy, n_cross, cross_t, cross_x, &
                         cross_dir, counters, stat)
  end subroutine run_trajectory

  !> run_trajectory with an integrator set up at t = 0 and the conservative model cons (the
  !> samples' energies); the arguments checked by the caller.
  subroutine trajectory_with(ig, cons, x0, t_end, dt_out, sec, obs, n, t, state, energy, n_cross, cross_t, &
                             cross_x, cross_dir, counters, stat)
    class(integrator_t), intent(inout) :: ig
    class(hamiltonian_t), intent(in) :: cons
    real(wp), intent(in) :: x0(:), t_end, dt_out
    type(section_spec_t), intent(in) :: sec
    class(sampler_t), intent(inout) :: obs
    integer, intent(out) :: n, n_cross
    real(wp), intent(inout) :: t(:), state(:, :), energy(:), cross_t(:), cross_x(:, :)
    integer, intent(inout) :: cross_dir(:)
    integer(i8), intent(out) :: counters(4)
    integer, intent(out) :: stat
    type(crossing_log_t) :: log
    type(section_spec_t) :: spec
    integer :: k
    n = 0; n_cross = 0
    spec = sec
    spec%max_crossings = max(sec%max_crossings, 1)
    call obs%start(0.0_wp, dt_out, x0, size(t), t_end=t_end)
    call integrate_with(ig, x0, t_end, spec, obs, log, counters, stat)
    n = obs%n
    ! the crossing log full before t_end: said (TUBES_FULL), not a silent stop (t_end = 200000 s
    ! ended at 24,488 s with status 0)
    if (stat == TUBES_OK .and. sec%kind /= SECTION_NONE .and. .not. sec%stop_at_first .and. n > 0) then
      if (log%n >= spec%max_crossings .and. obs%t(n) < t_end) stat = TUBES_FULL
    end if
    t(1:n) = obs%t(1:n)
    state(:, 1:n) = obs%x(:, 1:n)
    do k = 1, n
      energy(k) = cons%energy(state(:, k))
    end do
    if (sec%kind /= SECTION_NONE) then
      n_cross = min(log%n, sec%max_crossings)
      do k = 1, n_cross
        cross_t(k) = log%t(k)
        cross_x(:, k) = log%x(:, k)
        cross_dir(k) = log%direction(k)
      end do
    end if
  end subroutine trajectory_with

  !> run_trajectory with the kept integrator at handle (open_integrator), restarted at t = 0: the
  !> model and, for the Taylor method, its kernel are not made again (Python's tubes.integrate
  !> keeps one per model and options: tens of microseconds a call).
  subroutine trajectory_kept(handle, x0, t_end, dt_out, sec, obs, n, t, state, energy, n_cross, cross_t, &
                             cross_x, cross_dir, counters, stat)
    integer(c_intptr_t), intent(in) :: handle
    real(wp), intent(in) :: x0(:), t_end, dt_out
    type(section_spec_t), intent(in) :: sec
    class(sampler_t), intent(inout) :: obs
    integer, intent(out) :: n, n_cross
    real(wp), intent(out) :: t(:), state(:, :), energy(:), cross_t(:), cross_x(:, :)
    integer, intent(out) :: cross_dir(:)
    integer(i8), intent(out) :: counters(4)
    integer, intent(out) :: stat
    type(kept_integrator_t), pointer :: kept
    n = 0; n_cross = 0; counters = 0
    t = 0; state = 0; energy = 0; cross_t = 0; cross_x = 0; cross_dir = 0
    stat = TUBES_EINPUT
    if (handle == 0) return
    call c_f_pointer(transfer(handle, c_null_ptr), kept)
    if (dt_out <= 0 .or. .not. t_end >= 0 .or. size(t) < 2 .or. sec%max_crossings < 0) return
    if (.not. allocated(kept%cons)) return
    if (size(x0) /= kept%cons%dim()) return
    call kept%ig%restart(0.0_wp)
    call trajectory_with(kept%ig, kept%cons, x0, t_end, dt_out, sec, obs, n, t, state, energy, n_cross, cross_t, &
                         cross_x, cross_dir, counters, stat)
  end subroutine trajectory_kept

  !> Many integrations of one model from t = 0 to t_end, each from its own state x0(:, k), to
  !> xs(:, k) with status st(k) and nsteps(k) steps: the Taylor method ('taylor', 'auto') in the
  !> lanes (lane_width() at a time, ENSEMBLE_CHUNK states per thread's unit), any other method one state
  !> at a time; over `threads` OpenMP threads (0: all). Each state's result is that of a lone
  !> integration bit for bit, whatever the threads (tubes_lanes). stat: the set-up's status (a
  !> failed state has its own st(k) < 0 and xs(:, k) where it stopped).
  subroutine run_ensemble(system, params, x0, t_end, method, rtol, atol, h, max_steps, mopts, threads, &
                          xs, st, nsteps, stat)
    character(*), intent(in) :: system
    real(wp), intent(in) :: params(:), x0(:, :), t_end, rtol, atol, h
    integer, intent(in) :: method, threads
    integer(i8), intent(in) :: max_steps
    type(method_opts_t), intent(in) :: mopts
    real(wp), intent(out) :: xs(:, :)
    integer, intent(out) :: st(:)
    integer(i8), intent(out) :: nsteps(:)
    integer, intent(out) :: stat
    type(ensemble_jobs_t) :: ens
    type(ens_out_t) :: out
    class(vector_field_t), allocatable :: field
    class(integrator_t), allocatable :: ig
    real(wp) :: c_damp
    integer :: m, d
    xs = x0
    st = TUBES_EINPUT
    nsteps = 0
    m = size(x0, 2)
    call make_field(system, params, field, c_damp, stat)
    if (stat /= TUBES_OK) return
    d = field%dim()
    if (size(x0, 1) /= d .or. .not. t_end >= 0 .or. any(shape(xs) /= shape(x0)) .or. &
        size(st) /= m .or. size(nsteps) /= m) then
      stat = TUBES_EINPUT
      return
    end if
    call new_integrator(method, ig, stat, mopts)        ! the method exists
    if (stat /= TUBES_OK) return
    ens = ensemble_jobs_t(lanes=uses_taylor(integ_choice_t(method=method)) .and. .not. noisy(field), x0=x0, &
                          t_end=t_end, rtol=rtol, atol=atol, h=h, max_steps=max_steps, method=method, mopts=mopts)
    call move_alloc(field, ens%field)
    call ens_run(ens, m, out, d + 1, 0, local=.true., chunk=merge(ENSEMBLE_CHUNK, 1, ens%lanes), threads=threads)
    xs = out%r(1:d, :)
    nsteps = int(out%r(d + 1, :), i8)
    st = out%st
  end subroutine run_ensemble

  !> State k by its own integrator (one per call: nothing shared between threads but the model).
  subroutine ensemble_item(self, k, out)
    class(ensemble_jobs_t), intent(in) :: self
    integer, intent(in) :: k
    type(ens_out_t), intent(inout) :: out
    class(integrator_t), allocatable :: ik
    real(wp) :: x(size(self%x0, 1))
    integer :: d
    d = size(x)
    x = self%x0(:, k)
    out%r(1:d, k) = x
    if (noisy(self%field)) then       ! the stochastic method, row k's own noise
      call make_integrator(integ_choice_t(method=self%method, h=self%h, opts=self%mopts), ik, out%st(k), &
                           f=self%field)
      if (out%st(k) /= TUBES_OK) return
      call noise_stream(ik, k)
    else
      call new_integrator(self%method, ik, out%st(k), self%mopts)
      if (out%st(k) /= TUBES_OK) return
      call ik%init(self%field, 0.0_wp)
      ik%h = self%h
    end if
    ik%rtol = self%rtol
    ik%atol = self%atol
    ik%max_steps = self%max_steps
    if (self%t_end > 0) call propagate(ik, x, self%t_end, out%st(k))
    out%r(1:d, k) = x
    out%r(d + 1, k) = real(ik%nsteps, wp)
  end subroutine ensemble_item

  !> State k in a lane: the Taylor integrator on the model, its tolerances, from t = 0.
  subroutine ensemble_start(self, k, lane, stat)
    class(ensemble_jobs_t), intent(inout) :: self
    integer, intent(in) :: k
    type(lane_t), intent(inout) :: lane
    integer, intent(out) :: stat
    stat = TUBES_OK
    call lane%setup(self%field, self%h, self%rtol, self%atol, self%max_steps)
    lane%x = self%x0(:, k)
    lane%tend = self%t_end
  end subroutine ensemble_start

  !> State k's end: where it stopped, its status and steps.
  subroutine ensemble_finish(self, k, lane, out)
    class(ensemble_jobs_t), intent(in) :: self
    integer, intent(in) :: k
    type(lane_t), intent(inout) :: lane
    type(ens_out_t), intent(inout) :: out
    out%r(1:size(lane%x), k) = lane%x
    out%r(size(lane%x) + 1, k) = real(lane%ig%nsteps, wp)
    out%st(k) = lane%stat
  end subroutine ensemble_finish

  !> The conservative model of (system, params); stat TUBES_EINPUT unless n is the size of its
  !> state, 2N (per_dof: of its configuration, N). The C API's and Python's calls on one state.
  subroutine sized_model(system, params, n, per_dof, model, stat)
    character(*), intent(in) :: system
    real(wp), intent(in) :: params(:)
    integer, intent(in) :: n
    logical, intent(in) :: per_dof
    class(hamiltonian_t), allocatable, intent(out) :: model
    integer, intent(out) :: stat
    call make_model(trim(system), params, model, stat)
    if (stat /= TUBES_OK) return
    if (n /= merge(model%ndof(), model%dim(), per_dof)) stat = TUBES_EINPUT
  end subroutine sized_model

  !> dx/dt of the model's vector field at x (damped for a rolling ball with damping_ratio > 0):
  !> TUBES_EINPUT if x is not its state's size, TUBES_EMODEL if the field fails there.
  subroutine field_rates_one(system, params, x, dxdt, stat)
    character(*), intent(in) :: system
    real(wp), intent(in) :: params(:), x(:)
    real(wp), intent(out) :: dxdt(:)
    integer, intent(out) :: stat
    real(wp) :: f(size(dxdt), 1)
    call field_rates_many(system, params, reshape(x, [size(x), 1]), f, stat)
    dxdt = f(:, 1)
  end subroutine field_rates_one

  !> The same at each column of x (the model made once: a formula's library is looked up and
  !> checked once for all of them, not per state): dxdt(:, k) at x(:, k); stat TUBES_EMODEL at the
  !> first column where the field fails (what the field gave there; the columns after it are 0).
  subroutine field_rates_many(system, params, x, dxdt, stat)
    character(*), intent(in) :: system
    real(wp), intent(in) :: params(:), x(:, :)
    real(wp), intent(out) :: dxdt(:, :)
    integer, intent(out) :: stat
    class(vector_field_t), allocatable :: field
    real(wp) :: c
    integer :: k
    dxdt = 0
    call make_field(trim(system), params, field, c, stat)
    if (stat /= TUBES_OK) return
    if (size(x, 1) /= field%dim() .or. size(dxdt, 1) /= size(x, 1) .or. size(dxdt, 2) /= size(x, 2)) then
      stat = TUBES_EINPUT
      return
    end if
    do k = 1, size(x, 2)
      call field%eval(0.0_wp, x(:, k), dxdt(:, k), stat)
      if (stat /= 0) then
        stat = TUBES_EMODEL
        return
      end if
    end do
  end subroutine field_rates_many
end module tubes_run
