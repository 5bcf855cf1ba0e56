!> Synthetic tracking data in the manner of the paper's experiment (Ross et al. 2018,
!> "Experimental setup"): a ball released from rest at random places, rolling on the damped
!> surface, filmed at camera_rate; each frame gives its position plus Gaussian noise, rounded to
!> the pixel grid. The truth (noise-free states) is returned beside the measurement.
!> Model and defaults: docs/experiment-data.md.
!>
!> All random numbers come from one GSL MT19937 stream (tubes_rng_uniform, src/base/tubes_quad_shim.c)
!> and are drawn serially before the tracks are integrated in parallel (MPI ranks and OpenMP
!> threads), each track into its own slice: the result does not depend on either number.
module tubes_experiment
  use, intrinsic :: iso_c_binding, only: c_int, c_double, c_long
  use tubes_kinds, only: wp, PI
  use tubes_quad, only: rng_uniform
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
  use tubes_status, only: TUBES_OK, TUBES_EINPUT, TUBES_EFAULT
  use tubes_ensemble, only: ensemble_t, ens_out_t, ens_run, ens_agree
  use tubes_ball, only: ball_t
  use tubes_models, only: NMODEL, model_ball, conservative_ball
  use tubes_field, only: vector_field_t
  use tubes_methods, only: integ_choice_t, make_integrator, uses_taylor, noisy_field => noisy
  use tubes_sampler, only: sampler_t
  use tubes_integrator, only: integrator_t, observer_t, propagate
  use tubes_lanes, only: lane_t, lane_jobs_t, MAX_LANES
  implicit none
  private

  !> Rejection sampling gives up after this many draws of a release point.
  integer, parameter, public :: MAX_RELEASE_DRAWS = 2**22

  !> The noise-free tracks: item j released from rest at release(:, j) (in lanes with the Taylor
  !> method, tubes_lanes; a noisy field: one by one).
  type, extends(lane_jobs_t) :: track_ens_t
    class(vector_field_t), allocatable :: model
    type(integ_choice_t) :: integ
    real(wp), allocatable :: release(:, :)      !! x0, y0 [cm] (2, n_tracks)
    real(wp) :: dt = 0, rtol = 0, atol = 0
    integer :: ns = 0
  contains
    procedure :: item => track_item
    procedure :: start => track_start
    procedure :: finish => track_finish
  end type track_ens_t

  !> What to simulate. Defaults are the paper's set-up (docs/experiment-data.md).
  type, public :: experiment_opts_t
    integer :: n_tracks = 120             !! released trajectories
    real(wp) :: duration = 10             !! length of each track [s]
    real(wp) :: camera_rate = 50          !! frames per second [Hz]
    real(wp) :: pixel = 0.16_wp           !! pixel size: positions are rounded to it [cm]; 0 = none
    real(wp) :: noise = 0.05_wp           !! standard deviation of the position noise [cm]
    real(wp) :: de_min = 1000             !! release excess energy g H - E_e, lower bound [(cm/s)^2]
    real(wp) :: de_max = 3000             !! upper bound [(cm/s)^2]
    real(wp) :: e_e = 0                   !! critical energy E_e of the reference saddle [(cm/s)^2]
    real(wp) :: box = 13                  !! releases in |x|, |y| <= box [cm]
    integer(c_long) :: seed = 1           !! seed of the MT19937 stream
    real(wp) :: rtol = 1.0e-10_wp         !! the integrator's relative tolerance
    real(wp) :: atol = 1.0e-10_wp         !! its absolute tolerance [state units]
  end type experiment_opts_t

  public :: experiment_samples, synthetic_experiment

