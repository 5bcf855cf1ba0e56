!> One integration as the program and the Python layer run it: the model from the parameter
!> vector, a method with its options, sampling on a time grid, and optionally every crossing of
!> a section. The C API (src/capi/tubes_capi.f90) and f2py (python/tubes_f2py.f90) both call this.
module tubes_run
  use tubes_kinds, only: wp, i8
  use tubes_status, only: TUBES_OK, TUBES_EINPUT, TUBES_EVENT
  use tubes_field, only: vector_field_t
  use tubes_models, only: make_field, make_model
  use tubes_hamiltonian, only: hamiltonian_t
  use tubes_integrator, only: integrator_t, event_t, plane_t, crossing_log_t, propagate
  use tubes_methods, only: new_integrator, method_opts_t
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

  public :: run_integration, run_trajectory

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
    class(vector_field_t), allocatable :: field
    class(integrator_t), allocatable :: ig
    class(event_t), allocatable :: ev
    real(wp) :: x(size(x0))
    counters = 0
    c_damp = 0
    call make_field(system, params, field, c_damp, stat)
    if (stat /= TUBES_OK) return
    if (size(x0) /= field%dim()) then
      stat = TUBES_EINPUT
      return
    end if
    call new_integrator(method, ig, stat, mopts)
    if (stat /= TUBES_OK) return
    call ig%init(field, 0.0_wp)
    ig%rtol = rtol
    ig%atol = atol
    ig%h = h
    ig%max_steps = max_steps
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
  end subroutine run_integration
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
    type(crossing_log_t) :: log
    type(section_spec_t) :: spec
    integer :: k, nmax
    n = 0; n_cross = 0; counters = 0; c_damp = 0
    t = 0; state = 0; energy = 0; cross_t = 0; cross_x = 0; cross_dir = 0
    nmax = size(t)
    if (dt_out <= 0 .or. t_end < 0 .or. nmax < 2 .or. sec%max_crossings < 0) then
      stat = TUBES_EINPUT
      return
    end if
    call make_model(system, params, cons, stat)
    if (stat /= TUBES_OK) return
    if (size(x0) /= cons%dim()) then
      stat = TUBES_EINPUT
      return
    end if
    spec = sec
    spec%max_crossings = max(sec%max_crossings, 1)
    call obs%start(0.0_wp, dt_out, x0, nmax)
    call run_integration(system, params, x0, t_end, method, rtol, atol, h, max_steps, mopts, spec, &
                         obs, log, counters, c_damp, stat)
    n = obs%n
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
  end subroutine run_trajectory
end module tubes_run
