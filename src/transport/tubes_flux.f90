!> The flux of reacting trajectories through a rank-1 saddle's bottleneck, in N degrees of
!> freedom (the paper's section II; docs/theory.md, "Flux in N degrees of freedom"):
!>
!> - leading order: f = (2 pi)^(N-1) dE^(N-1) / ((N-1)! prod omega_k) (T_po dE in 2 DOF);
!> - by sampling, without a normal form, for H quadratic in the momenta (natural or gyroscopic:
!>   quadratic_parts): the dividing surface DS is the configuration hyperplane through the saddle
!>   normal to its reaction coordinate n (the unstable eigenvector's q part; for a model that is
!>   not natural put in the +1 space of its reversor, so that the DS is mapped to itself).
!>   In the rotated canonical coordinates Q = R (q - q_s), P = R p (R orthogonal, first row n)
!>   the flux form on the energy shell is dQ' dP' (the primes: components 2..N), so the flux is
!>   an integral over (Q', P'). At fixed Q' the momenta with a crossing of the shell form the
!>   ellipsoid 1/2 P'^T S P' <= E - V(q) (S the Schur complement of the kinetic matrix in the
!>   rotated frame, P1 eliminated), whose volume w(Q') = c_(N-1) (2 (E - V))^((N-1)/2) / sqrt(det S)
!>   is integrated exactly; Q' is sampled uniformly in a box around the saddle (the part of
!>   {V < E} seen from the saddle along straight segments: other bottlenecks that the hyperplane
!>   cuts farther out are excluded) and P' uniformly in the ellipsoid. Each point, on the branch dQ1/dt > 0, is followed forwards, and its
!>   time-reversed image (q, -p) forwards (natural systems: that is the point's past), until
!>   they leave the slab |(q - q_s) . n| <= gate (another model's past is followed backwards;
!>   a gate below twice the NHIM's linear reach along n is refused): c = +1 for a passage from the - side to the +
!>   side, -1 for the reverse, 0 otherwise. Then f = vol(box) E[w c], whose standard error is the
!>   sample's. Recrossings cancel in pairs, so f is the flux of trajectories passing through the
!>   bottleneck, exact whatever the choice of DS (in 2 DOF: the Lyapunov orbit's action).
module tubes_flux
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
  use tubes_kinds, only: wp, PI
  use tubes_status, only: TUBES_OK, TUBES_EINPUT, TUBES_EMODEL, TUBES_EFAULT, TUBES_EOUTSIDE, TUBES_ENARROW, TUBES_ENOREGION, &
                         TUBES_EPASTEND
  use tubes_hamiltonian, only: hamiltonian_t, quadratic_parts, veff, quadratic_in_p
  use tubes_equilibria, only: equilibrium_t, neck_normal, nhim_reach, gate_holds_nhim
  use tubes_integrator, only: integrator_t, observer_t, propagate
  use tubes_methods, only: integ_choice_t, make_integrator, uses_taylor
  use tubes_quad, only: rng_uniform
  use tubes_ensemble, only: ensemble_t, ens_out_t, ens_run, ens_agree
  use tubes_lanes, only: lane_t, lane_jobs_t
  implicit none
  private

  integer, parameter :: MAXN = 3
  integer, parameter :: NSTAR = 64     !! points checked on the segment from the saddle to a sample
  integer, parameter :: FLUX_CHUNK = 64 !! integrations per call of run_lanes (a thread's unit of work)

  !> An observer that stops an integration with a class for it (outcome_of).
  type, abstract, extends(observer_t) :: classifier_t
    integer :: outcome = 0   !! the class, 0 while none
  end type classifier_t

  !> Stops an integration once it leaves the slab |(q - q_s) . n| <= dist; outcome = the side,
  !> +1 or -1.
  type, extends(classifier_t) :: slab_t
    real(wp) :: origin(MAXN) = 0, normal(MAXN) = 0, dist = 0
    integer :: n = 0
  contains
    procedure :: on_step => slab_on_step
  end type slab_t

  !> Integrates until the trajectory passes the saddle's slab on the far side (outcome 1, a
  !> transit) or crosses the section q_k = c again in its direction (outcome -1, a return):
  !> checked at NSUB points of every step on the dense output.
  type, extends(classifier_t) :: transit_t
    real(wp) :: qs(MAXN) = 0, ns(MAXN) = 0, gate = 0, c = 0, s_prev = 0, t_prev = 0
    integer :: n = 0, k = 1, dir = 1
  contains
    procedure :: on_step => transit_on_step
  end type transit_t

  !> The flux's samples, first pass (tubes_ensemble): sample i's point and weight, no integration.
  !> Its reals: w, then its state x (2N; NaN where it has none), its integer: 0 (to integrate) or
  !> 3 (outside the shell). The components are flux_sampled's set-up.
  type, extends(ensemble_t) :: flux_pts_t
    class(hamiltonian_t), allocatable :: model
    integer :: nd = 0
    real(wp), allocatable :: u(:)             !! the uniforms, 2 (N - 1) per sample
    real(wp), allocatable :: box(:, :)        !! the box of Q' (2, N - 1)
    real(wp) :: r(MAXN, MAXN) = 0, q0(MAXN) = 0, energy = 0, cball = 0
  contains
    procedure :: item => point_item
  end type flux_pts_t

  !> The flux's samples, second pass: the integrations that classify them, one item each (a
  !> sample's future, and off the section its past: two items), as outcome_of integrates them; in
  !> lanes with the Taylor method (tubes_lanes). Item j's integer: the class obs gives (0: none by
  !> tend), its status: outcome_of's.
  type, extends(lane_jobs_t) :: flux_runs_t
    class(hamiltonian_t), allocatable :: model
    class(classifier_t), allocatable :: obs   !! the classifier (slab_t or transit_t), as it starts
    real(wp), allocatable :: x0(:, :)         !! the start states (2N, items)
    real(wp), allocatable :: tend(:)          !! the end times (items): t_max, or -t_max (the past)
    real(wp) :: tol = 0
    type(integ_choice_t) :: integ
  contains
    procedure :: item => run_item
    procedure :: start => run_start
    procedure :: finish => run_finish
  end type flux_runs_t

  !> What flux_sampled found.
  type, public :: flux_result_t
    real(wp) :: flux = 0            !! f [action^(N-1)]
    real(wp) :: err = 0             !! its standard error
    integer :: n_reactive = 0       !! samples with c /= 0
    integer :: n_recrossing = 0     !! samples with c = -1
    integer :: n_undecided = 0      !! samples whose future or past stayed in the slab to t_max
    integer :: n_inside = 0         !! samples with V(q) < E (w > 0)
    real(wp) :: box(2, MAXN - 1) = 0 !! the sampling box of Q' [lo, hi per axis]
    !> section mode (flux_sampled with plane): the energy surface's volume on the section and
    !> the fraction of it that transits before returning
    real(wp) :: volume = 0, volume_err = 0, fraction = 0, fraction_err = 0
    integer :: n_transit = 0, n_return = 0
    !> the NHIM's reach along the reaction coordinate n at dE, linear: max_k of mode k's amplitude
    !> sqrt(2 dE / (omega_k |a^T J b|)) times |(n . a_q, n . b_q)| (a + i b its eigenvector)
    real(wp) :: nhim_reach = 0
    !> section mode: every sample, its state (2N, n; NaN outside the shell), weight w (n) and
    !> class (n: 1 transit, -1 return, 2 undecided, 3 outside the shell)
    real(wp), allocatable :: x(:, :), w(:)
    integer, allocatable :: cls(:)
  end type flux_result_t

  public :: flux_leading_order, flux_sampled

contains

  !> (2 pi)^(N-1) dE^(N-1) / ((N-1)! prod omega_k).
  pure real(wp) function flux_leading_order(omegas, de) result(f)
    real(wp), intent(in) :: omegas(:), de
    integer :: k
    f = ieee_value(1.0_wp, ieee_quiet_nan)      ! a degenerate saddle (a frequency 0): none
    if (any(.not. omegas > 0)) return
    f = 1
    do k = 1, size(omegas)
      f = f*2*PI*de/(k*omegas(k))
    end do
  end function flux_leading_order

  subroutine slab_on_step(self, ig, t_hi)
    class(slab_t), intent(inout) :: self
    class(integrator_t), intent(inout) :: ig
    real(wp), intent(in) :: t_hi
    real(wp) :: x(ig%f%dim()), s
    call ig%interp(t_hi, x)
    s = dot_product(x(1:self%n) - self%origin(1:self%n), self%normal(1:self%n))
    self%stop_now = abs(s) > self%dist
    if (self%stop_now) self%outcome = merge(1, -1, s > 0)
  end subroutine slab_on_step

  subroutine transit_on_step(self, ig, t_hi)
    class(transit_t), intent(inout) :: self
    class(integrator_t), intent(inout) :: ig
    real(wp), intent(in) :: t_hi
    integer, parameter :: NSUB = 8
    real(wp) :: x(ig%f%dim()), t, s, d
    integer :: j
    do j = 1, NSUB
      t = self%t_prev + (t_hi - self%t_prev)*j/NSUB
      call ig%interp(t, x)
      d = dot_product(x(1:self%n) - self%qs(1:self%n), self%ns(1:self%n))
      s = x(self%k) - self%c
      if (d > self%gate) then
        self%outcome = 1
      else if (self%dir*self%s_prev < 0 .and. self%dir*s >= 0) then
        self%outcome = -1
      end if
      self%s_prev = s
      if (self%outcome /= 0) then
        self%stop_now = .true.
        exit
      end if
    end do
    self%t_prev = t_hi
  end subroutine transit_on_step

  !> The class observer obs0 gives x0's trajectory to t_max (t_max < 0: its past), 0 if it gives
  !> none by then: for slab_t the side by which it leaves the slab (+1, -1), for transit_t 1 (a
  !> transit) or -1 (a return to the section).
  subroutine outcome_of(model, obs0, x0, t_max, tol, integ, outcome, stat)
    class(hamiltonian_t), intent(in) :: model
    class(classifier_t), intent(in) :: obs0
    real(wp), intent(in) :: x0(:), t_max, tol
    type(integ_choice_t), intent(in) :: integ
    integer, intent(out) :: outcome, stat
    class(classifier_t), allocatable :: obs
    class(integrator_t), allocatable :: ig
    real(wp) :: x(size(x0))
    outcome = 0
    call make_integrator(integ, ig, stat, f=model, rtol=tol, atol=tol)
    if (stat /= TUBES_OK) return
    allocate (obs, source=obs0)
    x = x0
    call propagate(ig, x, t_max, stat, observer=obs)
    if (stat < 0) return
    stat = TUBES_OK
    outcome = obs%outcome
  end subroutine outcome_of

  !> The extent of {V <= E} from q_s along +-e: the first t with V(q_s + t e) > E (marching in
  !> steps of h0, then bisection); t_cap if V stays below E up to there. (Doubling the step
  !> instead could step over a ridge lower than E into the next well or neck: the ball's S12 line
  !> at dE = 770 ran from 5.8 out to 16 across the centre.)
  real(wp) function extent(model, qs, e, energy, h0, t_cap) result(t)
    class(hamiltonian_t), intent(in) :: model
    real(wp), intent(in) :: qs(:), e(:), energy, h0, t_cap
    real(wp) :: lo, hi
    integer :: k
    lo = 0
    hi = h0
    do while (veff(model, qs + hi*e) <= energy)
      lo = hi
      hi = hi + h0
      if (hi > t_cap) then
        t = t_cap
        return
      end if
    end do
    do k = 1, 60
      t = (lo + hi)/2
      if (veff(model, qs + t*e) <= energy) then
        lo = t
      else
        hi = t
      end if
    end do
    t = hi
  end function extent

  !> Whether V_eff rises from the saddle qs along e up to the energy surface at t (64 samples; a
  !> fall below the highest value passed by more than rounding and 1e-6 de is a dip): the dividing
  !> surface then spans one bottleneck. A dip means it passes over a ridge into another well or
  !> bottleneck: the ball above its central maximum (dE > 777 at S12, where the orbit family ends),
  !> whose 'flux' would be the flux over the top and through the opposite neck as well.
  logical function rises(model, qs, e, t, energy, de) result(ok)
    class(hamiltonian_t), intent(in) :: model
    real(wp), intent(in) :: qs(:), e(:), t, energy, de
    integer, parameter :: NS = 64
    real(wp) :: vmax, v, slack
    integer :: i
    slack = 1.0e-6_wp*abs(de) + 64*epsilon(1.0_wp)*abs(energy)
    vmax = veff(model, qs)
    ok = .true.
    do i = 1, NS
      v = veff(model, qs + (t*i/NS)*e)
      if (v < vmax - slack) then
        ok = .false.
        return
      end if
      vmax = max(vmax, v)
    end do
  end function rises

  !> The sampled flux through the saddle sad's bottleneck at E = E_s + de: n points, uniforms
  !> from seed (drawn serially: the same result for any number of threads), t_max and tol for
  !> the integrations, gate the half-width of the slab [units of q]. stat = TUBES_EINPUT for a
  !> model that is not natural, TUBES_EMODEL where the model fails at a sample.
  !> With plane = (k, dir) and plane_c: the section q_k = c crossed with sign(dq_k/dt) = dir
  !> instead of the dividing surface: the same sampling of (Q', P') on the section's energy
  !> surface around the point of the section nearest the saddle (res%volume: its volume), each
  !> point followed forwards until it transits (passes the saddle's slab on the far side) or
  !> returns to the section (res%fraction: the fraction that transits; docs/theory.md).
  !> TUBES_EOUTSIDE if that point is not inside the energy shell.
  subroutine flux_sampled(model, sad, de, n, seed, t_max, tol, gate, span, integ, res, stat, plane, plane_c)
    class(hamiltonian_t), intent(in) :: model
    type(equilibrium_t), intent(in) :: sad
    real(wp), intent(in) :: de, t_max, tol, gate
    real(wp), intent(in) :: span          !! no extent beyond this [units of q]
    integer, intent(in) :: n, seed
    type(integ_choice_t), intent(in) :: integ
    type(flux_result_t), intent(out) :: res
    integer, intent(out) :: stat
    integer, intent(in), optional :: plane(2)
    real(wp), intent(in), optional :: plane_c
    real(wp) :: r(MAXN, MAXN), energy, vol, ex(2), cball, q0(MAXN), sw
    real(wp), allocatable :: u(:), val(:)
    integer, allocatable :: cls(:), st(:), todo(:)
    integer :: nd, m, j, k, rv(2*MAXN), nper, fw, bw, sf, sb
    logical :: section, natural
    type(flux_pts_t) :: pts
    type(flux_runs_t) :: runs
    type(ens_out_t) :: out, oruns
    type(slab_t) :: slab
    type(transit_t) :: tobs
    stat = TUBES_EINPUT
    nd = model%ndof()
    if (nd < 2 .or. nd > MAXN .or. n < 2 .or. .not. de > 0 .or. .not. allocated(sad%evec)) return
    energy = sad%energy + de
    section = present(plane) .and. present(plane_c)
    q0 = 0
    q0(1:nd) = sad%q
    ! the rotated frame: r(1, :) = n, then an orthonormal basis of n's complement
    r = 0
    r(1, 1:nd) = sad%evec(1:nd, 1)/sqrt(sum(sad%evec(1:nd, 1)**2))
    if (section) then           ! the section's normal, oriented by its direction
      if (plane(1) < 1 .or. plane(1) > nd .or. abs(plane(2)) /= 1) return
      r(1, :) = 0
      r(1, plane(1)) = plane(2)
      q0(plane(1)) = plane_c
      tobs%n = nd
      tobs%k = plane(1)
      tobs%dir = plane(2)
      tobs%c = plane_c
      tobs%gate = gate
      tobs%qs(1:nd) = sad%q
      tobs%ns(1:nd) = neck_normal(model, sad)
      ! towards the far side: away from the section's point
      if (dot_product(q0(1:nd) - sad%q, tobs%ns(1:nd)) > 0) tobs%ns = -tobs%ns
    end if
    natural = model%is_natural()
    if (.not. natural .and. .not. section) then
      ! a crossing against the DS pairs with its time-reverse (on the positive branch, with the
      ! opposite c) only if a reversor maps the DS to itself: n in the +1 space of the reversor's
      ! q part (the CR3BP's (x, -y): n along x). No reversor: not sampled (TUBES_EINPUT)
      rv = 0
      rv(1:2*nd) = model%reversor()
      if (all(rv == 0)) return
      where (rv(1:nd) /= 1) r(1, 1:nd) = 0
      if (sqrt(sum(r(1, 1:nd)**2)) < 0.1_wp) return
      r(1, 1:nd) = r(1, 1:nd)/sqrt(sum(r(1, 1:nd)**2))
    end if
    m = 1
    do k = 1, nd
      if (m == nd) exit
      r(m + 1, :) = 0
      r(m + 1, k) = 1
      do j = 1, m
        r(m + 1, 1:nd) = r(m + 1, 1:nd) - dot_product(r(m + 1, 1:nd), r(j, 1:nd))*r(j, 1:nd)
      end do
      if (sqrt(sum(r(m + 1, 1:nd)**2)) < 0.1_wp) cycle
      r(m + 1, 1:nd) = r(m + 1, 1:nd)/sqrt(sum(r(m + 1, 1:nd)**2))
      m = m + 1
    end do
    ! the sampling needs H quadratic in the momenta (natural or gyroscopic models)
    if (.not. quadratic_in_p(model, q0(1:nd))) return
    ! a passage is a leaving of the slab on the far side: the NHIM must lie well inside it, else
    ! orbits on or near it leave the slab both ways without passing (recrossings counted as passages)
    res%nhim_reach = nhim_reach(sad, de, merge(tobs%ns(1:nd), r(1, 1:nd), section))
    if (.not. gate_holds_nhim(res%nhim_reach, gate)) then
      stat = TUBES_ENARROW
      return
    end if
    block
      ! the box of Q': twice the extent of {V_eff <= E} along each axis, both ways
      vol = 1
      if (section) then
        if (.not. veff(model, q0(1:nd)) < energy) then
          stat = TUBES_EOUTSIDE       ! the section misses the energy surface there
          return
        end if
      end if
      do j = 2, nd
        ex(1) = extent(model, q0(1:nd), -r(j, 1:nd), energy, 1.0e-3_wp*span, span)
        ex(2) = extent(model, q0(1:nd), r(j, 1:nd), energy, 1.0e-3_wp*span, span)
        if (any(ex >= span)) then     ! the shell reaches past the window: its volume would be cut
          stat = TUBES_ENOREGION      ! (before: a box-dependent volume and flux, exit 0)
          return
        end if
        if (.not. section) then       ! the dividing surface crosses the bottleneck alone
          if (.not. (rises(model, q0(1:nd), -r(j, 1:nd), ex(1), energy, de) .and. &
                     rises(model, q0(1:nd), r(j, 1:nd), ex(2), energy, de))) then
            stat = TUBES_EPASTEND
            return
          end if
        end if
        res%box(:, j - 1) = [-2*ex(1), 2*ex(2)]
        vol = vol*2*(ex(1) + ex(2))
      end do
      cball = merge(2.0_wp, PI, nd == 2)       ! the volume of the unit (N-1)-ball
      allocate (u(2*(nd - 1)*n), val(n), cls(n), st(n))
      stat = int(rng_uniform(int(seed, 8), size(u), u))
      if (stat /= 0) then
        stat = TUBES_EINPUT
        return
      end if
      if (section) then
        allocate (res%x(2*nd, n))
        res%x = ieee_value(1.0_wp, ieee_quiet_nan)
      end if
      ! the loop's inputs from the work every rank repeats, as rank 0 has them (docs/cluster.md)
      call ens_agree(u)
      call ens_agree(res%box)
      call ens_agree(vol)
      call ens_agree(r)
      call ens_agree(q0)
      call ens_agree(tobs%ns)
      slab%n = nd
      slab%origin(1:nd) = sad%q
      call ens_agree(slab%origin)
      slab%normal(1:nd) = r(1, 1:nd)
      slab%dist = gate
      ! the samples are dealt out over MPI ranks and threads (tubes_ensemble): first their points
      pts%nd = nd
      pts%u = u
      pts%box = res%box
      pts%r = r
      pts%q0 = q0
      pts%energy = energy
      pts%cball = cball
      allocate (pts%model, source=model)
      call ens_run(pts, n, out, 1 + 2*nd, 1)
      st = out%st
      cls = out%i(1, :)
      if (section) res%x = out%r(2:, :)
      ! then their integrations, in lanes with the Taylor method: each point inside the shell
      ! followed forwards; off the section its past too (natural: the future of (q, -p); else
      ! followed backwards), the item after its future's
      todo = pack([(j, j=1, n)], st == TUBES_OK .and. cls == 0)
      nper = merge(1, 2, section)
      runs%lanes = uses_taylor(integ)
      runs%tol = tol
      runs%integ = integ
      allocate (runs%model, source=model)
      if (section) then
        allocate (runs%obs, source=tobs)
      else
        allocate (runs%obs, source=slab)
      end if
      allocate (runs%x0(2*nd, nper*size(todo)), runs%tend(nper*size(todo)))
      do j = 1, size(todo)
        runs%x0(:, nper*(j - 1) + 1) = out%r(2:, todo(j))
        runs%tend(nper*(j - 1) + 1) = t_max
        if (section) cycle
        runs%x0(:, 2*j) = out%r(2:, todo(j))
        runs%tend(2*j) = -t_max
        if (natural) then         ! the past of (q, p) is the future of (q, -p)
          runs%x0(nd + 1:, 2*j) = -runs%x0(nd + 1:, 2*j)
          runs%tend(2*j) = t_max
        end if
      end do
      call ens_run(runs, size(runs%tend), oruns, 0, 1, chunk=merge(FLUX_CHUNK, 1, runs%lanes))
      val = 0
      do j = 1, size(todo)
        k = todo(j)
        fw = oruns%i(1, nper*(j - 1) + 1)
        sf = oruns%st(nper*(j - 1) + 1)
        if (section) then          ! val = w, cls = 1 transit, -1 return, 2 undecided
          if (sf /= TUBES_OK) then
            st(k) = sf
            cycle
          end if
          cls(k) = merge(2, fw, fw == 0)
          val(k) = out%r(1, k)
          cycle
        end if
        bw = oruns%i(1, 2*j)
        sb = oruns%st(2*j)
        if (sf /= TUBES_OK .or. sb /= TUBES_OK) then
          st(k) = merge(sf, sb, sf /= TUBES_OK)
          cycle
        end if
        if (fw == 0 .or. bw == 0) then
          cls(k) = 2
        else if (fw == 1 .and. bw == -1) then
          cls(k) = 1
        else if (fw == -1 .and. bw == 1) then
          cls(k) = -1
        end if
        if (cls(k) == 1 .or. cls(k) == -1) val(k) = cls(k)*out%r(1, k)
      end do
      if (any(st /= TUBES_OK)) then
        stat = st(findloc(st /= TUBES_OK, .true., dim=1))
        return
      end if
      if (section) then        ! val = w inside the shell, cls = 1 transit, -1 return, 2 undecided
        res%w = val
        res%cls = cls
        res%volume = vol*sum(val)/n
        res%volume_err = vol*sqrt(max(0.0_wp, sum((val - sum(val)/n)**2)/(n - 1))/n)
        sw = sum(val)
        if (sw > 0) then
          res%fraction = sum(val, mask=cls == 1)/sw
          res%fraction_err = sqrt(sum(val**2*(merge(1.0_wp, 0.0_wp, cls == 1) - res%fraction)**2))/sw
        end if
        res%n_transit = count(cls == 1)
        res%n_return = count(cls == -1)
        res%n_undecided = count(cls == 2)
        res%n_inside = count(cls /= 3)
        stat = TUBES_OK
        return
      end if
      res%flux = vol*sum(val)/n
      res%err = vol*sqrt(max(0.0_wp, sum((val - sum(val)/n)**2)/(n - 1))/n)
      res%n_reactive = count(cls == 1 .or. cls == -1)
      res%n_recrossing = count(cls == -1)
      res%n_undecided = count(cls == 2)
      res%n_inside = count(cls /= 3)
      stat = TUBES_OK
    end block

  end subroutine flux_sampled

  !> Sample k's point (flux_pts_t): its weight w into out%r(1, k), its state (q, p) on the branch
  !> dQ1/dt > 0 into out%r(2:, k) (NaN where none); out%i(1, k) = 3 outside the shell, else 0
  !> (its integrations follow: flux_runs_t).
  subroutine point_item(self, k, out)
    class(flux_pts_t), intent(in) :: self
    integer, intent(in) :: k
    type(ens_out_t), intent(inout) :: out
    real(wp) :: q(self%nd), a(self%nd, self%nd), ar(self%nd, self%nd), s(self%nd - 1, self%nd - 1), &
                l(self%nd - 1, self%nd - 1), pp(self%nd - 1), bigp(self%nd), p(self%nd), v, w, &
                qa, qb, qc, rad, uu(2*(self%nd - 1)), pc(self%nd)
    integer :: j2, i
    i = k
    out%r(2:, i) = ieee_value(1.0_wp, ieee_quiet_nan)
    associate (model => self%model, nd => self%nd, u => self%u, q0 => self%q0, r => self%r, &
               energy => self%energy, cball => self%cball, cls => out%i(1, :), st => out%st)
    uu = u(2*(nd - 1)*(i - 1) + 1:2*(nd - 1)*i)
    q = q0(1:nd)
    do j2 = 2, nd
      q = q + (self%box(1, j2 - 1) + uu(j2 - 1)*(self%box(2, j2 - 1) - self%box(1, j2 - 1)))*r(j2, 1:nd)
    end do
    call quadratic_parts(model, q, a, pc, v, j2)
    if (j2 /= 0 .or. .not. v < energy) then
      cls(i) = 3
      return
    end if
    ! only the part of {V < E} on the DS that the saddle sees (star-shaped from it): other
    ! bottlenecks the hyperplane may cut farther out are not this saddle's
    do j2 = 1, NSTAR - 1
      if (.not. veff(model, q0(1:nd) + (real(j2, wp)/NSTAR)*(q - q0(1:nd))) < energy) then
        cls(i) = 3
        return
      end if
    end do
    ar = matmul(matmul(r(1:nd, 1:nd), a), transpose(r(1:nd, 1:nd)))
    s = ar(2:nd, 2:nd) - spread(ar(2:nd, 1), 2, nd - 1)*spread(ar(1, 2:nd), 1, nd - 1)/ar(1, 1)
    ! Cholesky s = l l^T (1 x 1 or 2 x 2)
    l = 0
    l(1, 1) = sqrt(s(1, 1))
    if (nd == 3) then
      l(2, 1) = s(2, 1)/l(1, 1)
      l(2, 2) = sqrt(s(2, 2) - l(2, 1)**2)
    end if
    rad = sqrt(2*(energy - v))
    w = cball*rad**(nd - 1)/product([(l(j2, j2), j2=1, nd - 1)])
    if (.not. (w >= 0 .and. w <= huge(1.0_wp))) then
      st(i) = TUBES_EMODEL
      return
    end if
    ! a point uniform in the unit (N-1)-ball, then P' = rad l^-T ball
    if (nd == 2) then
      pp(1) = 2*uu(2) - 1
    else
      pp = sqrt(uu(3))*[cos(2*PI*uu(4)), sin(2*PI*uu(4))]
    end if
    pp = rad*pp
    if (nd == 3) then          ! solve l^T y = pp
      pp(2) = pp(2)/l(2, 2)
      pp(1) = (pp(1) - l(2, 1)*pp(2))/l(1, 1)
    else
      pp(1) = pp(1)/l(1, 1)
    end if
    ! P1 on the branch dQ1/dt = ar(1,:) . P > 0: 1/2 ar11 P1^2 + b P1 + c = 0
    qa = ar(1, 1)/2
    qb = dot_product(ar(1, 2:nd), pp)
    qc = dot_product(pp, matmul(ar(2:nd, 2:nd), pp))/2 + v - energy
    bigp(1) = (-qb + sqrt(max(0.0_wp, qb*qb - 4*qa*qc)))/(2*qa)
    bigp(2:nd) = pp
    p = pc + matmul(transpose(r(1:nd, 1:nd)), bigp)    ! the ellipsoid's centre pc (gyroscopic)
    out%r(1, i) = w
    out%r(2:nd + 1, i) = q
    out%r(nd + 2:2*nd + 1, i) = p
    end associate
  end subroutine point_item

  !> Integration k (flux_runs_t) item by item: outcome_of's class and status.
  subroutine run_item(self, k, out)
    class(flux_runs_t), intent(in) :: self
    integer, intent(in) :: k
    type(ens_out_t), intent(inout) :: out
    call outcome_of(self%model, self%obs, self%x0(:, k), self%tend(k), self%tol, self%integ, out%i(1, k), &
                    out%st(k))
  end subroutine run_item

  !> Integration k in a lane: outcome_of's set-up (the integrator of the choice with rtol = atol =
  !> tol from t = 0, a fresh copy of the classifier as its observer).
  subroutine run_start(self, k, lane, stat)
    class(flux_runs_t), intent(inout) :: self
    integer, intent(in) :: k
    type(lane_t), intent(inout) :: lane
    integer, intent(out) :: stat
    stat = TUBES_OK
    call lane%setup(self%model, self%integ%h, self%tol, self%tol)
    lane%x = self%x0(:, k)
    lane%tend = self%tend(k)
    allocate (lane%observer, source=self%obs)
  end subroutine run_start

  !> Integration k's class and status, as outcome_of's.
  subroutine run_finish(self, k, lane, out)
    class(flux_runs_t), intent(in) :: self
    integer, intent(in) :: k
    type(lane_t), intent(inout) :: lane
    type(ens_out_t), intent(inout) :: out
    out%i(1, k) = 0
    out%st(k) = lane%stat
    if (lane%stat < 0) return
    out%st(k) = TUBES_OK
    select type (obs => lane%observer)
    class is (classifier_t)
      out%i(1, k) = obs%outcome
    end select
  end subroutine run_finish
end module tubes_flux