contains

  !> Frames per track: t = 0, 1/rate, ..., up to duration (both ends included).
  pure integer function experiment_samples(duration, camera_rate) result(ns)
    real(wp), intent(in) :: duration      !! [s]
    real(wp), intent(in) :: camera_rate   !! [Hz]
    ns = 0
    if (.not. (duration > 0 .and. camera_rate > 0)) return
    if (duration*camera_rate > 1.0e8_wp) return
    ns = floor(duration*camera_rate*(1 + 1.0e-12_wp)) + 1
  end function experiment_samples

  !> Simulate the experiment. params is the model vector (include/tubes.h) with params(7) the
  !> experiment's damping ratio zeta. Per track j (ns = experiment_samples frames, times t):
  !> state(:, :, j) the true (x, y, px, py) at the frames, energy(:, j) its conservative energy,
  !> noisy(:, :, j) the positions plus noise, measured(:, :, j) those rounded to the pixel grid,
  !> release(:, j) = (x0, y0, g H(x0, y0) - E_e). c_damp is the damping rate [1/s], n_draws the
  !> release points drawn (accepted and rejected).
  !> stat: TUBES_OK; TUBES_EINPUT for bad options, array shapes, or when fewer than n_tracks
  !> points in the box have an excess energy in [de_min, de_max] after MAX_RELEASE_DRAWS draws;
  !> an integration failure's code (the tracks that failed keep their samples up to the
  !> failure, the rest of them NaN).
  subroutine synthetic_experiment(params, opts, integ, t, state, energy, noisy, measured, release, &
                                  c_damp, n_draws, stat)
    real(wp), intent(in) :: params(NMODEL)
    type(experiment_opts_t), intent(in) :: opts
    type(integ_choice_t), intent(in) :: integ    !! the integrator (&integrator method)
    real(wp), intent(out) :: t(:)                !! frame times [s] (ns)
    real(wp), intent(out) :: state(:, :, :)      !! true states [cm, cm/s] (4, ns, n_tracks)
    real(wp), intent(out) :: energy(:, :)        !! conservative energy [(cm/s)^2] (ns, n_tracks)
    real(wp), intent(out) :: noisy(:, :, :)      !! positions + noise [cm] (2, ns, n_tracks)
    real(wp), intent(out) :: measured(:, :, :)   !! noisy rounded to the pixels [cm] (2, ns, n_tracks)
    real(wp), intent(out) :: release(:, :)       !! x0 [cm], y0 [cm], dE0 [(cm/s)^2] (3, n_tracks)
    real(wp), intent(out) :: c_damp              !! damping rate used [1/s]
    integer, intent(out) :: n_draws              !! release points drawn
    integer, intent(out) :: stat
    class(vector_field_t), allocatable :: model
    type(ball_t) :: cons
    real(wp), allocatable :: u(:)
    real(wp) :: dt, de, r, th
    integer :: ns, nt, nb, j, k, m, off
    integer, allocatable :: st(:)
    type(track_ens_t) :: tracks
    type(ens_out_t) :: out
    t = 0; state = 0; energy = 0; noisy = 0; measured = 0; release = 0; c_damp = 0; n_draws = 0
    stat = TUBES_EINPUT
    nt = opts%n_tracks
    ns = experiment_samples(opts%duration, opts%camera_rate)
    if (nt < 1 .or. ns < 1) return
    if (.not. (opts%pixel >= 0 .and. opts%noise >= 0 .and. opts%de_min < opts%de_max .and. &
               opts%box > 0 .and. opts%rtol > 0 .and. opts%atol > 0 .and. opts%seed >= 0)) return
    if (size(t) /= ns .or. any(shape(state) /= [4, ns, nt]) .or. any(shape(energy) /= [ns, nt]) &
        .or. any(shape(noisy) /= [2, ns, nt]) .or. any(shape(measured) /= [2, ns, nt]) .or. &
        any(shape(release) /= [3, nt])) return
    call conservative_ball(params, cons, stat)
    if (stat /= TUBES_OK) return
    call model_ball(params, model, c_damp, stat)
    if (stat /= TUBES_OK) return
    dt = 1/opts%camera_rate

    ! release points by rejection in the box, then 2 uniforms per frame for the noise: one
    ! stream, laid out [release draws | noise]; if the release budget nb runs out it is
    ! enlarged and the same stream drawn again (the accepted points so far do not change)
    nb = max(64*nt, 1024)
    do
      if (allocated(u)) deallocate (u)
      allocate (u(2*nb + 2*ns*nt))
      stat = rng_uniform(opts%seed, size(u), u)
      if (stat /= 0) then
        stat = TUBES_EINPUT
        return
      end if
      m = 0
      k = 0
      do while (m < nt .and. k < nb)
        k = k + 1
        release(1, m + 1) = opts%box*(2*u(2*k - 1) - 1)
        release(2, m + 1) = opts%box*(2*u(2*k) - 1)
        de = cons%potential_xy(release(1, m + 1), release(2, m + 1)) - opts%e_e
        if (de >= opts%de_min .and. de <= opts%de_max) then
          m = m + 1
          release(3, m) = de
        end if
      end do
      n_draws = k
      if (m == nt) exit
      if (nb >= MAX_RELEASE_DRAWS) then
        release = 0
        stat = TUBES_EINPUT
        return
      end if
      nb = min(4*nb, MAX_RELEASE_DRAWS)
    end do

    ! the noise-free tracks, dealt out over MPI ranks and threads (tubes_ensemble)
    call ens_agree(release)
    tracks = track_ens_t(lanes=uses_taylor(integ), integ=integ, release=release(1:2, :), dt=dt, ns=ns, &
                         rtol=opts%rtol, atol=opts%atol)
    tracks%lanes = tracks%lanes .and. .not. noisy_field(model)   ! a noisy field: one by one
    allocate (tracks%model, source=model)
    call ens_run(tracks, nt, out, 4*ns, 0, fault='track', chunk=merge(MAX_LANES, 1, tracks%lanes))
    state = reshape(out%r, [4, ns, nt])
    st = out%st
    do j = 1, nt
      if (st(j) == TUBES_EFAULT) state(:, :, j) = ieee_value(1.0_wp, ieee_quiet_nan)
    end do
    do k = 1, ns
      t(k) = (k - 1)*dt
    end do

    ! measurement: Box-Muller pairs (x, y) per frame, then rounding to the pixel grid; a track
    ! whose integration failed keeps NaN after its last frame (its uniforms are still consumed)
    off = 2*nb
    do j = 1, nt
      do k = 1, ns
        r = opts%noise*sqrt(-2*log(1 - u(off + 1)))   ! 1 - u in (0, 1]
        th = 2*PI*u(off + 2)
        off = off + 2
        if (.not. (abs(state(1, k, j)) <= huge(1.0_wp))) then
          noisy(:, k, j) = state(1:2, k, j)
          measured(:, k, j) = state(1:2, k, j)
          energy(k, j) = state(1, k, j)
          cycle
        end if
        noisy(1, k, j) = state(1, k, j) + r*cos(th)
        noisy(2, k, j) = state(2, k, j) + r*sin(th)
        if (opts%pixel > 0) then
          measured(:, k, j) = anint(noisy(:, k, j)/opts%pixel)*opts%pixel
        else
          measured(:, k, j) = noisy(:, k, j)
        end if
        energy(k, j) = cons%energy(state(:, k, j))
      end do
    end do
    stat = TUBES_OK
    if (any(st /= TUBES_OK)) stat = minval(st)
  end subroutine synthetic_experiment

  !> One track from rest at x0: the chosen integrator on the (damped) model, sampled every dt by
  !> the dense output (ns frames from t = 0). On failure the frames not reached are NaN.
  subroutine one_track(model, integ, x0, dt, ns, rtol, atol, xs, stat)
    class(vector_field_t), intent(in) :: model
    type(integ_choice_t), intent(in) :: integ
    real(wp), intent(in) :: x0(4), dt, rtol, atol
    integer, intent(in) :: ns
    real(wp), intent(out) :: xs(4, ns)
    integer, intent(out) :: stat
    class(integrator_t), allocatable :: ig
    type(sampler_t) :: obs
    real(wp) :: x(4)
    integer :: st
    xs = ieee_nan()
    call make_integrator(integ, ig, stat, f=model, rtol=rtol, atol=atol)
    if (stat /= TUBES_OK) return
    call obs%start(0.0_wp, dt, x0, ns)
    x = x0
    st = TUBES_OK
    if (ns > 1) call propagate(ig, x, (ns - 1)*dt, st, observer=obs)
    call frames(obs, ns, st, xs, stat)
  end subroutine one_track

  subroutine track_item(self, k, out)
    class(track_ens_t), intent(in) :: self
    integer, intent(in) :: k
    type(ens_out_t), intent(inout) :: out
    call one_track(self%model, self%integ, [self%release(:, k), 0.0_wp, 0.0_wp], self%dt, self%ns, &
                   self%rtol, self%atol, out%r(:, k), out%st(k))
  end subroutine track_item

  !> Track k in a lane: one_track's set-up (the integrator of the choice from t = 0 with rtol and
  !> atol, the frames' sampler as its observer).
  subroutine track_start(self, k, lane, stat)
    class(track_ens_t), intent(inout) :: self
    integer, intent(in) :: k
    type(lane_t), intent(inout) :: lane
    integer, intent(out) :: stat
    type(sampler_t) :: obs
    stat = TUBES_OK
    call lane%setup(self%model, self%integ%h, self%rtol, self%atol)
    lane%x = [self%release(:, k), 0.0_wp, 0.0_wp]
    lane%tend = (self%ns - 1)*self%dt
    call obs%start(0.0_wp, self%dt, lane%x, self%ns)
    allocate (lane%observer, source=obs)
  end subroutine track_start

  !> Track k's frames, as one_track's (NaN after the last reached).
  subroutine track_finish(self, k, lane, out)
    class(track_ens_t), intent(in) :: self
    integer, intent(in) :: k
    type(lane_t), intent(inout) :: lane
    type(ens_out_t), intent(inout) :: out
    call frames(lane%observer, self%ns, lane%stat, out%r(:, k), out%st(k))
  end subroutine track_finish

  !> A track's frames xs (4, ns) from its sampler obs after an integration that ended with stat
  !> (its status, TUBES_EINPUT if the frames are short of ns on success: cannot happen).
  subroutine frames(obs, ns, stat, xs, st)
    class(observer_t), intent(in) :: obs
    integer, intent(in) :: ns, stat
    real(wp), intent(out) :: xs(4, ns)
    integer, intent(out) :: st
    xs = ieee_nan()
    st = stat
    select type (obs)
    type is (sampler_t)
      xs(:, 1:obs%n) = obs%x(:, 1:obs%n)
      if (stat == TUBES_OK .and. obs%n /= ns) st = TUBES_EINPUT   ! grid mismatch: cannot happen
    end select
  end subroutine frames

  pure real(wp) function ieee_nan() result(v)
    use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
    v = ieee_value(1.0_wp, ieee_quiet_nan)
  end function ieee_nan
end module tubes_experiment
