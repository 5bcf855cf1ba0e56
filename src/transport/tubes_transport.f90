!> Transition fractions from tube dynamics: the tube cut's area over the energy surface's area
!> on the section (p_trans), the paper's leading-order formula, the Monte Carlo check by direct
!> integration, and Poincare maps of the section. Theory: docs/tubes.md.
module tubes_transport
  use, intrinsic :: iso_c_binding, only: c_int, c_double, c_long
  use tubes_kinds, only: wp, i8
  use tubes_quad, only: rng_uniform
  use tubes_status, only: TUBES_OK, TUBES_EINPUT, TUBES_EVENT, TUBES_ENOCONV, TUBES_EFAULT, TUBES_EMODEL, TUBES_EINTERRUPT
  use tubes_ensemble, only: ens_out_t, ens_run, ens_agree, ens_cancelled
  use tubes_hamiltonian, only: hamiltonian_t, veff, damped_t
  use tubes_models, only: MAX_DOF
  use tubes_field, only: vector_field_t
  use tubes_integrator, only: integrator_t, observer_t, propagate, crossing_log_t
  use tubes_methods, only: integ_choice_t, make_integrator, uses_taylor, noisy, noise_stream
  use tubes_integrator, only: event_t
  use tubes_lanes, only: lane_t, lane_jobs_t, MAX_LANES
  use tubes_section_kinds, only: poincare_t
  implicit none
  private

  integer, parameter, public :: MC_RETURN = 0    !! came back to the section: no transition
  integer, parameter, public :: MC_TRANSIT = 1   !! entered the other well through the bottleneck
  integer, parameter, public :: MC_UNDECIDED = 2 !! neither within t_max
  !> left for good through another exit (a finite-time escape: the model refused the state beyond
  !> ESCAPE_SCALES length scales) before it transited or came back: no transition
  integer, parameter, public :: MC_ESCAPE = 3
  !> its energy fell below the saddle's (a dissipative model without noise): it can no longer pass
  !> the neck, no transition
  integer, parameter, public :: MC_TRAPPED = 4

  !> The transit gate of a saddle: the configuration hyperplane (q - q_s) . n = dist, n the
  !> saddle's neck direction pointing away from the section's well, bounded (gate_bound, 2 DOF) to
  !> the neck: the segment of the line through the saddle's side of {V_eff <= E}. A trajectory has
  !> transited when a step crosses the line from the saddle's side within the segment; it stops at
  !> that step's end.
  type, public :: gate_spec_t
    real(wp), allocatable :: origin(:)   !! the saddle's configuration q_s
    real(wp), allocatable :: normal(:)   !! unit normal n, towards the other side
    real(wp) :: dist = 0                 !! distance past the saddle [units of q]
    !> the neck's segment: a crossing point q counts when (q - origin - dist n) . tangent lies in
    !> [seg_lo, seg_hi] (unbounded: no tangent)
    real(wp), allocatable :: tangent(:)
    real(wp) :: seg_lo = -huge(1.0_wp), seg_hi = huge(1.0_wp)
    !> a dissipative field without noise: the saddle's energy, below which a trajectory can no
    !> longer pass the neck (its energy does not rise again): it stops there, trapped (-huge: off)
    real(wp) :: e_floor = -huge(1.0_wp)
  end type gate_spec_t

  !> The gate as an observer of an integration (propagate): passed once a step crosses it in the
  !> neck; the integration stops at that step's end.
  type, extends(observer_t), public :: gate_t
    type(gate_spec_t) :: spec
    logical :: passed = .false.
    logical :: trapped = .false.         !! its energy fell below spec%e_floor, or it stalled
    real(wp) :: t_slow = -1              !! rolling resistance: since when it crawls (-1: it does not)
    integer :: outside = 0               !! crossings of the line outside the neck's segment
    real(wp) :: g_prev = 0               !! (q - q_s) . n - dist at the last step's end
    logical :: started = .false.
  contains
    procedure :: on_step => gate_on_step
    procedure :: quiet => gate_quiet
  end type gate_t

  !> The Monte Carlo's points as an ensemble (tubes_ensemble; in lanes with the Taylor method,
  !> tubes_lanes): item i set on the section at (r(i), pr(i)) and classified as mc_classify does,
  !> its outcome in i(1, :) (an MC_* class, or its status when it failed), and whether the cut
  !> predicts a transit in i(2, :) (1: inside).
  type, extends(lane_jobs_t) :: mc_jobs_t
    class(hamiltonian_t), allocatable :: model
    !> the field integrated: the model with its dissipation (unallocated: the model itself)
    class(vector_field_t), allocatable :: field
    type(poincare_t) :: psec
    type(gate_spec_t) :: gspec
    type(integ_choice_t) :: integ
    real(wp) :: t_max = 0, tol = 0
    real(wp), allocatable :: r(:), pr(:)
    real(wp), allocatable :: cr(:), cp(:)   !! the tube's cut
    real(wp) :: box(4) = 0                  !! its bounding box: r min, max, p_r min, max
  contains
    procedure :: item => mc_item
    procedure :: start => mc_start
    procedure :: finish => mc_finish
  end type mc_jobs_t

  !> The Poincare map's seeds as an ensemble: item j's returns (2, n_iter) in its reals, as
  !> one_map integrates them.
  type, extends(lane_jobs_t) :: map_jobs_t
    class(hamiltonian_t), allocatable :: model
    class(vector_field_t), allocatable :: field   !! what is integrated (unallocated: the model)
    type(poincare_t) :: psec
    type(integ_choice_t) :: integ
    real(wp) :: t_max = 0, tol = 0
    integer :: n_iter = 0
    real(wp), allocatable :: x0(:, :)
  contains
    procedure :: item => map_item
    procedure :: start => map_start
    procedure :: finish => map_finish
  end type map_jobs_t

  !> A rolling ball crawling slower than the drag's regularisation speed for this long [time] has come
  !> to rest (gate_floor)
  real(wp), parameter :: STALL_TIME = 1
  !> Items of an ensemble per call of run_lanes (an OpenMP thread's unit of work)
  integer, parameter :: LANE_CHUNK = 64
  !> A Poincare seed the model refuses beyond this many length scales (|q|_1) has escaped
  !> (map_status)
  real(wp), parameter :: ESCAPE_SCALES = 1.0e3_wp

  public :: inside_curve, mc_classify, monte_carlo, poincare_map, mc_agreement, classify_points, gate_bound

  !> The Monte Carlo check agrees with the tube within this many standard errors (mc_agreement;
  !> a false alarm of a correct tube: 6e-7)
  real(wp), parameter, public :: MC_SIGMA = 5

contains

  !> The Monte Carlo check's verdict (docs/tubes.md, "Monte Carlo check"): of n points, n_transit
  !> transited, n_undecided stayed undecided and misclassified disagree with the tube's inside;
  !> against the tube's p = A_tube/A_E: the count's distance from p in standard errors of a binomial
  !> count with p (sqrt(p (1 - p)/n): the observed fraction's own error is 0 for 0 or n transits,
  !> and would make one point without a transit a disagreement of infinitely many), the limits of
  !> misclassified points (2 + n/1000: a point within the cut's resolution of its boundary can be)
  !> and of undecided ones (2 + n/100), and whether the two answers agree. The one definition: the
  !> montecarlo scene (src/io/tubes_scenes.c) and Python's monte_carlo call it.
  pure subroutine mc_agreement(n, n_transit, n_undecided, misclassified, p, sigmas, mis_lim, und_lim, agrees)
    use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_positive_inf
    integer, intent(in) :: n, n_transit, n_undecided, misclassified
    real(wp), intent(in) :: p
    real(wp), intent(out) :: sigmas
    integer, intent(out) :: mis_lim, und_lim
    logical, intent(out) :: agrees
    real(wp) :: f, se_p
    f = real(n_transit, wp)/n
    se_p = sqrt(p*(1 - p)/n)
    if (se_p > 0) then
      sigmas = abs(f - p)/se_p
    else if (f == p) then
      sigmas = 0
    else
      sigmas = ieee_value(1.0_wp, ieee_positive_inf)
    end if
    mis_lim = 2 + n/1000
    und_lim = 2 + n/100
    agrees = sigmas <= MC_SIGMA .and. misclassified <= mis_lim .and. n_undecided <= und_lim
  end subroutine mc_agreement

  subroutine gate_on_step(self, ig, t_hi)
    class(gate_t), intent(inout) :: self
    class(integrator_t), intent(inout) :: ig
    real(wp), intent(in) :: t_hi
    real(wp) :: buf(2*MAX_DOF)                        ! (the state, off the heap: every step)
    real(wp), allocatable :: big(:)
    if (ig%f%dim() <= size(buf)) then
      call gate_step(self, ig, t_hi, buf(1:ig%f%dim()))
    else
      allocate (big(ig%f%dim()))
      call gate_step(self, ig, t_hi, big)
    end if
  end subroutine gate_on_step

  !> A step of a bounded gate after the first: nothing happens unless the line is crossed outwards
  !> (g_prev <= 0 < g) or gate_floor finds the trajectory trapped (a dissipative field: its energy
  !> below the floor before the neck) or has a stall clock to keep (rolling resistance), so any
  !> other step only keeps g (gate_step's arithmetic, the same g); gate_floor's test is its own.
  logical function gate_quiet(self, ig, t, x) result(q)
    class(gate_t), intent(inout) :: self
    class(integrator_t), intent(in) :: ig
    real(wp), intent(in) :: t
    real(wp), intent(in) :: x(:)
    real(wp) :: g
    integer :: n
    q = .false.
    if (.not. self%started .or. .not. allocated(self%spec%tangent)) return
    n = size(self%spec%normal)
    if (.not. (self%passed .or. self%spec%e_floor == -huge(1.0_wp))) then   ! gate_floor's work
      select type (f => ig%f)
      type is (damped_t)
        if (below_floor(self, f, x)) return      ! trapped
        if (f%f > 0) return                      ! its stall clock
      end select
    end if
    g = dot_product(x(1:n) - self%spec%origin, self%spec%normal) - self%spec%dist
    if (self%g_prev <= 0 .and. g > 0) return
    self%g_prev = g
    q = .true.
  end function gate_quiet

  !> gate_on_step's work, x the state's room.
  subroutine gate_step(self, ig, t_hi, x)
    class(gate_t), intent(inout) :: self
    class(integrator_t), intent(inout) :: ig
    real(wp), intent(in) :: t_hi
    real(wp), intent(inout) :: x(:)
    real(wp) :: g, g0, a, b, m, gm
    integer :: n, k
    n = size(self%spec%normal)
    call ig%interp(t_hi, x)
    g = dot_product(x(1:n) - self%spec%origin, self%spec%normal) - self%spec%dist
    if (.not. allocated(self%spec%tangent)) then      ! unbounded: a step that ends beyond the line
      self%stop_now = g > 0
      if (self%stop_now) self%passed = .true.
      call gate_floor(self, ig, x, t_hi)
      return
    end if
    call gate_floor(self, ig, x, t_hi)
    if (.not. self%started) then                      ! the side at the start
      call ig%interp(ig%t_old, x)
      self%g_prev = dot_product(x(1:n) - self%spec%origin, self%spec%normal) - self%spec%dist
      self%started = .true.
    end if
    g0 = self%g_prev
    self%g_prev = g
    if (.not. (g0 <= 0 .and. g > 0)) return
    ! the crossing in [t_old, t_hi] by bisection on the dense output, and where it lies on the line
    a = ig%t_old
    b = t_hi
    do k = 1, 60
      m = 0.5_wp*(a + b)
      if (m == a .or. m == b) exit
      call ig%interp(m, x)
      gm = dot_product(x(1:n) - self%spec%origin, self%spec%normal) - self%spec%dist
      if (gm > 0) then
        b = m
      else
        a = m
      end if
    end do
    call ig%interp(b, x)
    m = dot_product(x(1:n) - self%spec%origin - self%spec%dist*self%spec%normal, self%spec%tangent)
    if (m >= self%spec%seg_lo .and. m <= self%spec%seg_hi) then
      self%stop_now = .true.
      self%passed = .true.
    else
      self%outside = self%outside + 1                 ! through another opening of the line
    end if
  end subroutine gate_step

  !> A dissipative field's trajectory at the step's end t, before the gate, is trapped when on the
  !> section's side of the saddle ((q - q_s) . n < 0: the neck still to pass) its energy is below the
  !> saddle's (past the saddle it may fall below E_e on the way down to the gate), or, with rolling
  !> resistance, anywhere before the gate when it has crawled at a path speed below the drag's
  !> regularisation speed for STALL_TIME: it has come to rest where the slope is gentler than the
  !> drag (on the saddle's plateau, or at a well's bottom: a Coulomb drag stops a ball there; the
  !> regularised one lets it creep on, for tens of seconds).
  subroutine gate_floor(self, ig, x, t)
    class(gate_t), intent(inout) :: self
    class(integrator_t), intent(inout) :: ig
    real(wp), intent(in) :: x(:), t
    real(wp) :: v(2*MAX_DOF)                          ! (dq/dt in its first n: off the heap)
    integer :: n, st
    if (self%passed .or. self%spec%e_floor == -huge(1.0_wp)) return
    n = size(self%spec%normal)
    select type (f => ig%f)
    type is (damped_t)
      if (below_floor(self, f, x)) then
        self%trapped = .true.
        self%stop_now = .true.
        return
      end if
      if (.not. f%f > 0) return
      if (size(x) > size(v)) error stop 'gate_floor: a state larger than 2 MAX_DOF'   ! (a model's: never)
      call f%base%eval(t, x, v(1:size(x)), st)
      if (st /= 0) return
      if (f%sigma*dot_product(x(n + 1:2*n), v(1:n)) < f%v_reg**2) then
        if (self%t_slow < 0) self%t_slow = t
        if (t - self%t_slow >= STALL_TIME) then
          self%trapped = .true.
          self%stop_now = .true.
        end if
      else
        self%t_slow = -1
      end if
    end select
  end subroutine gate_floor

  !> gate_floor's trap: x on the section's side of the saddle ((q - q_s) . n < 0) with the energy
  !> of the field's conservative model below the floor.
  logical function below_floor(self, f, x)
    class(gate_t), intent(in) :: self
    type(damped_t), intent(in) :: f
    real(wp), intent(in) :: x(:)
    integer :: n
    n = size(self%spec%normal)
    below_floor = f%base%energy(x) < self%spec%e_floor .and. &
                  dot_product(x(1:n) - self%spec%origin, self%spec%normal) < 0
  end function below_floor

  !> Bound the gate to the neck at energy e (2 DOF): the segment of the gate line around its point
  !> q_s + dist n where V_eff <= e, found by marching out along the line in steps of
  !> max(dist, length scale)/64 and bisection (a singular point of H bounds it too). A crossing of
  !> the line elsewhere, through another opening of {V_eff <= e}, is then no transit. Where the
  !> line's point itself lies above e (a gate beyond the neck's end) the segment is empty: no
  !> crossing counts (the Monte Carlo check then disagrees with any tube). stat = TUBES_EINPUT
  !> outside 2 DOF.
  subroutine gate_bound(model, gspec, e, stat)
    class(hamiltonian_t), intent(in) :: model
    type(gate_spec_t), intent(inout) :: gspec
    real(wp), intent(in) :: e
    integer, intent(out) :: stat
    integer, parameter :: MAX_MARCH = 200000
    real(wp) :: c0(2), t(2), h, a, b, m
    integer :: side, k
    stat = TUBES_EINPUT
    if (model%ndof() /= 2 .or. size(gspec%normal) /= 2) return
    c0 = gspec%origin + gspec%dist*gspec%normal
    t = [-gspec%normal(2), gspec%normal(1)]
    gspec%tangent = t
    stat = TUBES_OK
    if (.not. veff(model, c0) <= e) then
      gspec%seg_lo = 1
      gspec%seg_hi = -1
      return
    end if
    h = max(gspec%dist, model%length_scale())/64
    do side = -1, 1, 2
      a = 0
      b = huge(1.0_wp)
      do k = 1, MAX_MARCH
        if (.not. veff(model, c0 + side*k*h*t) <= e) then
          b = k*h
          exit
        end if
        a = k*h
      end do
      if (b < huge(1.0_wp)) then
        do k = 1, 80
          m = 0.5_wp*(a + b)
          if (m == a .or. m == b) exit
          if (veff(model, c0 + side*m*t) <= e) then
            a = m
          else
            b = m
          end if
        end do
      end if
      if (side < 0) gspec%seg_lo = -b
      if (side > 0) gspec%seg_hi = b
    end do
  end subroutine gate_bound

  !> Point-in-polygon (even-odd rule) for the closed curve (cr, cp).
  pure logical function inside_curve(r, p, cr, cp) result(inside)
    real(wp), intent(in) :: r, p, cr(:), cp(:)
    integer :: i, j
    inside = .false.
    j = size(cr)
    do i = 1, size(cr)
      if ((cp(i) > p) .neqv. (cp(j) > p)) then
        if (r < (cr(j) - cr(i))*(p - cp(i))/(cp(j) - cp(i)) + cr(i)) inside = .not. inside
      end if
      j = i
    end do
  end function inside_curve

  !> Follow the state x0 (on the section) forward until it returns to the section (either
  !> branch: MC_RETURN) or passes the saddle's gate (MC_TRANSIT), escapes (MC_ESCAPE), or t_max
  !> (MC_UNDECIDED): mc_outcome. field: the vector field integrated (the model with its
  !> dissipation; default the model ball itself).
  subroutine mc_classify(ball, psec, x0, gspec, t_max, tol, integ, outcome, t_end, stat, field, stream)
    class(hamiltonian_t), intent(in) :: ball
    type(poincare_t), intent(in) :: psec
    real(wp), intent(in) :: x0(:), t_max, tol
    type(gate_spec_t), intent(in) :: gspec
    type(integ_choice_t), intent(in) :: integ   !! the integrator
    integer, intent(out) :: outcome
    real(wp), intent(out) :: t_end
    integer, intent(out) :: stat
    class(vector_field_t), intent(in), optional :: field
    integer, intent(in), optional :: stream      !! a noisy field's trajectory number (its noise)
    class(integrator_t), allocatable :: ig
    type(gate_t) :: gate
    real(wp) :: x(size(x0))
    class(event_t), allocatable :: ret
    outcome = MC_UNDECIDED
    t_end = 0
    call trajectory_integrator(ball, tol, integ, ig, stat, field, stream)
    if (stat /= TUBES_OK) return
    call psec%return_event(ret)
    x = x0
    gate%spec = gspec
    call propagate(ig, x, t_max, stat, event=ret, observer=gate)
    t_end = ig%t
    call mc_outcome(ball, gate%passed, x, stat, outcome, gate%trapped)
  end subroutine mc_classify

  !> The integrator of one trajectory of mc_classify or one_map: integ's method at rtol = atol = tol
  !> on field (the model with its dissipation) or, without one, on the model ball itself; a noisy
  !> field's trajectory number stream (its noise) set.
  subroutine trajectory_integrator(ball, tol, integ, ig, stat, field, stream)
    class(hamiltonian_t), intent(in) :: ball
    real(wp), intent(in) :: tol
    type(integ_choice_t), intent(in) :: integ
    class(integrator_t), allocatable, intent(out) :: ig
    integer, intent(out) :: stat
    class(vector_field_t), intent(in), optional :: field
    integer, intent(in), optional :: stream
    if (present(field)) then
      call make_integrator(integ, ig, stat, f=field, rtol=tol, atol=tol)
    else
      call make_integrator(integ, ig, stat, f=ball, rtol=tol, atol=tol)
    end if
    if (stat /= TUBES_OK) return
    if (present(stream)) call noise_stream(ig, stream)
  end subroutine trajectory_integrator

  !> A point's class from the end of its integration (stat, the state x there, whether it passed
  !> the gate): a return to the section (the terminal event) MC_RETURN, the gate passed
  !> MC_TRANSIT, an escape (map_status: the model refused a state beyond ESCAPE_SCALES length
  !> scales; Henon-Heiles' points leaving through another saddle) MC_ESCAPE, else MC_UNDECIDED
  !> (t_max); stat becomes TUBES_OK for a return and an escape, and stays any other failure.
  subroutine mc_outcome(model, passed, x, stat, outcome, trapped)
    class(hamiltonian_t), intent(in) :: model
    logical, intent(in) :: passed
    real(wp), intent(in) :: x(:)
    integer, intent(inout) :: stat
    integer, intent(out) :: outcome
    logical, intent(in), optional :: trapped     !! stopped below the saddle's energy (MC_TRAPPED)
    integer :: st
    if (present(trapped)) then
      if (trapped .and. stat == TUBES_OK) then
        outcome = MC_TRAPPED
        return
      end if
    end if
    if (stat == TUBES_EVENT) then
      outcome = MC_RETURN
      stat = TUBES_OK
      return
    end if
    st = map_status(model, stat, x)
    if (passed) then
      outcome = MC_TRANSIT
      stat = st                         ! an escape after the transit is no failure either
    else if (st == TUBES_OK .and. stat /= TUBES_OK) then
      outcome = MC_ESCAPE
      stat = TUBES_OK
    else
      outcome = MC_UNDECIDED
    end if
  end subroutine mc_outcome

  !> Monte Carlo transition fraction: n points uniform in the permitted region of the
  !> section at its energy (rejection in the bounding box, GSL MT19937 from seed, drawn
  !> serially), each on the section's branch, integrated in parallel (OpenMP) and classified by
  !> the saddle's gate gspec. The cut (cr, cp) gives each point's predicted class (inside =
  !> transit). field: the vector field integrated (the model with its dissipation; default the
  !> model).
  subroutine monte_carlo(model, psec, n, seed, gspec, t_max, tol, integ, cr, cp, r, pr, outcome, &
                         inside, stat, field)
    class(hamiltonian_t), intent(in) :: model
    type(integ_choice_t), intent(in) :: integ   !! the integrator
    type(poincare_t), intent(in) :: psec
    integer, intent(in) :: n
    integer(c_long), intent(in) :: seed
    real(wp), intent(in) :: t_max, tol, cr(:), cp(:)
    type(gate_spec_t), intent(in) :: gspec      !! the saddle's transit gate
    real(wp), intent(out) :: r(n), pr(n)
    integer, intent(out) :: outcome(n)
    logical, intent(out) :: inside(n)
    integer, intent(out) :: stat
    class(vector_field_t), intent(in), optional :: field
    real(wp), allocatable :: u(:)
    real(wp) :: plo, phi_, pl, ph, pc, pmax, rr, pp_
    integer :: k, m, i, ntry
    stat = TUBES_OK
    if (n < 1) then
      stat = TUBES_EINPUT
      return
    end if
    ! the bounding box of the region in p_s: centre pc, half-height pmax (1 % margin)
    pl = huge(1.0_wp)
    ph = -huge(1.0_wp)
    do i = 0, 2000
      call psec%bounds(psec%smin + (psec%smax - psec%smin)*i/2000.0_wp, plo, phi_)
      pl = min(pl, plo)
      ph = max(ph, phi_)
    end do
    pc = (pl + ph)/2
    pmax = (ph - pl)/2*1.01_wp
    m = 0
    k = 0
    ntry = 0
    allocate (u(8*n + 64))
    stat = rng_uniform(seed, size(u), u)
    if (stat /= 0) then
      stat = merge(TUBES_EINTERRUPT, TUBES_EINPUT, ens_cancelled())   ! else GSL refused the seed or the size
      return
    end if
    do while (m < n)
      ntry = ntry + 1
      if (iand(ntry, 4095) == 0 .and. ens_cancelled()) then   ! 10^7 points: seconds of drawing
        stat = TUBES_EINTERRUPT
        return
      end if
      if (k + 2 > size(u)) then            ! rare: draw more from the same stream's seed + 1
        stat = rng_uniform(seed + k, size(u), u)
        if (stat /= 0) then
          stat = TUBES_EINPUT
          return
        end if
        k = 0
      end if
      rr = psec%smin + (psec%smax - psec%smin)*u(k + 1)
      pp_ = pc + pmax*(2*u(k + 2) - 1)
      k = k + 2
      call psec%bounds(rr, plo, phi_)
      if (pp_ > plo .and. pp_ < phi_) then
        m = m + 1
        r(m) = rr
        pr(m) = pp_
      end if
    end do
    ! the samples are dealt out over MPI ranks and threads (tubes_ensemble); a failed sample
    ! keeps its status as its outcome
    call ens_agree(r)
    call ens_agree(pr)
    call classify_points(model, psec, r, pr, gspec, t_max, tol, integ, outcome, stat, cr, cp, inside, field)
  end subroutine monte_carlo

  !> The points (r(k), pr(k)) of the section, each set on its branch at the section's energy and
  !> classified as mc_classify does (in parallel: tubes_ensemble; in lanes with the Taylor
  !> method), outcome(k) an MC_* class or its status where it failed; with the cut (cr, cp), inside(k)
  !> whether the cut holds it. field: the vector field integrated (default the model). stat: the
  !> lowest failure, or TUBES_OK.
  subroutine classify_points(model, psec, r, pr, gspec, t_max, tol, integ, outcome, stat, cr, cp, inside, field, &
                             local)
    class(hamiltonian_t), intent(in) :: model
    type(poincare_t), intent(in) :: psec
    real(wp), intent(in) :: r(:), pr(:), t_max, tol
    type(gate_spec_t), intent(in) :: gspec
    type(integ_choice_t), intent(in) :: integ
    integer, intent(out) :: outcome(size(r))
    integer, intent(out) :: stat
    real(wp), intent(in), optional :: cr(:), cp(:)
    logical, intent(out), optional :: inside(size(r))
    class(vector_field_t), intent(in), optional :: field
    logical, intent(in), optional :: local       !! this MPI rank alone (the caller dealt out a coarser level)
    type(mc_jobs_t) :: ens
    type(ens_out_t) :: out
    ens = mc_jobs_t(lanes=uses_taylor(integ), psec=psec, gspec=gspec, integ=integ, t_max=t_max, tol=tol, r=r, &
                    pr=pr)
    if (present(field)) ens%lanes = ens%lanes .and. .not. noisy(field)   ! a noisy field: one by one
    if (present(cr) .and. present(cp)) then
      ens%cr = cr
      ens%cp = cp
      if (size(cr) > 0) ens%box = [minval(cr), maxval(cr), minval(cp), maxval(cp)]
    else
      allocate (ens%cr(0), ens%cp(0))
    end if
    allocate (ens%model, source=model)
    if (present(field)) allocate (ens%field, source=field)
    call ens_run(ens, size(r), out, 0, 2, fault='sample', chunk=merge(LANE_CHUNK, 1, ens%lanes), local=local)
    outcome = merge(out%st, out%i(1, :), out%st < 0)
    if (present(inside)) inside = out%i(2, :) == 1
    stat = min(0, minval(out%st))
  end subroutine classify_points

  !> Point k, as mc_classify classifies it, and the cut's prediction for it.
  subroutine mc_item(self, k, out)
    class(mc_jobs_t), intent(in) :: self
    integer, intent(in) :: k
    type(ens_out_t), intent(inout) :: out
    real(wp) :: x(self%model%dim()), te
    out%i(1, k) = MC_UNDECIDED
    call self%psec%state(self%r(k), self%pr(k), x, out%st(k))
    if (out%st(k) /= TUBES_OK) then
      continue
    else if (allocated(self%field)) then
      call mc_classify(self%model, self%psec, x, self%gspec, self%t_max, self%tol, self%integ, out%i(1, k), te, &
                       out%st(k), self%field, k)
    else
      call mc_classify(self%model, self%psec, x, self%gspec, self%t_max, self%tol, self%integ, out%i(1, k), te, &
                       out%st(k))
    end if
    out%i(2, k) = merge(1, 0, mc_inside(self, k))
  end subroutine mc_item

  !> Is point k inside the cut? The bounding box first: a point outside it is outside the curve
  !> (no edge straddles p, or an even number to its one side), the full test's answer, in O(1).
  logical function mc_inside(self, k) result(inside)
    class(mc_jobs_t), intent(in) :: self
    integer, intent(in) :: k
    associate (r => self%r(k), p => self%pr(k), box => self%box)
      if (r < box(1) .or. r > box(2) .or. p < box(3) .or. p > box(4)) then
        inside = .false.
      else
        inside = inside_curve(r, p, self%cr, self%cp)
      end if
    end associate
  end function mc_inside

  !> Point k in a lane: mc_classify's set-up (the state on the section, the integrator of the
  !> choice with rtol = atol = tol, the return to the section as a terminal event, the gate).
  subroutine mc_start(self, k, lane, stat)
    class(mc_jobs_t), intent(inout) :: self
    integer, intent(in) :: k
    type(lane_t), intent(inout) :: lane
    integer, intent(out) :: stat
    class(event_t), allocatable :: ret
    type(gate_t) :: gate
    if (.not. allocated(lane%x)) allocate (lane%x(self%model%dim()))
    call self%psec%state(self%r(k), self%pr(k), lane%x, stat)
    if (stat /= TUBES_OK) return
    if (allocated(self%field)) then
      call lane%setup(self%field, self%integ%h, self%tol, self%tol)
    else
      call lane%setup(self%model, self%integ%h, self%tol, self%tol)
    end if
    lane%tend = self%t_max
    call self%psec%return_event(ret)
    call move_alloc(ret, lane%event)
    gate%spec = self%gspec
    allocate (lane%observer, source=gate)
  end subroutine mc_start

  !> Point k's class, as mc_classify's, and the cut's prediction.
  subroutine mc_finish(self, k, lane, out)
    class(mc_jobs_t), intent(in) :: self
    integer, intent(in) :: k
    type(lane_t), intent(inout) :: lane
    type(ens_out_t), intent(inout) :: out
    logical :: passed, trapped
    passed = .false.
    trapped = .false.
    if (allocated(lane%observer)) then
      select type (g => lane%observer)
      type is (gate_t)
        passed = g%passed
        trapped = g%trapped
      end select
    end if
    out%st(k) = lane%stat
    call mc_outcome(self%model, passed, lane%x, out%st(k), out%i(1, k), trapped)
    out%i(2, k) = merge(1, 0, mc_inside(self, k))
  end subroutine mc_finish

  !> Poincare map of the section branch: n_iter returns of each start state x0(:, j), recorded
  !> as (r, p_r) in pts(:, k, j) (NaN after a trajectory stops returning within t_max). field: the
  !> vector field integrated (the model with its dissipation; default the model).
  subroutine poincare_map(ball, psec, x0, n_iter, t_max, tol, integ, pts, stat, field)
    use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
    class(hamiltonian_t), intent(in) :: ball
    type(poincare_t), intent(in) :: psec
    type(integ_choice_t), intent(in) :: integ   !! the integrator
    real(wp), intent(in) :: x0(:, :), t_max, tol
    integer, intent(in) :: n_iter
    real(wp), intent(out) :: pts(2, n_iter, size(x0, 2))
    integer, intent(out) :: stat
    class(vector_field_t), intent(in), optional :: field
    type(map_jobs_t) :: ens
    type(ens_out_t) :: out
    integer :: j, ns
    ns = size(x0, 2)
    ens = map_jobs_t(lanes=uses_taylor(integ), psec=psec, integ=integ, t_max=t_max, tol=tol, n_iter=n_iter, x0=x0)
    allocate (ens%model, source=ball)
    if (present(field)) allocate (ens%field, source=field)
    if (present(field)) ens%lanes = ens%lanes .and. .not. noisy(field)
    call ens_agree(ens%x0)             ! seeds dealt out over MPI ranks and threads (tubes_ensemble)
    call ens_run(ens, ns, out, 2*n_iter, 0, fault='map', chunk=merge(MAX_LANES, 1, ens%lanes))
    pts = reshape(out%r, [2, n_iter, ns])
    do j = 1, ns
      if (out%st(j) == TUBES_EFAULT) pts(:, :, j) = ieee_value(1.0_wp, ieee_quiet_nan)
    end do
    stat = min(0, minval(out%st))
  end subroutine poincare_map

  !> Seed k's returns, as one_map integrates them.
  subroutine map_item(self, k, out)
    class(map_jobs_t), intent(in) :: self
    integer, intent(in) :: k
    type(ens_out_t), intent(inout) :: out
    if (allocated(self%field)) then
      call one_map(self%model, self%psec, self%x0(:, k), self%n_iter, self%t_max, self%tol, self%integ, &
                   out%r(:, k), out%st(k), self%field, k)
    else
      call one_map(self%model, self%psec, self%x0(:, k), self%n_iter, self%t_max, self%tol, self%integ, &
                   out%r(:, k), out%st(k))
    end if
  end subroutine map_item

  !> Seed k in a lane: one_map's set-up.
  subroutine map_start(self, k, lane, stat)
    class(map_jobs_t), intent(inout) :: self
    integer, intent(in) :: k
    type(lane_t), intent(inout) :: lane
    integer, intent(out) :: stat
    class(event_t), allocatable :: ev
    stat = TUBES_OK
    if (allocated(self%field)) then
      call lane%setup(self%field, self%integ%h, self%tol, self%tol, 100000000_i8)
    else
      call lane%setup(self%model, self%integ%h, self%tol, self%tol, 100000000_i8)
    end if
    lane%x = self%x0(:, k)
    lane%tend = self%t_max
    lane%use_log = .true.
    lane%log%max_crossings = self%n_iter
    call self%psec%event(.false., ev)
    call move_alloc(ev, lane%event)
  end subroutine map_start

  !> Seed k's returns, as one_map's (NaN past the last).
  subroutine map_finish(self, k, lane, out)
    use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
    class(map_jobs_t), intent(in) :: self
    integer, intent(in) :: k
    type(lane_t), intent(inout) :: lane
    type(ens_out_t), intent(inout) :: out
    integer :: j
    out%st(k) = map_status(self%model, lane%stat, lane%x)
    out%r(:, k) = ieee_value(1.0_wp, ieee_quiet_nan)
    do j = 1, min(lane%log%n, self%n_iter)
      out%r(2*j - 1:2*j, k) = self%psec%coords(lane%log%x(:, j))
    end do
  end subroutine map_finish

  !> The returns of one trajectory (all locals: thread-private by construction).
  subroutine one_map(ball, psec, x0, n_iter, t_max, tol, integ, pts, stat, field, stream)
    use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
    class(hamiltonian_t), intent(in) :: ball
    type(poincare_t), intent(in) :: psec
    type(integ_choice_t), intent(in) :: integ
    real(wp), intent(in) :: x0(:), t_max, tol
    integer, intent(in) :: n_iter
    real(wp), intent(out) :: pts(2, n_iter)
    integer, intent(out) :: stat
    class(vector_field_t), intent(in), optional :: field
    integer, intent(in), optional :: stream      !! a noisy field's trajectory number (its noise)
    type(crossing_log_t) :: log
    class(integrator_t), allocatable :: ig
    class(event_t), allocatable :: ev
    real(wp) :: x(size(x0))
    integer :: k
    pts = ieee_value(1.0_wp, ieee_quiet_nan)
    call trajectory_integrator(ball, tol, integ, ig, stat, field, stream)
    if (stat /= TUBES_OK) return
    ig%max_steps = 100000000
    x = x0
    log%max_crossings = n_iter
    call psec%event(.false., ev)
    call propagate(ig, x, t_max, stat, event=ev, crossings=log)
    stat = map_status(ball, stat, x)
    do k = 1, min(log%n, n_iter)
      pts(:, k) = psec%coords(log%x(:, k))
    end do
  end subroutine one_map

  !> A Poincare seed's status from its integration's: TUBES_OK at t_max or the last return; also
  !> TUBES_OK when the model refused a state far outside its region (the last accepted one beyond
  !> ESCAPE_SCALES length scales: an escape to infinity in finite time, as Henon-Heiles' above
  !> its saddles), for such a seed has only stopped returning; any other failure as it is.
  integer function map_status(model, stat, x) result(st)
    class(hamiltonian_t), intent(in) :: model
    integer, intent(in) :: stat
    real(wp), intent(in) :: x(:)
    st = stat
    if (stat == TUBES_EVENT) st = TUBES_OK
    if (stat == TUBES_EMODEL) then
      if (sum(abs(x(1:model%ndof()))) > ESCAPE_SCALES*model%length_scale()) st = TUBES_OK
    end if
  end function map_status
end module tubes_transport
