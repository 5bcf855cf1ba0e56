!> Stable and unstable manifolds (tubes) of a Lyapunov orbit and their cut with a section
!> theta = theta0: seeds along the orbit stepped off along the transported Floquet eigenvector,
!> propagated (in parallel, OpenMP) to their first crossing of the section's p_theta branch,
!> refined adaptively until the area enclosed by the cut, by Green's theorem on periodic cubic
!> splines (GSL), converges. Theory: docs/tubes.md.
!> Any number of degrees of freedom N: with N > 2 the section is a plane q_k = c (poincare_t of
!> kind SEC_PLANE, its region not used), the cut a closed curve in its 2N - 2 coordinates (the
!> conjugate pairs (q_j, p_j), j /= k, ascending j), and the area the loop integral of p . dq over
!> it, the sum of the pairs' Green areas (docs/tubes.md, "Tubes of halo orbits").
module tubes_manifold
  use, intrinsic :: iso_c_binding, only: c_int, c_double
  use tubes_kinds, only: wp
  use tubes_lapack, only: dlasrt, eigen
  use tubes_quad, only: spline_area, polygon_area
  use tubes_status, only: TUBES_OK, TUBES_EDIRECTION, TUBES_EINPUT, TUBES_ENOCONV, TUBES_EVENT, TUBES_EFAULT, &
                          TUBES_ENOCROSS
  use tubes_ensemble, only: ens_out_t, ens_run, ens_agree, ens_reuse_ok
  use tubes_hamiltonian, only: hamiltonian_t
  use tubes_variational, only: variational_t, make_variational, stm_start, tangent_t, make_tangent
  use tubes_methods, only: integ_choice_t, make_integrator, uses_taylor
  use tubes_taylor, only: taylor_t, taylor_record_t
  use tubes_lanes, only: lane_t, lane_jobs_t
  use tubes_integrator, only: integrator_t, observer_t, event_t, propagate
  use tubes_dop853, only: dop853_t
  use tubes_section_kinds, only: poincare_t
  use tubes_orbits, only: orbit_t
  implicit none
  private

  integer, parameter :: SEED_CHUNK = 16         ! tube seeds per call of run_lanes (a thread's unit)
  integer, parameter, public :: STABLE = -1     !! the stable manifold: integrated backwards
  integer, parameter, public :: UNSTABLE = 1    !! the unstable manifold: integrated forwards

  !> Options of a tube cut (the section itself is a tubes_section_kinds section).
  type, public :: tube_opts_t
    integer :: kind = STABLE          !! STABLE or UNSTABLE
    real(wp) :: eps = 1.0e-6_wp       !! step-off distance from the orbit, position part [units of q]
    integer :: n_init = 64            !! seeds of the first round
    integer :: n_max = 4096           !! seeds at most
    real(wp) :: area_tol = 1.0e-10_wp !! relative change of the area that ends the refinement
    real(wp) :: t_max = 30            !! longest flight from the orbit to the section [s]
    real(wp) :: rtol = 1.0e-12_wp     !! integration tolerances
    real(wp) :: atol = 1.0e-12_wp
    type(integ_choice_t) :: integ     !! the integrator (default DOP853)
    logical :: adaptive = .true.      !! refine where the cut bends or its points spread;
                                      !! .false.: double the seeds uniformly
    logical :: local = .false.        !! compute on this MPI rank alone (the caller has dealt
                                      !! out a coarser level); default: seeds over all ranks
  end type tube_opts_t

  !> The cut: a closed curve in the section's (s, p_s) (the ray's (r, p_r)), ordered by the
  !> seeds' phase tau on the orbit. N > 2: (r, pr) the first pair of the section's coordinates.
  type, public :: tube_cut_t
    integer :: n = 0                  !! points
    real(wp), allocatable :: tau(:)   !! seed phase on the orbit [time]
    real(wp), allocatable :: r(:)     !! s at the crossing (ray: r [cm])
    real(wp), allocatable :: pr(:)    !! p_s at the crossing (ray: p_r [cm/s])
    real(wp), allocatable :: time(:)  !! flight time from the seed to the section [time] (signed)
    real(wp), allocatable :: x(:, :)  !! the state at the crossing (2N)
    real(wp), allocatable :: sec(:, :) !! the section's coordinates at the crossing (2N - 2)
    real(wp), allocatable :: floquet(:) !! the monodromy's unit eigenvector at the orbit's x0 (2N)
    real(wp) :: sigma = 0             !! the branch: the seed at phase tau is x(tau) + sigma eps
                                      !! v(tau) / |v_q(tau)|, v(tau) = Phi(tau) floquet
    real(wp) :: area = 0              !! Green's theorem on periodic splines [cm^2/s] (N > 2: the
                                      !! sum over the section's pairs, the loop integral of p . dq)
    real(wp) :: area_polygon = 0      !! the polygon's (shoelace) area [cm^2/s]
    real(wp) :: area_change = 0       !! |last - previous refinement| [cm^2/s]
    integer :: rounds = 0             !! refinement rounds
    integer, allocatable :: hist_n(:)        !! points after each round
    real(wp), allocatable :: hist_area(:)    !! area after each round
    integer :: n_failed = 0           !! seeds that failed (the cut is then incomplete)
    real(wp) :: fail_tau = 0          !! phase on the orbit of the first failed seed [s]
    integer :: fail_stat = 0          !! and its status
  end type tube_cut_t

  !> The seeds of a tube cut as the Taylor method's lanes' items: the orbit and its transported
  !> eigenvector from one recorded integration (each seed evaluates it at its phase), each seed
  !> then integrated to the section as one_seed does.

  !> The orbit's variational run (state and STM) over one period with DOP853, a copy of the
  !> integrator after every accepted step. The seeds' own runs from 0 to their phases tau take
  !> the same steps as this one until a step is shortened to land on tau (DOP853 looks at the
  !> end time only there), so a seed restarts from the last copy its run would also have
  !> passed and gets the same bits as integrating from 0, in a step or two instead of tau's.
  type, extends(observer_t) :: var_snapshots_t
    type(dop853_t), allocatable :: snap(:)   !! after accepted step j = 1..n
    real(wp), allocatable :: t(:)            !! t(j): the start of step j + 1 (t(0) = 0)
    real(wp), allocatable :: h1(:)           !! h1(j): its first attempt (huge: not known)
    integer :: n = 0
  contains
    procedure :: on_step => snapshot_step
  end type var_snapshots_t

  !> Seeds already integrated: phase tau -> crossing, for the cuts of one orbit with one section,
  !> one step-off and one integration (the caller keeps one store per such set-up). A later cut
  !> looks its seeds up by phase (bit for bit) before integrating them: a seed's crossing
  !> depends on nothing else, so a looked-up seed has the same bits as an integrated one.
  !> A round's tube seeds as an ensemble (tubes_ensemble; in lanes with the Taylor method,
  !> tubes_lanes): item k from phase tau(k), its crossing's (s, p_s), flight time and state
  !> (2 + 1 + 2N reals), as one_seed computes them.
  type, extends(lane_jobs_t) :: seed_jobs_t
    class(hamiltonian_t), allocatable :: ball
    type(orbit_t) :: orb                    !! the orbit (rank 0's)
    real(wp), allocatable :: v0(:)          !! its eigenvector at phase 0
    type(var_snapshots_t) :: snaps          !! its variational run (DOP853)
    type(taylor_record_t) :: orbit          !! (x, w) along one period: w the transported eigenvector (Taylor)
    type(poincare_t) :: psec
    type(tube_opts_t) :: opts
    real(wp) :: sigma = 1
    real(wp), allocatable :: tau(:)         !! the seeds' phases
  contains
    procedure :: item => seed_item
    procedure :: start => seed_start
    procedure :: finish => seed_finish
  end type seed_jobs_t

  type, public :: seed_store_t
    integer :: n = 0
    real(wp), allocatable :: tau(:)         !! sorted
    real(wp), allocatable :: p(:, :), tc(:), xc(:, :)
  end type seed_store_t

  public :: tube_cut, floquet_vector, cut_coords

contains

  !> Floquet eigenvector of the monodromy for the unstable (kind = UNSTABLE) or stable
  !> multiplier, unit length: of the real multipliers the largest in modulus, or the smallest
  !> (in 3 DOF an elliptic pair exp(+-i theta) may have a real part below the stable one's).
  !> TUBES_EINPUT when that multiplier is not hyperbolic (|mu| within 1e-6 of 1: the orbit has no
  !> stable and unstable manifolds).
  subroutine floquet_vector(mono, kind, v, stat)
    real(wp), intent(in) :: mono(:, :)
    integer, intent(in) :: kind
    real(wp), intent(out) :: v(:)
    integer, intent(out) :: stat
    real(wp) :: wr(size(v)), wi(size(v)), vr(size(v), size(v))
    integer :: k
    real(wp) :: modulus(size(v))
    logical :: real_mu(size(v))
    call eigen(mono, wr, wi, stat, vr)
    if (stat /= TUBES_OK) return
    real_mu = wi == 0
    modulus = abs(wr)
    if (kind == UNSTABLE) then
      k = maxloc(modulus, 1, mask=real_mu)
    else
      k = minloc(modulus, 1, mask=real_mu)
    end if
    stat = TUBES_EINPUT
    if (k < 1) return
    if (abs(modulus(k) - 1) <= 1.0e-6_wp) return
    v = vr(:, k)/sqrt(sum(vr(:, k)**2))
    stat = TUBES_OK
  end subroutine floquet_vector

  !> One seed: the orbit state at phase tau stepped off by sigma eps along the transported
  !> eigenvector, propagated to its first crossing of the section branch.
  subroutine one_seed(ball, orb, v0, sigma, tau, psec, opts, snaps, pc, tcross, xc, stat, any_branch)
    class(hamiltonian_t), intent(in) :: ball
    type(orbit_t), intent(in) :: orb
    real(wp), intent(in) :: v0(:), sigma, tau
    type(poincare_t), intent(in) :: psec
    type(tube_opts_t), intent(in) :: opts
    type(var_snapshots_t), intent(in) :: snaps   !! the orbit's variational run (may be empty)
    real(wp), intent(out) :: pc(:), tcross, xc(:)   !! pc: the section's coordinates (cut_coords)
    integer, intent(out) :: stat
    logical, intent(in), optional :: any_branch   !! to the first crossing of either direction
    class(integrator_t), allocatable :: ig
    real(wp) :: z(size(v0) + size(v0)**2), v(size(v0)), x(size(v0))
    class(event_t), allocatable :: sec
    integer :: n2, j
    n2 = size(v0)
    pc = 0
    tcross = 0
    xc = 0
    j = 0                 ! the last snapshot this seed's run from 0 passes whole
    do while (j < snaps%n)
      if (snaps%h1(j)*(1 + 64*epsilon(1.0_wp)) >= abs(tau - snaps%t(j))) exit   ! as dop853_step
      j = j + 1
    end do
    if (j > 0) then
      allocate (ig, source=snaps%snap(j))
      z = snaps%snap(j)%x_new
    else
      call var_integrator(ball, opts, ig, stat)
      if (stat /= TUBES_OK) return
      z = stm_start(orb%x0)
    end if
    stat = TUBES_OK
    if (tau > ig%t) call propagate(ig, z, tau, stat)
    if (stat < 0) return
    v = matmul(reshape(z(n2 + 1:), [n2, n2]), v0)
    x = z(1:n2) + sigma*opts%eps*v/sqrt(sum(v(1:n2/2)**2))
    if (present(any_branch)) then
      if (any_branch) then
        call psec%return_event(sec)
      else
        call psec%event(.true., sec)
      end if
    else
      call psec%event(.true., sec)
    end if
    call ig%init(ball, 0.0_wp)
    ig%rtol = opts%rtol
    ig%atol = opts%atol
    call propagate(ig, x, real(opts%kind, wp)*opts%t_max, stat, event=sec)
    if (stat == TUBES_EVENT) then
      stat = TUBES_OK
      tcross = ig%t
      xc = x
      pc = cut_coords(psec, x)
    else if (stat >= 0) then
      stat = TUBES_ENOCROSS    ! no crossing within t_max
    end if
  end subroutine one_seed

  !> The integrator of a seed's variational run (its start at phase 0).
  subroutine var_integrator(ball, opts, ig, stat)
    class(hamiltonian_t), intent(in) :: ball
    type(tube_opts_t), intent(in) :: opts
    class(integrator_t), allocatable, intent(out) :: ig
    integer, intent(out) :: stat
    type(variational_t) :: var
    call make_variational(var, ball)
    call make_integrator(opts%integ, ig, stat, extended=.true., f=var, rtol=opts%rtol, atol=opts%atol)
  end subroutine var_integrator

  !> The orbit's variational run over one period, recorded in snaps when the method is DOP853
  !> with its own step control (else snaps stays empty and every seed starts from 0).
  subroutine record_variational(ball, orb, opts, snaps, stat)
    class(hamiltonian_t), intent(in) :: ball
    type(orbit_t), intent(in) :: orb
    type(tube_opts_t), intent(in) :: opts
    type(var_snapshots_t), intent(out) :: snaps
    integer, intent(out) :: stat
    class(integrator_t), allocatable :: ig
    real(wp), allocatable :: z(:)
    call var_integrator(ball, opts, ig, stat)
    if (stat /= TUBES_OK) return
    select type (ig)
    type is (dop853_t)
      if (ig%h > 0) return
    class default
      return
    end select
    allocate (snaps%snap(64), snaps%t(0:64), snaps%h1(0:64))
    snaps%t(0) = ig%t
    z = stm_start(orb%x0)
    call propagate(ig, z, orb%period, stat, observer=snaps)
    if (stat < 0) snaps%n = 0     ! the seeds then fail (or not) on their own
    stat = TUBES_OK
  end subroutine record_variational

  !> After accepted step j: the copy, the step's start time and its first attempt's size.
  subroutine snapshot_step(self, ig, t_hi)
    class(var_snapshots_t), intent(inout) :: self
    class(integrator_t), intent(inout) :: ig
    real(wp), intent(in) :: t_hi
    type(dop853_t), allocatable :: more(:)
    real(wp), allocatable :: tmore(:), hmore(:)
    integer :: j
    select type (ig)
    type is (dop853_t)
      j = self%n + 1
      if (j > size(self%snap)) then
        allocate (more(2*size(self%snap)), tmore(0:2*size(self%snap)), hmore(0:2*size(self%snap)))
        more(1:self%n) = self%snap(1:self%n)
        tmore(0:self%n) = self%t(0:self%n)
        hmore(0:self%n) = self%h1(0:self%n)
        call move_alloc(more, self%snap)
        call move_alloc(tmore, self%t)
        call move_alloc(hmore, self%h1)
      end if
      self%snap(j) = ig
      self%t(j) = ig%t
      self%h1(j) = ig%h_next        ! the next step's first attempt
      ! the first step's first attempt (start_step's) is its accepted size unless rejected
      if (j == 1) self%h1(0) = merge(abs(ig%h_used), huge(1.0_wp), ig%nrejected == 0)
      self%n = j
    class default
      self%stop_now = .true.
    end select
  end subroutine snapshot_step

  !> Seed k: the orbit's state at its phase, stepped off along the transported eigenvector.
  subroutine seed_start(self, k, lane, stat)
    class(seed_jobs_t), intent(inout) :: self
    integer, intent(in) :: k
    type(lane_t), intent(inout) :: lane
    integer, intent(out) :: stat
    real(wp) :: z(self%orbit%dim)
    class(event_t), allocatable :: sec
    integer :: n2
    n2 = self%orbit%dim/2
    call self%orbit%eval(self%tau(k), z, stat)
    if (stat /= TUBES_OK) return
    lane%x = z(1:n2) + self%sigma*self%opts%eps*z(n2 + 1:)/sqrt(sum(z(n2 + 1:n2 + n2/2)**2))
    call lane%setup(self%ball, self%opts%integ%h, self%opts%rtol, self%opts%atol)
    lane%tend = real(self%opts%kind, wp)*self%opts%t_max
    call self%psec%event(.true., sec)
    call move_alloc(sec, lane%event)
  end subroutine seed_start

  !> Seed k's crossing, as one_seed's.
  subroutine seed_finish(self, k, lane, out)
    class(seed_jobs_t), intent(in) :: self
    integer, intent(in) :: k
    type(lane_t), intent(inout) :: lane
    type(ens_out_t), intent(inout) :: out
    integer :: nc
    nc = size(lane%x) - 2
    out%st(k) = lane%stat
    out%r(:, k) = 0
    if (lane%stat == TUBES_EVENT) then
      out%st(k) = TUBES_OK
      out%r(nc + 1, k) = lane%ig%t
      out%r(nc + 2:, k) = lane%x
      out%r(1:nc, k) = cut_coords(self%psec, lane%x)
    else if (lane%stat >= 0) then
      out%st(k) = TUBES_ENOCROSS
    end if
  end subroutine seed_finish

  !> Seed k of the round, as one_seed computes it.
  subroutine seed_item(self, k, out)
    class(seed_jobs_t), intent(in) :: self
    integer, intent(in) :: k
    type(ens_out_t), intent(inout) :: out
    integer :: nc
    nc = size(self%v0) - 2
    call one_seed(self%ball, self%orb, self%v0, self%sigma, self%tau(k), self%psec, self%opts, self%snaps, &
                  out%r(1:nc, k), out%r(nc + 1, k), out%r(nc + 2:, k), out%st(k))
  end subroutine seed_item

  !> The orbit and the eigenvector v0 transported along one period (tangent equations), every
  !> step recorded: the seeds' starts for the Taylor method.
  subroutine record_orbit(ball, orb, v0, opts, rec, stat)
    class(hamiltonian_t), intent(in) :: ball
    type(orbit_t), intent(in) :: orb
    real(wp), intent(in) :: v0(:)
    type(tube_opts_t), intent(in) :: opts
    type(taylor_record_t), intent(out) :: rec
    integer, intent(out) :: stat
    type(tangent_t) :: tan
    type(taylor_t) :: ig
    real(wp) :: z(2*size(v0))
    call make_tangent(tan, ball)
    call ig%init(tan, 0.0_wp)
    ig%h = opts%integ%h
    ig%rtol = opts%rtol
    ig%atol = opts%atol
    z = [orb%x0, v0]
    call propagate(ig, z, orb%period, stat, observer=rec)
  end subroutine record_orbit

  !> The cut of the tube of orbit orb (period, x0 and monodromy set) with the section of opts.
  !> well_dir: a vector from the saddle towards the well the section lies in; the branch of
  !> the manifold on that side is taken. stat < 0 if a seed failed (no crossing within t_max,
  !> integration failure) or the area did not converge within n_max seeds.
  subroutine tube_cut(ball, orb, well_dir, psec, opts, cut, stat, store)
    class(hamiltonian_t), intent(in) :: ball
    type(orbit_t), intent(in) :: orb
    real(wp), intent(in) :: well_dir(:)      !! from the saddle towards the section's well (N)
    type(poincare_t), intent(in) :: psec     !! the section
    type(tube_opts_t), intent(in) :: opts
    type(tube_cut_t), intent(out) :: cut
    integer, intent(out) :: stat
    !> seeds of earlier cuts of this set-up (looked up, and this cut's added; one MPI rank only)
    type(seed_store_t), intent(inout), optional :: store
    type(orbit_t) :: orb0
    type(seed_jobs_t) :: ens
    real(wp) :: v0(size(orb%x0)), sigma, a_old, a_new, span(size(orb%x0) - 2), dc
    real(wp), allocatable :: tau(:), pcs(:, :), tcs(:), xcs(:, :), newtau(:), chord(:), medc
    logical, allocatable :: split(:)
    integer, allocatable :: st(:)
    integer :: n, i, j, m, info, nconv, nc, l
    nc = size(orb%x0) - 2     ! the section's coordinates: (s, p_s) in 2 DOF
    if (opts%n_init < 8 .or. opts%eps <= 0 .or. orb%period <= 0) then
      stat = TUBES_EINPUT
      return
    end if
    ! every rank seeds from rank 0's orbit (tubes_ensemble: replicated inputs agree)
    orb0 = orb
    call ens_agree(orb0%x0, opts%local)
    call ens_agree(orb0%period, opts%local)
    call ens_agree(orb0%monodromy, opts%local)
    call floquet_vector(orb0%monodromy, opts%kind, v0, stat)
    if (stat /= TUBES_OK) return
    call ens_agree(v0, opts%local)
    sigma = sign(1.0_wp, dot2(v0, well_dir))
    cut%floquet = v0
    cut%sigma = sigma
    ens = seed_jobs_t(lanes=uses_taylor(opts%integ), psec=psec, opts=opts, sigma=sigma, orb=orb0, v0=v0)
    allocate (ens%ball, source=ball)
    if (ens%lanes) then   ! the seeds' starts from one integration
      call record_orbit(ball, orb0, v0, opts, ens%orbit, stat)
    else
      call record_variational(ball, orb0, opts, ens%snaps, stat)
    end if
    if (stat < 0) return
    n = opts%n_init
    allocate (tau(n))
    tau = [((i - 1)*orb0%period/n, i = 1, n)]
    allocate (pcs(nc, 0), tcs(0), xcs(size(v0), 0), st(0))
    call seeds(tau, 1, n)
    if (stat < 0) then
      call report_failed()
      return
    end if
    if (opts%kind == STABLE) call first_crossing(stat)   ! (the unstable tube's cut on the branch
    if (stat < 0) return                                 ! is the Poincare map's image: below)
    allocate (cut%hist_n(0), cut%hist_area(0))
    a_old = huge(1.0_wp)
    nconv = 0
    do
      call area_of(a_new, info)
      call ens_agree(a_new, opts%local)   ! the refinement decisions must agree on every rank
      if (info /= 0) then
        stat = TUBES_ENOCONV
        return
      end if
      cut%rounds = cut%rounds + 1
      cut%hist_n = [cut%hist_n, n]
      cut%hist_area = [cut%hist_area, a_new]
      cut%area_change = abs(a_new - a_old)
      if (cut%area_change <= opts%area_tol*abs(a_new)) then
        nconv = nconv + 1
        if (nconv >= 2) exit
      else
        nconv = 0
      end if
      if (n >= opts%n_max) then
        stat = TUBES_ENOCONV
        exit
      end if
      a_old = a_new
      ! refine: intervals whose chord (scaled) exceeds twice the median, or all of them
      allocate (chord(n), split(n))
      do l = 1, nc       ! the cut's extent in each coordinate (2 DOF: r, p_r)
        span(l) = max(1.0e-300_wp, maxval(pcs(l, :)) - minval(pcs(l, :)))
      end do
      if (nc > 2) then   ! N > 2: one scale for the positions, one for the momenta (a pair that
        span(1:nc:2) = maxval(span(1:nc:2))   ! stays ~0, z of a planar orbit, is no rounding
        span(2:nc:2) = maxval(span(2:nc:2))   ! noise blown up to the cut's size)
      end if
      do i = 1, n
        j = mod(i, n) + 1
        chord(i) = hypot((pcs(1, j) - pcs(1, i))/span(1), (pcs(2, j) - pcs(2, i))/span(2))
        do l = 3, nc - 1, 2            ! N > 2: the other pairs
          dc = hypot((pcs(l, j) - pcs(l, i))/span(l), (pcs(l + 1, j) - pcs(l + 1, i))/span(l + 1))
          chord(i) = hypot(chord(i), dc)
        end do
      end do
      medc = median(chord)
      split = chord > 2*medc
      if (.not. opts%adaptive .or. count(split) == 0 .or. nconv > 0) split = .true.
      m = count(split)
      if (n + m > opts%n_max) then
        stat = TUBES_ENOCONV
        deallocate (chord, split)
        exit
      end if
      allocate (newtau(m))
      j = 0
      do i = 1, n
        if (split(i)) then
          j = j + 1
          if (i < n) then
            newtau(j) = 0.5_wp*(tau(i) + tau(i + 1))
          else
            newtau(j) = 0.5_wp*(tau(n) + orb0%period)
          end if
        end if
      end do
      tau = [tau, newtau]
      call seeds(tau, n + 1, n + m)
      if (stat < 0) then
        call report_failed()
        return
      end if
      call sort_by_tau()
      n = n + m
      deallocate (chord, split, newtau)
    end do
    cut%n = n
    cut%tau = tau
    cut%r = pcs(1, :)
    cut%pr = pcs(2, :)
    cut%time = tcs
    cut%x = xcs
    cut%sec = pcs
    cut%area = abs(a_new)
    cut%area_polygon = -polygon_area(pcs(1, :), pcs(2, :))   ! Green: the integral of p dr is minus the
    do l = 3, nc - 1, 2                                        ! shoelace sum of (r, p)
      cut%area_polygon = cut%area_polygon - polygon_area(pcs(l, :), pcs(l + 1, :))
    end do
    cut%area_polygon = abs(cut%area_polygon)
    if (stat == TUBES_ENOCONV .and. cut%area_change <= 1.0e3_wp*opts%area_tol*abs(a_new)) stat = TUBES_OK
  contains
    subroutine seeds(tt, i1, i2)
      real(wp), intent(in) :: tt(:)
      integer, intent(in) :: i1, i2
      real(wp) :: p(nc, i2 - i1 + 1), tc(i2 - i1 + 1), xc(size(v0), i2 - i1 + 1)
      integer :: s(i2 - i1 + 1), k, nk, at(i2 - i1 + 1)
      logical :: found(i2 - i1 + 1), keep
      type(ens_out_t) :: out
      nk = i2 - i1 + 1                   ! seed k of this round is seed i1 + k - 1 of the cut
      p = 0
      tc = 0
      xc = 0
      found = .false.
      keep = .false.
      if (present(store)) keep = ens_reuse_ok('seed', opts%local)
      if (keep) then
        do k = i1, i2
          at(k - i1 + 1) = store_find(store, tt(k))
        end do
        found = at > 0
        do k = 1, nk
          if (.not. found(k)) cycle
          p(:, k) = store%p(:, at(k))
          tc(k) = store%tc(at(k))
          xc(:, k) = store%xc(:, at(k))
        end do
      end if
      ens%tau = tt(i1:i2)
      call ens_run(ens, nk, out, nc + 1 + size(v0), 0, fault='seed', first=i1, local=opts%local, skip=found, &
                   chunk=merge(SEED_CHUNK, 1, ens%lanes))
      do k = 1, nk
        if (found(k)) cycle
        p(:, k) = out%r(1:nc, k)
        tc(k) = out%r(nc + 1, k)
        xc(:, k) = out%r(nc + 2:, k)
      end do
      s = out%st
      if (keep) call store_add(store, tt(i1:i2), p, tc, xc, s == TUBES_OK .and. .not. found)
      pcs = reshape([reshape(pcs, [size(pcs)]), reshape(p, [size(p)])], [nc, i2])
      tcs = [tcs, tc]
      xcs = reshape([reshape(xcs, [size(xcs)]), reshape(xc, [size(xc)])], [size(v0), i2])
      st = [st, s]
      if (any(s < 0)) stat = minval(s)
    end subroutine seeds
    subroutine first_crossing(stat)     ! the stable tube meets the section on its branch first
      ! The stable tube's cut is of its first crossing of the section, as the Monte Carlo check's
      ! transit test ends at any crossing (p_trans is the fraction of the section that transits
      ! before it meets the section again): seed 1 followed to a crossing of either direction
      ! must not cross the other way earlier (the ball's S14 tube with the ray U1^- took its
      ! second crossing, p_trans a number and the Monte Carlo check 0 of 52 inside points
      ! transiting). The unstable tube's cut is its first crossing of the branch whatever came
      ! before: the image the Poincare map of the branch shows (the ball's unstable S12 tube
      ! meets U1^+ first, then U1^-).
      integer, intent(out) :: stat
      real(wp) :: pc1(nc), t1, x1(size(v0))
      call one_seed(ball, orb0, v0, sigma, tau(1), psec, opts, ens%snaps, pc1, t1, x1, stat, any_branch=.true.)
      if (stat < 0) return
      if (abs(t1) < abs(tcs(1))*(1 - 1.0e-6_wp)) stat = TUBES_EDIRECTION
    end subroutine first_crossing
    subroutine sort_by_tau()            ! merge the two sorted runs tau(1:n), tau(n+1:n+m)
      integer :: idx(size(tau)), k, a, b, nt
      nt = size(tau)
      a = 1
      b = n + 1
      do k = 1, nt
        if (b > nt) then
          idx(k) = a
          a = a + 1
        else if (a > n) then
          idx(k) = b
          b = b + 1
        else if (tau(b) < tau(a)) then
          idx(k) = b
          b = b + 1
        else
          idx(k) = a
          a = a + 1
        end if
      end do
      tau = tau(idx)
      pcs = pcs(:, idx)
      tcs = tcs(idx)
      xcs = xcs(:, idx)
      st = st(idx)
    end subroutine sort_by_tau
    subroutine area_of(a, info)
      real(wp), intent(out) :: a
      integer, intent(out) :: info
      real(wp) :: rr(size(tau)), pp(size(tau)), a2
      integer :: l2
      rr = pcs(1, :)      ! contiguous copies for the C side
      pp = pcs(2, :)
      info = spline_area(size(tau), tau, rr, pp, orb0%period, a)
      do l2 = 3, nc - 1, 2          ! N > 2: p . dq summed over the section's pairs
        if (info /= 0) return
        rr = pcs(l2, :)
        pp = pcs(l2 + 1, :)
        info = spline_area(size(tau), tau, rr, pp, orb0%period, a2)
        a = a + a2
      end do
    end subroutine area_of
    subroutine report_failed()         ! the failed seeds, for the caller's diagnostics
      integer :: k
      cut%n_failed = count(st < 0)
      do k = 1, size(st)
        if (st(k) < 0) then
          cut%fail_tau = tau(k)
          cut%fail_stat = st(k)
          exit
        end if
      end do
    end subroutine report_failed
  end subroutine tube_cut

  !> The section's coordinates of a state x (2N) on it: 2 DOF the section's (s, p_s) (the ray's
  !> (r, p_r)); N > 2 (a plane q_k = c) the conjugate pairs (q_j, p_j), j /= k, ascending j.
  pure function cut_coords(psec, x) result(pc)
    type(poincare_t), intent(in) :: psec
    real(wp), intent(in) :: x(:)
    real(wp) :: pc(size(x) - 2)
    integer :: nd, j, l
    nd = size(x)/2
    if (nd == 2) then
      pc = psec%coords(x)
      return
    end if
    l = 0
    do j = 1, nd
      if (j == psec%k) cycle
      pc(l + 1:l + 2) = [x(j), x(nd + j)]
      l = l + 2
    end do
  end function cut_coords

  !> The index of phase tau in the store (bit for bit), or 0.
  pure integer function store_find(store, tau) result(i)
    type(seed_store_t), intent(in) :: store
    real(wp), intent(in) :: tau
    integer :: lo, hi, mid
    i = 0
    lo = 1
    hi = store%n
    do while (lo <= hi)
      mid = (lo + hi)/2
      if (store%tau(mid) == tau) then
        i = mid
        return
      else if (store%tau(mid) < tau) then
        lo = mid + 1
      else
        hi = mid - 1
      end if
    end do
  end function store_find

  !> Add the seeds where new is set (phases not in the store, increasing), keeping the store's
  !> phases sorted.
  subroutine store_add(store, tau, p, tc, xc, new)
    type(seed_store_t), intent(inout) :: store
    real(wp), intent(in) :: tau(:), p(:, :), tc(:), xc(:, :)
    logical, intent(in) :: new(:)
    real(wp), allocatable :: t2(:), p2(:, :), tc2(:), xc2(:, :)
    integer, allocatable :: idx(:)
    integer :: m, k, a, b, j
    m = count(new)
    if (m == 0) return
    if (.not. allocated(store%tau)) allocate (store%tau(0), store%p(size(p, 1), 0), store%tc(0), store%xc(size(xc, 1), 0))
    idx = pack([(k, k = 1, size(tau))], new)
    if (m > 1) then               ! a round's phases come in increasing order; else keep none
      if (any(tau(idx(2:)) <= tau(idx(:m - 1)))) return
    end if
    allocate (t2(store%n + m), p2(size(p, 1), store%n + m), tc2(store%n + m), xc2(size(xc, 1), store%n + m))
    a = 1
    b = 1
    do j = 1, store%n + m            ! merge the store's run and the new (sorted) one
      if (b > m) then
        call take_old()
      else if (a > store%n) then
        call take_new()
      else if (store%tau(a) < tau(idx(b))) then
        call take_old()
      else
        call take_new()
      end if
    end do
    call move_alloc(t2, store%tau)
    call move_alloc(p2, store%p)
    call move_alloc(tc2, store%tc)
    call move_alloc(xc2, store%xc)
    store%n = store%n + m
  contains
    subroutine take_old()
      t2(j) = store%tau(a)
      p2(:, j) = store%p(:, a)
      tc2(j) = store%tc(a)
      xc2(:, j) = store%xc(:, a)
      a = a + 1
    end subroutine take_old
    subroutine take_new()
      t2(j) = tau(idx(b))
      p2(:, j) = p(:, idx(b))
      tc2(j) = tc(idx(b))
      xc2(:, j) = xc(:, idx(b))
      b = b + 1
    end subroutine take_new
  end subroutine store_add

  !> The configuration part of v (first N of 2N components) dotted with w (N): the side of the
  !> saddle a step along v goes to. Written out as the 2-DOF code always was (the same bits).
  pure real(wp) function dot2(v, w) result(d)
    real(wp), intent(in) :: v(:), w(:)
    integer :: k
    d = v(1)*w(1)
    do k = 2, size(w)
      d = d + v(k)*w(k)
    end do
  end function dot2

  !> The median (the upper one for an even count), by LAPACK's sort.
  real(wp) function median(a) result(m)
    real(wp), intent(in) :: a(:)
    real(wp) :: b(size(a))
    integer :: info
    b = a
    call dlasrt('I', size(b), b, info)
    if (info /= 0) error stop '[tubes_manifold:median] dlasrt refused a finite array'   ! cannot happen
    m = b((size(b) + 1)/2)
  end function median
end module tubes_manifold
