!> Equilibria of Hamilton's equations for any model (tubes_hamiltonian), their index (the
!> number of eigenvalues of the linearised flow with positive real part; for natural systems
!> the Morse index of V), names, and at rank-1 saddles (one real pair, the rest centres) the
!> linearised flow: lambda, the centre frequencies omega_k and the eigenvectors (LAPACK dgeev).
!> Natural systems: rest points p = 0 at the critical points of V, by Newton in q. Others (the
!> CR3BP): Newton on the 2N-dimensional vector field from (q, rest momenta of q).
!> A degenerate equilibrium (a Hessian eigenvalue 0, a root of grad V of multiplicity m > 1 along
!> it) is found too: Newton converges only linearly there (by (m - 1)/m an iteration) and, where
!> the Hessian is singular, takes the pseudo-inverse's step; it is accepted by its residual
!> (GRAD_TOL) and located to about (residual/c)^(1/m) along the degenerate direction
!> (docs/models.md, "Degenerate equilibria").
module tubes_equilibria
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
  use tubes_kinds, only: wp
  use tubes_lapack, only: eigen, dsyev, dgesv
  use tubes_hamiltonian, only: hamiltonian_t, natural_t, NAMES_QUADRANT, NAMES_LAGRANGE
  use tubes_status, only: TUBES_OK, TUBES_EINPUT, TUBES_ENOCONV
  implicit none
  private

  integer, parameter, public :: MAX_EQUILIBRIA = 256   !! equilibria kept at most (more: TUBES_ENOCONV)
  integer, parameter :: MAXN = 8                       !! configuration dimension at most
  !> Natural systems: q is an equilibrium when Newton from a grid point ends there and
  !> |grad shape(q)| <= GRAD_TOL G, G the largest |grad shape| on the search grid
  real(wp), parameter, public :: GRAD_TOL = 1.0e-10_wp
  !> Natural systems: a Hessian eigenvalue kappa is zero (a degenerate mode) when
  !> |kappa| <= CURV_TOL K, K = max(max |kappa|, G / (the box's largest half-width))
  real(wp), parameter, public :: CURV_TOL = 1.0e-8_wp
  integer, parameter :: NEWTON_FAST = 60    !! iterations before a slow (degenerate) root's own rules
  integer, parameter :: NEWTON_MAX = 400    !! iterations at most: (m-1)/m per step, 1 -> 1e-14 for m <= 8
  integer, parameter :: NEWTON_STALL = 20   !! after NEWTON_FAST: stop after this many without a
                                            !! smaller residual (the roundoff floor)

  !> One equilibrium.
  type, public :: equilibrium_t
    real(wp), allocatable :: q(:)   !! configuration [units of q]
    real(wp), allocatable :: x(:)   !! full state (q, p); p = 0 for natural systems
    real(wp) :: height = 0          !! natural: shape(q) (the ball: H(x, y) [cm]); else H
    real(wp) :: energy = 0          !! H at the equilibrium
    real(wp) :: grad_norm = 0       !! Newton residual: |grad shape| (natural) or |f(x)|
    real(wp) :: location_error = 0  !! estimated distance to the exact equilibrium [units of q]:
                                    !! Newton's last step, times (m - 1) at a root of multiplicity m
    integer :: nzero = 0            !! zero modes: Hessian eigenvalues 0 within CURV_TOL (natural),
                                    !! else zero pairs of the flow's spectrum
    real(wp), allocatable :: curv(:) !! natural: Hessian eigenvalues of shape, ascending
    integer :: morse = -1           !! index: eigenvalues with Re > 0 (natural: Morse index of V)
    logical :: rank1 = .false.      !! one real pair +-lambda, all others +-i omega_k
    logical :: degenerate = .false. !! one real pair +-lambda, the others +-i omega_k or 0 (a mode
                                    !! without quadratic term, e.g. a quartic bath): named D<k>;
                                    !! lambda, evec(:, 1:2) and the nonzero omegas are set
    character(len=8) :: name = ''   !! docs/models.md, "Naming of equilibria"
    real(wp) :: lambda = 0          !! rank-1 only: real eigenvalue of the flow [1/time]
    real(wp), allocatable :: omegas(:) !! rank-1 only: centre frequencies, ascending [rad/time]
    real(wp) :: omega = 0           !! rank-1 only: omegas(1)
    real(wp), allocatable :: evec(:, :) !! rank-1 only: columns u(+lambda), s(-lambda), Re c_k, Im c_k,
                                        !! each of unit length (Re, Im: the centre plane; linearize)
    real(wp), allocatable :: freqs(:) !! every equilibrium: the frequencies omega of its centre pairs
                                      !! +-i omega, ascending, NaN-padded to N [rad/time]
    logical :: stable = .false.     !! linearly (spectrally) stable: all N pairs are centres
  end type equilibrium_t

  public :: find_equilibria, continue_equilibria, linearize, quadrant, rest_jacobian, sort_indices, neck_normal, &
            nhim_reach, gate_holds_nhim



  !> A Newton loop's record: its last two steps' lengths and the stall of its residual.
  type :: newton_log_t
    real(wp) :: step = huge(1.0_wp), step_prev = huge(1.0_wp)
    real(wp) :: gbest = huge(1.0_wp)   !! the smallest residual so far
    integer :: nstall = 0              !! iterations since it decreased
  end type newton_log_t
contains

  !> The NHIM's reach along the unit vector n (configuration) at de above the saddle, from the
  !> linearisation: max_k sqrt(2 de / (omega_k |a_k^T J b_k|)) |(n . a_k, n . b_k)|, a_k + i b_k the
  !> k-th centre eigenvector (docs/theory.md, the flux's slab) [units of q].
  pure real(wp) function nhim_reach(sad, de, n) result(ext)
    type(equilibrium_t), intent(in) :: sad
    real(wp), intent(in) :: de, n(:)
    real(wp) :: a(size(sad%x)), b(size(sad%x)), sy
    integer :: k, nd
    nd = size(n)
    ext = 0
    do k = 1, nd - 1
      if (size(sad%evec, 2) < 2 + 2*k .or. .not. sad%omegas(k) > 0) cycle
      a = sad%evec(:, 1 + 2*k)
      b = sad%evec(:, 2 + 2*k)
      sy = abs(dot_product(a(1:nd), b(nd + 1:)) - dot_product(a(nd + 1:), b(1:nd)))
      if (.not. sy > 0) cycle
      ext = max(ext, sqrt(2*de/(sad%omegas(k)*sy))*sqrt(dot_product(n, a(1:nd))**2 + dot_product(n, b(1:nd))**2))
    end do
  end function nhim_reach

  !> Does a gate (the flux's slab half-width, the Monte Carlo's transit distance) hold the NHIM of
  !> that reach? Orbits on or near the NHIM swing by up to the reach either way of the saddle: a
  !> gate within twice the reach counts their swings as passages (TUBES_ENARROW).
  pure logical function gate_holds_nhim(reach, gate)
    real(wp), intent(in) :: reach, gate
    gate_holds_nhim = 2*reach < gate
  end function gate_holds_nhim

  !> The unit normal of a rank-1 saddle's neck in configuration space (unoriented): the direction
  !> of negative curvature of A Hess(V_eff) at the saddle, A = d2H/dp2 and V_eff the effective
  !> potential (tubes_hamiltonian quadratic_parts; Hess V_eff is the Schur complement
  !> H_qq - H_qp H_pp^-1 H_pq of the Hessian at the equilibrium). For a natural model that is the
  !> configuration part of the unstable eigenvector (q'' = -A Hess(V) q), taken from evec. For a
  !> gyroscopic one (the CR3BP) the eigenvector leans with the Coriolis terms (at the CR3BP's L1 by
  !> about 25 degrees) while the neck, the part of {V_eff <= E} between the realms, stays across
  !> V_eff's own saddle direction (the x axis at L1): a gate or transit plane across the lean
  !> eigenvector cuts a realm away from the neck (docs/theory.md, the flux's dividing surface). Falls
  !> back to the eigenvector where H_pp is singular or A Hess(V_eff) has no negative eigenvalue.
  function neck_normal(model, sad) result(n)
    class(hamiltonian_t), intent(in) :: model
    type(equilibrium_t), intent(in) :: sad
    real(wp) :: n(size(sad%q))
    real(wp) :: h(size(sad%x), size(sad%x)), a(size(sad%q), size(sad%q)), c(size(sad%q), size(sad%q)), &
                b(size(sad%q), size(sad%q)), vr(size(sad%q), size(sad%q)), wr(size(sad%q)), wi(size(sad%q))
    integer :: nd, k, st, ipiv(size(sad%q))
    nd = size(sad%q)
    n = sad%evec(1:nd, 1)/sqrt(sum(sad%evec(1:nd, 1)**2))
    if (model%is_natural()) return
    call model%hessian(sad%x, h, st)
    if (st /= TUBES_OK) return
    a = h(nd + 1:, nd + 1:)
    c = h(nd + 1:, 1:nd)
    call dgesv(nd, nd, a, nd, ipiv, c, nd, st)              ! c = H_pp^-1 H_pq
    if (st /= 0) return
    b = matmul(h(nd + 1:, nd + 1:), h(1:nd, 1:nd) - matmul(h(1:nd, nd + 1:), c))
    call eigen(b, wr, wi, st, vr)
    if (st /= TUBES_OK) return
    k = minloc(wr, 1)
    if (.not. (wr(k) < 0 .and. wi(k) == 0)) return
    n = vr(:, k)/sqrt(sum(vr(:, k)**2))
  end function neck_normal

  !> idx reordered so that key(idx) ascends (insertion sort: a few eigenvalue pairs).
  pure subroutine sort_indices(idx, key)
    integer, intent(inout) :: idx(:)
    real(wp), intent(in) :: key(:)
    integer :: k, j, t
    do k = 2, size(idx)
      j = k
      do while (j > 1)
        if (.not. key(idx(j)) < key(idx(j - 1))) exit
        t = idx(j); idx(j) = idx(j - 1); idx(j - 1) = t
        j = j - 1
      end do
    end do
  end subroutine sort_indices

  !> Quadrant 1..4 of (x, y), 0 on an axis.
  pure integer function quadrant(q)
    real(wp), intent(in) :: q(:)
    quadrant = 0
    if (q(1) > 0 .and. q(2) > 0) quadrant = 1
    if (q(1) < 0 .and. q(2) > 0) quadrant = 2
    if (q(1) < 0 .and. q(2) < 0) quadrant = 3
    if (q(1) > 0 .and. q(2) < 0) quadrant = 4
  end function quadrant

  !> Solve a x = b for a small system (closed form for n = 2, LAPACK otherwise; n <= MAXN).
  !> Fixed-size locals: this runs thousands of times per equilibrium search, and gfortran puts
  !> automatic arrays on the heap.
  subroutine small_solve(a, b, x, ok)
    real(wp), intent(in) :: a(:, :), b(:)
    real(wp), intent(out) :: x(:)
    logical, intent(out) :: ok
    real(wp) :: det, aa(MAXN, MAXN), bb(MAXN)
    integer :: ipiv(MAXN), info, n
    n = size(b)
    ok = .true.
    if (n == 2) then
      det = a(1, 1)*a(2, 2) - a(1, 2)*a(2, 1)
      if (abs(det) < 1.0e-14_wp) then
        ok = .false.
        return
      end if
      x(1) = (a(2, 2)*b(1) - a(1, 2)*b(2))/det
      x(2) = (a(1, 1)*b(2) - a(2, 1)*b(1))/det
    else
      aa(1:n, 1:n) = a
      bb(1:n) = b
      call dgesv(n, 1, aa, MAXN, ipiv, bb, MAXN, info)
      ok = info == 0
      x = bb(1:n)
    end if
  end subroutine small_solve

  !> Pseudo-inverse solve of the symmetric a x = b (n <= MAXN): x = sum_i v_i (v_i.b)/kappa_i
  !> over the eigenpairs (kappa_i, v_i) of a with kappa_i /= 0 and a representable quotient; the
  !> others (a flat direction) are left out. For a singular Hessian, where small_solve refuses.
  subroutine pinv_solve(a, b, x, ok)
    real(wp), intent(in) :: a(:, :), b(:)
    real(wp), intent(out) :: x(:)
    logical, intent(out) :: ok          !! .false. only if LAPACK's dsyev failed
    real(wp) :: aa(MAXN, MAXN), ev(MAXN), work(64), c
    integer :: n, i, info
    n = size(b)
    aa(1:n, 1:n) = a
    call dsyev('V', 'U', n, aa, MAXN, ev, work, 64, info)
    ok = info == 0
    x = 0
    if (.not. ok) return
    do i = 1, n
      c = dot_product(aa(1:n, i), b)
      if (abs(ev(i)) > 0 .and. abs(c) < abs(ev(i))*1.0e200_wp) x = x + aa(1:n, i)*(c/ev(i))
    end do
  end subroutine pinv_solve

  !> Estimated distance to the root after a Newton step of length step whose predecessor was
  !> step_prev: at a root of multiplicity m the steps shrink by r = (m - 1)/m and the distance
  !> left is step r/(1 - r) = (m - 1) step; r is capped at 0.95 (m = 20).
  !> A loop that did not converge (stalled at the roundoff floor, or NEWTON_MAX) counts the
  !> longer of its last two steps.
  pure real(wp) function newton_error(converged, lg)
    logical, intent(in) :: converged
    type(newton_log_t), intent(in) :: lg
    real(wp) :: r, s
    s = lg%step
    if (.not. converged) s = max(lg%step, lg%step_prev)
    r = 0
    if (lg%step_prev > 0 .and. lg%step_prev < huge(1.0_wp)) r = min(s/lg%step_prev, 0.95_wp)
    newton_error = s*max(1.0_wp, r/(1 - r))
  end function newton_error

  !> The stall rule of both Newton loops: lg keeps the smallest residual so far and the
  !> iterations since; stalled once it has not decreased for NEWTON_STALL iterations after the
  !> first NEWTON_FAST (a degenerate root's linear approach has reached roundoff).
  pure subroutine track_stall(it, gn, lg, stalled)
    integer, intent(in) :: it
    real(wp), intent(in) :: gn
    type(newton_log_t), intent(inout) :: lg
    logical, intent(out) :: stalled
    if (gn < lg%gbest) then
      lg%gbest = gn
      lg%nstall = 0
    else
      lg%nstall = lg%nstall + 1
    end if
    stalled = it > NEWTON_FAST .and. lg%nstall > NEWTON_STALL
  end subroutine track_stall

  !> Newton's method on grad shape = 0 from q (natural systems). Steps are damped to
  !> length_scale; a singular Hessian takes the pseudo-inverse's step. It ends when the step is
  !> below roundoff, or, after NEWTON_FAST iterations (a degenerate root: linear convergence),
  !> when the residual stopped decreasing or after NEWTON_MAX; ok if then |grad shape| <= gtol
  !> (default 1e-13). err: the estimated distance to the root (newton_error).
  subroutine newton_natural(model, q, ok, gtol, err)
    class(natural_t), intent(in) :: model
    real(wp), intent(inout) :: q(:)
    logical, intent(out) :: ok
    real(wp), intent(in), optional :: gtol
    real(wp), intent(out), optional :: err
    real(wp) :: gr(MAXN), hs(MAXN, MAXN), dq(MAXN), scale, ls, gn, tol
    type(newton_log_t) :: lg
    integer :: it, n
    logical :: converged, solved, stalled
    ok = .false.
    converged = .false.
    n = size(q)
    ls = model%length_scale()
    tol = 1.0e-13_wp
    if (present(gtol)) tol = gtol
    if (present(err)) err = huge(1.0_wp)
    do it = 1, NEWTON_MAX
      call model%shape_derivs(q, gr(1:n), hs(1:n, 1:n))
      if (.not. all(abs(gr(1:n)) <= huge(1.0_wp))) return
      call track_stall(it, sqrt(sum(gr(1:n)**2)), lg, stalled)
      if (stalled) exit
      call small_solve(hs(1:n, 1:n), gr(1:n), dq(1:n), solved)
      if (.not. solved) call pinv_solve(hs(1:n, 1:n), gr(1:n), dq(1:n), solved)
      if (.not. solved) return
      lg%step_prev = lg%step
      lg%step = sqrt(sum(dq(1:n)**2))
      scale = max(1.0_wp, lg%step/ls)   ! damp long steps to one length scale
      q = q - dq(1:n)/scale
      if (lg%step <= 1.0e-14_wp*max(ls, sqrt(sum(q**2)))) then
        converged = .true.
        exit
      end if
    end do
    call model%shape_derivs(q, gr(1:n), hs(1:n, 1:n))
    gn = sqrt(sum(gr(1:n)**2))
    ok = gn <= tol
    if (present(err)) err = newton_error(converged, lg)
  end subroutine newton_natural

  !> Least-squares step for a singular Jacobian: x minimises |a x - b| with the least norm, from
  !> the eigenpairs of a^T a (pinv_solve).
  subroutine lsq_solve(a, b, x, ok)
    real(wp), intent(in) :: a(:, :), b(:)
    real(wp), intent(out) :: x(:)
    logical, intent(out) :: ok
    real(wp) :: ata(MAXN, MAXN), atb(MAXN)
    integer :: n
    n = size(b)
    if (n > MAXN) then
      ok = .false.
      x = 0
      return
    end if
    ata(1:n, 1:n) = matmul(transpose(a), a)
    atb(1:n) = matmul(transpose(a), b)
    call pinv_solve(ata(1:n, 1:n), atb(1:n), x, ok)
  end subroutine lsq_solve

  !> Newton's method on f(x) = J grad H = 0 in 2N dimensions (any model); a singular Jacobian
  !> takes the least-squares step, a slow (degenerate) root the rules of newton_natural; ok if at
  !> the end |f| <= 1e-10 max(length_scale, |x|). err as newton_natural's.
  subroutine newton_general(model, x, ok, err)
    class(hamiltonian_t), intent(in) :: model
    real(wp), intent(inout) :: x(:)
    logical, intent(out) :: ok
    real(wp), intent(out), optional :: err
    real(wp) :: f(size(x)), jac(size(x), size(x)), dx(size(x)), scale, ls, xs
    type(newton_log_t) :: lg
    integer :: it, stat, n
    logical :: converged, solved, stalled
    ok = .false.
    converged = .false.
    n = size(x)/2
    ls = model%length_scale()
    if (present(err)) err = huge(1.0_wp)
    do it = 1, NEWTON_MAX
      call model%eval(0.0_wp, x, f, stat)
      if (stat /= 0) return
      call track_stall(it, sqrt(sum(f**2)), lg, stalled)
      if (stalled) exit
      call model%jacobian(0.0_wp, x, jac, stat)
      if (stat /= 0) return
      call small_solve(jac, f, dx, solved)
      if (.not. solved) call lsq_solve(jac, f, dx, solved)
      if (.not. solved) return
      lg%step_prev = lg%step
      lg%step = sqrt(sum(dx**2))
      scale = max(1.0_wp, sqrt(sum(dx(1:n)**2))/ls)
      x = x - dx/scale
      xs = max(ls, sqrt(sum(x**2)))
      if (lg%step <= 1.0e-14_wp*xs) then
        converged = .true.
        exit
      end if
    end do
    call model%eval(0.0_wp, x, f, stat)
    xs = max(ls, sqrt(sum(x**2)))
    ok = stat == 0 .and. sqrt(sum(f**2)) <= 1.0e-10_wp*xs
    if (present(err)) err = newton_error(converged, lg)
  end subroutine newton_general

  !> Steepest descent of shape from q into a minimum (names saddles by their wells); ok =
  !> .false. if the final Newton polish did not converge.
  subroutine descend(model, q, ok)
    class(natural_t), intent(in) :: model
    real(wp), intent(inout) :: q(:)
    logical, intent(out) :: ok
    real(wp) :: gr(size(q)), hs(size(q), size(q)), a, qn(size(q)), h0, grn(size(q))
    integer :: it
    a = 1.0_wp
    do it = 1, 20000
      call model%shape_derivs(q, gr, hs)
      if (sqrt(sum(gr**2)) < 1.0e-6_wp) exit
      h0 = model%shape(q)
      do
        qn = q - a*gr
        if (model%shape(qn) < h0 .or. a < 1.0e-12_wp) exit
        ! shape's rounding can hide a decrease (a large additive constant: the ball's h0 = 1e10):
        ! still going down along -gr at qn (grad shape(qn) . gr > 0) is a step downhill too
        call model%shape_derivs(qn, grn, hs)
        if (dot_product(grn, gr) > 0) exit
        a = a/2
      end do
      q = qn
      a = min(2*a, 10.0_wp)
    end do
    call newton_natural(model, q, ok)
  end subroutine descend

  !> Eigenvalues (ascending) and vectors of the Hessian of shape at q.
  subroutine hessian_eigs(model, q, ev, vecs, stat)
    class(natural_t), intent(in) :: model
    real(wp), intent(in) :: q(:)
    real(wp), intent(out) :: ev(:), vecs(:, :)
    integer, intent(out) :: stat     !! TUBES_ENOCONV if LAPACK's dsyev failed
    real(wp) :: gr(MAXN), work(64)
    integer :: info, n
    n = size(q)
    call model%shape_derivs(q, gr(1:n), vecs)
    call dsyev('V', 'U', n, vecs, n, ev, work, 64, info)
    stat = merge(TUBES_OK, TUBES_ENOCONV, info == 0)
  end subroutine hessian_eigs

  !> All equilibria with q in the box [lo, hi] (per coordinate), by Newton from an n_grid^N
  !> grid, deduplicated, classified and named. Sorted: by index, then by name. Natural systems:
  !> a point where |grad shape| <= GRAD_TOL G (G: the largest |grad shape| on the grid);
  !> others: |f| <= 1e-10 max(length_scale, |x|). Two points are one equilibrium when closer
  !> than 1e-6 max(1, half-width) plus their location errors (a degenerate one's is larger);
  !> of such a pair the better located is kept when the first is poorly located (a degenerate
  !> root's, location_error > 1e-8 max(length_scale, |q|)).
  !> stat: TUBES_EINPUT for a bad box; TUBES_ENOCONV if more than MAX_EQUILIBRIA were found
  !> (nothing is dropped silently: errmsg says so).
  subroutine find_equilibria(model, lo, hi, n_grid, eqs, stat, errmsg)
    class(hamiltonian_t), intent(in) :: model
    real(wp), intent(in) :: lo(:), hi(:)   !! the search box [units of q] (size N)
    integer, intent(in) :: n_grid          !! starting points per axis (>= 2)
    type(equilibrium_t), allocatable, intent(out) :: eqs(:)
    integer, intent(out) :: stat
    character(:), allocatable, intent(out), optional :: errmsg
    real(wp), allocatable :: starts(:, :)
    integer, allocatable :: origin(:)
    character(:), allocatable :: msg   ! (errmsg passed on twice lost its text at -O0 with gfortran 12)
    integer :: nd, ig
    nd = model%ndof()
    call check_box(model, lo, hi, n_grid, stat, msg)
    if (stat == TUBES_OK) then
      allocate (starts(nd, n_grid**nd))
      do ig = 0, n_grid**nd - 1
        call grid_point(lo, hi, n_grid, ig, starts(:, ig + 1))
      end do
      call equilibria_from(model, lo, hi, n_grid, starts, eqs, origin, stat, msg)
    end if
    if (present(errmsg) .and. allocated(msg)) errmsg = msg
  end subroutine find_equilibria

  !> The equilibria continued from the configurations starts(:, k) (a parameter scan's previous
  !> step: docs/scan.md): Newton from each start, as find_equilibria's from its grid points (the
  !> same tolerances, from the same n_grid grid's gradient scale), then deduplicated, classified,
  !> named and sorted as find_equilibria's. origin(k): the index in eqs of the equilibrium start
  !> k converged to, 0 if its Newton failed or it left the box [lo, hi]; two starts with one
  !> origin have met (a fold passed). stat as find_equilibria's.
  subroutine continue_equilibria(model, lo, hi, n_grid, starts, eqs, origin, stat, errmsg)
    class(hamiltonian_t), intent(in) :: model
    real(wp), intent(in) :: lo(:), hi(:)   !! the search box [units of q] (size N)
    integer, intent(in) :: n_grid          !! the grid of the gradient's scale (as find_equilibria's)
    real(wp), intent(in) :: starts(:, :)   !! (N, m) configurations
    type(equilibrium_t), allocatable, intent(out) :: eqs(:)
    integer, allocatable, intent(out) :: origin(:)
    integer, intent(out) :: stat
    character(:), allocatable, intent(out), optional :: errmsg
    character(:), allocatable :: msg
    call check_box(model, lo, hi, n_grid, stat, msg)
    if (stat == TUBES_OK) call equilibria_from(model, lo, hi, n_grid, starts, eqs, origin, stat, msg)
    if (present(errmsg) .and. allocated(msg)) errmsg = msg
  end subroutine continue_equilibria

  !> find_equilibria's check of the box: TUBES_EINPUT with a message, else TUBES_OK.
  subroutine check_box(model, lo, hi, n_grid, stat, errmsg)
    class(hamiltonian_t), intent(in) :: model
    real(wp), intent(in) :: lo(:), hi(:)
    integer, intent(in) :: n_grid
    integer, intent(out) :: stat
    character(:), allocatable, intent(out), optional :: errmsg
    integer :: nd
    stat = TUBES_OK
    nd = model%ndof()
    if (size(lo) /= nd .or. size(hi) /= nd .or. n_grid < 2 .or. nd > 8) then
      stat = TUBES_EINPUT
      if (present(errmsg)) errmsg = 'find_equilibria: the box must have N = ndof entries, n_grid >= 2'
      return
    end if
    if (any(.not. (hi > lo))) then
      stat = TUBES_EINPUT
      if (present(errmsg)) errmsg = 'find_equilibria: the box is empty (hi <= lo)'
    end if
  end subroutine check_box

  !> Grid point ig of the n_grid^N grid of [lo, hi]: digits in base n_grid, coordinate 1 the
  !> slowest (as the 2-D loop i, j).
  pure subroutine grid_point(lo, hi, n_grid, ig, q)
    real(wp), intent(in) :: lo(:), hi(:)
    integer, intent(in) :: n_grid, ig
    real(wp), intent(out) :: q(:)
    integer :: kk, ii, id(8), nd
    nd = size(q)
    kk = ig
    do ii = nd, 1, -1
      id(ii) = mod(kk, n_grid)
      kk = kk/n_grid
    end do
    do ii = 1, nd
      q(ii) = lo(ii) + (hi(ii) - lo(ii))*id(ii)/(n_grid - 1)
    end do
  end subroutine grid_point

  !> The equilibria Newton finds from the configurations starts(:, k) (find_equilibria's rules),
  !> origin(k) as continue_equilibria's.
  subroutine equilibria_from(model, lo, hi, n_grid, starts, eqs, origin, stat, errmsg)
    class(hamiltonian_t), intent(in) :: model
    real(wp), intent(in) :: lo(:), hi(:)
    integer, intent(in) :: n_grid
    real(wp), intent(in) :: starts(:, :)
    type(equilibrium_t), allocatable, intent(out) :: eqs(:)
    integer, allocatable, intent(out) :: origin(:)
    integer, intent(out) :: stat
    character(:), allocatable, intent(out), optional :: errmsg
    type(equilibrium_t), allocatable :: found(:)
    real(wp), allocatable :: q(:), x(:), p(:), gr(:), hs(:, :)
    real(wp) :: dup_tol, tol_box, gmax, gtol, err, kscale
    integer :: n, nd, k, m, ngrid_total, ig, i, j, st, kdup
    integer, allocatable :: order(:), pos(:)
    logical :: ok
    character(160) :: msg
    stat = TUBES_OK
    nd = model%ndof()
    allocate (found(MAX_EQUILIBRIA), q(nd), x(2*nd), p(nd), gr(nd), hs(nd, nd), origin(size(starts, 2)))
    origin = 0
    n = 0
    dup_tol = 1.0e-6_wp*max(1.0_wp, maxval(0.5_wp*(hi - lo)))
    ngrid_total = n_grid**nd
    ! the gradient's scale G on the grid (natural systems): the residual GRAD_TOL G accepts
    gmax = 0
    select type (model)
    class is (natural_t)
      do ig = 0, ngrid_total - 1
        call grid_point(lo, hi, n_grid, ig, q)
        call model%shape_derivs(q, gr, hs)
        if (all(abs(gr) <= huge(1.0_wp))) gmax = max(gmax, sqrt(sum(gr**2)))
      end do
    end select
    gtol = GRAD_TOL*gmax
    kscale = gmax/maxval(0.5_wp*(hi - lo))
    do ig = 1, size(starts, 2)
      q = starts(:, ig)
      select type (model)
      class is (natural_t)
        call newton_natural(model, q, ok, gtol, err)
        x(1:nd) = q
        x(nd + 1:) = 0
      class default
        p = 0
        call model%rest_momenta(q, p, st)
        if (st /= TUBES_OK) cycle
        x = [q, p]
        call newton_general(model, x, ok, err)
        q = x(1:nd)
      end select
      if (.not. ok) cycle
      tol_box = 1.0e-12_wp
      if (any(q < lo - tol_box*abs(lo) .or. q > hi + tol_box*abs(hi))) cycle
      kdup = 0
      do k = 1, n
        if (sqrt(sum((found(k)%x - x)**2)) < dup_tol + found(k)%location_error + err) then
          kdup = k
          exit
        end if
      end do
      if (kdup > 0) then
        origin(ig) = kdup
        ! keep the better located of a poorly located (degenerate) pair
        if (found(kdup)%location_error > 1.0e-8_wp*max(model%length_scale(), sqrt(sum(found(kdup)%q**2))) &
            .and. err < found(kdup)%location_error) then
          found(kdup)%q = q
          found(kdup)%x = x
          found(kdup)%location_error = err
        end if
        cycle
      end if
      if (n == size(found)) then
        stat = TUBES_ENOCONV      ! more equilibria than MAX_EQUILIBRIA: refuse, do not truncate
        if (present(errmsg)) then
          write (msg, '(a,i0,a)') 'find_equilibria: more than ', MAX_EQUILIBRIA, &
            ' equilibria in the box (none is returned): narrow the box'
          errmsg = trim(msg)
        end if
        return
      end if
      n = n + 1
      found(n)%q = q
      found(n)%x = x
      found(n)%location_error = err
      origin(ig) = n
    end do
    ! classify
    do k = 1, n
      call classify(model, found(k), kscale, stat)
      if (stat /= TUBES_OK) then
        if (present(errmsg)) errmsg = 'find_equilibria: the linearisation at an equilibrium failed'
        return
      end if
    end do
    call name_all(model, found(1:n))
    ! sort by (index, name): insertion sort on a short list
    m = n
    allocate (order(m), pos(m))
    order = [(i, i = 1, m)]
    do i = 2, m
      j = i
      do while (j > 1)
        if (before(found(order(j)), found(order(j - 1)))) then
          k = order(j); order(j) = order(j - 1); order(j - 1) = k
          j = j - 1
        else
          exit
        end if
      end do
    end do
    allocate (eqs(m))
    do i = 1, m
      eqs(i) = found(order(i))
      pos(order(i)) = i
    end do
    do i = 1, size(origin)
      if (origin(i) > 0) origin(i) = pos(origin(i))
    end do
  end subroutine equilibria_from

  !> Energy, residual, index and (rank-1 or degenerate) linearisation of one equilibrium.
  !> Natural systems: from the Hessian's eigenvalues kappa, zero when |kappa| <= CURV_TOL
  !> max(max |kappa|, kscale): index = count(kappa < 0) of the others; degenerate = index 1 with
  !> zero modes (linearised with the zero modes projected out of the Hessian). Others: from the
  !> flow's spectrum (1e-8 of its largest modulus).
  subroutine classify(model, e, kscale, stat)
    class(hamiltonian_t), intent(in) :: model
    type(equilibrium_t), intent(inout) :: e
    real(wp), intent(in) :: kscale     !! curvature scale G / half-width of the box
    integer, intent(out) :: stat
    integer :: nd, nreal, ncentre, nzero, k, nz
    real(wp) :: f(size(e%x)), gr(size(e%q)), hs(size(e%q), size(e%q)), vecs(size(e%q), size(e%q))
    real(wp) :: wr(size(e%x)), wi(size(e%x)), scale, ztol
    real(wp), allocatable :: zdirs(:, :), fr(:)
    integer, allocatable :: ic(:)
    logical :: natural
    nd = size(e%q)
    stat = TUBES_OK
    natural = .false.
    ztol = 0
    allocate (e%curv(nd))
    e%curv = 0
    select type (model)
    class is (natural_t)
      natural = .true.
      call model%shape_derivs(e%q, gr, hs)
      e%grad_norm = sqrt(sum(gr**2))
      e%height = model%shape(e%q)
      e%energy = model%potential_scale()*e%height
      call hessian_eigs(model, e%q, e%curv, vecs, stat)
      if (stat /= TUBES_OK) return
      ztol = CURV_TOL*max(maxval(abs(e%curv)), kscale)
      e%nzero = count(abs(e%curv) <= ztol)
      e%morse = count(e%curv < -ztol)
      allocate (zdirs(nd, e%nzero))
      nz = 0
      do k = 1, nd
        if (abs(e%curv(k)) <= ztol) then
          nz = nz + 1
          zdirs(:, nz) = vecs(:, k)
        end if
      end do
    class default
      call model%eval(0.0_wp, e%x, f, stat)
      if (stat /= 0) return
      e%grad_norm = sqrt(sum(f**2))
      e%energy = model%energy(e%x)
      e%height = e%energy
    end select
    call spectrum(model, e%x, wr, wi, stat)
    if (stat /= TUBES_OK) return
    scale = max(maxval(abs(wr)), maxval(abs(wi)))
    nreal = count(wr > 1.0e-8_wp*scale .and. abs(wi) <= 1.0e-8_wp*scale)
    ncentre = count(abs(wr) <= 1.0e-8_wp*scale .and. wi > 1.0e-8_wp*scale)
    ! the full linear spectrum's centres, at every equilibrium (a well, L4/L5: centre x centre)
    allocate (e%freqs(nd))
    e%freqs = ieee_value(1.0_wp, ieee_quiet_nan)
    fr = pack(wi, abs(wr) <= 1.0e-8_wp*scale .and. wi > 1.0e-8_wp*scale)
    ic = [(k, k = 1, size(fr))]
    call sort_indices(ic, fr)
    e%freqs(1:min(size(fr), nd)) = fr(ic(1:min(size(fr), nd)))
    e%stable = ncentre == nd
    if (natural) then
      e%rank1 = e%morse == 1 .and. e%nzero == 0 .and. nreal == 1 .and. ncentre == nd - 1
      e%degenerate = e%morse == 1 .and. e%nzero > 0
    else
      e%morse = count(wr > 1.0e-8_wp*scale)
      e%rank1 = e%morse == 1 .and. nreal == 1 .and. ncentre == nd - 1
      nzero = count(abs(wr) <= 1.0e-8_wp*scale .and. abs(wi) <= 1.0e-8_wp*scale)
      e%nzero = nzero/2
      e%degenerate = e%morse == 1 .and. nreal == 1 .and. nzero > 0 .and. 2*ncentre + nzero == 2*nd - 2
    end if
    if (e%rank1 .or. e%degenerate) then
      allocate (e%omegas(nd - 1), e%evec(2*nd, 2*nd))
      if (natural .and. e%degenerate) then
        call linearize(model, e%x, e%lambda, e%omegas, e%evec, stat, .true., zdirs)
      else
        call linearize(model, e%x, e%lambda, e%omegas, e%evec, stat, e%degenerate)
      end if
      if (stat /= TUBES_OK) return
      if (nd > 1) e%omega = e%omegas(1)   ! 1 DOF: no centre (omegas is empty)
    else
      allocate (e%omegas(max(nd - 1, 1)), e%evec(2*nd, 2*nd))
      e%omegas = 0
      e%evec = 0
    end if
  end subroutine classify

  !> Eigenvalues of the linearised flow at the equilibrium x.
  subroutine spectrum(model, x, wr, wi, stat)
    class(hamiltonian_t), intent(in) :: model
    real(wp), intent(in) :: x(:)
    real(wp), intent(out) :: wr(:), wi(:)
    integer, intent(out) :: stat
    real(wp) :: jac(size(x), size(x))
    call rest_jacobian(model, x, jac, stat)
    if (stat == TUBES_OK) call eigen(jac, wr, wi, stat)
  end subroutine spectrum

  !> Jacobian of Hamilton's equations at an equilibrium x. Natural systems:
  !> [[0, A(q)], [-Hess V, 0]] with the rest kinetic matrix (the kinetic terms are quadratic in
  !> p); others: the model's Jacobian.
  subroutine rest_jacobian(model, x, jac, stat)
    class(hamiltonian_t), intent(in) :: model
    real(wp), intent(in) :: x(:)
    real(wp), intent(out) :: jac(:, :)
    integer, intent(out) :: stat
    integer :: nd
    real(wp) :: gr(size(x)/2), hs(size(x)/2, size(x)/2), a(size(x)/2, size(x)/2)
    nd = size(x)/2
    stat = TUBES_OK
    select type (model)
    class is (natural_t)
      call model%shape_derivs(x(1:nd), gr, hs)
      call model%rest_kinetic_matrix(x(1:nd), a)
      jac = 0
      jac(1:nd, nd + 1:2*nd) = a
      jac(nd + 1:2*nd, 1:nd) = -model%potential_scale()*hs
    class default
      call model%jacobian(0.0_wp, x, jac, stat)
      if (stat /= 0) stat = TUBES_EINPUT
    end select
  end subroutine rest_jacobian

  !> Linearised flow at a rank-1 saddle x: eigenvalues +-lambda, +-i omega_k (LAPACK dgeev,
  !> omegas ascending) and eigenvectors as columns u, s, Re c_1, Im c_1, ..., unit length, u
  !> and s with their largest component positive. Re c_k and Im c_k (dgeev's eigenvector of
  !> +i omega_k) are normalised separately: a basis of the centre plane, and Re + i r Im is the
  !> eigenvector for r = |Im c_k|/|Re c_k| (before normalising), not r = 1 (docs/output.md). stat = TUBES_EINPUT if x is not a saddle x
  !> centre^(N-1). With degenerate = .true., also a saddle whose other eigenvalues are centres or
  !> 0 (a mode without quadratic term): its zero modes come first in omegas (0) with zero columns.
  !> zero_dirs (natural systems, with degenerate): the Hessian's eigenvectors of its zero
  !> eigenvalues (columns), projected out of the Hessian, so that those modes are exactly 0; the
  !> 2 size(zero_dirs, 2) eigenvalues of least modulus are then the zero modes.
  subroutine linearize(model, x, lambda, omegas, evec, stat, degenerate, zero_dirs)
    class(hamiltonian_t), intent(in) :: model
    real(wp), intent(in) :: x(:)
    real(wp), intent(out) :: lambda, omegas(:), evec(:, :)
    integer, intent(out) :: stat
    logical, intent(in), optional :: degenerate
    real(wp), intent(in), optional :: zero_dirs(:, :)
    real(wp) :: jac(size(x), size(x)), wr(size(x)), wi(size(x)), vr(size(x), size(x))
    real(wp) :: v(size(x)), nrm, scale, pr(size(x)/2, size(x)/2), hs(size(x)/2, size(x)/2), a(size(x)/2, size(x)/2)
    real(wp) :: gr(size(x)/2), amod(size(x))
    integer :: k, iu, is, n2, nc, ic(size(x)), j, nz, nd, iz(size(x))
    logical :: deg, zero(size(x))
    stat = TUBES_OK
    deg = .false.
    if (present(degenerate)) deg = degenerate
    n2 = size(x)
    nd = n2/2
    zero = .false.
    if (present(zero_dirs)) then
      select type (model)
      class is (natural_t)
        pr = -matmul(zero_dirs, transpose(zero_dirs))
        do k = 1, nd
          pr(k, k) = pr(k, k) + 1
        end do
        call model%shape_derivs(x(1:nd), gr, hs)
        hs = matmul(pr, matmul(hs, pr))
        hs = 0.5_wp*(hs + transpose(hs))
        call model%rest_kinetic_matrix(x(1:nd), a)
        jac = 0
        jac(1:nd, nd + 1:n2) = a
        jac(nd + 1:n2, 1:nd) = -model%potential_scale()*hs
      class default
        stat = TUBES_EINPUT
        return
      end select
    else
      call rest_jacobian(model, x, jac, stat)
      if (stat /= TUBES_OK) return
    end if
    call eigen(jac, wr, wi, stat, vr)
    if (stat /= TUBES_OK) return
    scale = max(maxval(abs(wr)), maxval(abs(wi)))
    if (present(zero_dirs)) then      ! the 2 nz eigenvalues of least modulus are the zero modes
      nz = size(zero_dirs, 2)
      amod = hypot(wr, wi)
      iz = [(k, k = 1, n2)]
      call sort_indices(iz, amod)
      zero(iz(1:2*nz)) = .true.
      if (any(amod(iz(1:2*nz)) > 1.0e-6_wp*scale)) then
        stat = TUBES_EINPUT
        return
      end if
    end if
    iu = maxloc(wr, 1, mask=.not. zero)
    is = minloc(wr, 1, mask=.not. zero)
    lambda = wr(iu)
    ! the centre pairs: dgeev stores a pair as columns j (Re) and j+1 (Im), wi(j) > 0
    nc = 0
    do j = 1, n2
      if (zero(j)) cycle
      if (wi(j) > 1.0e-8_wp*scale .and. abs(wr(j)) <= 1.0e-8_wp*scale) then
        nc = nc + 1
        ic(nc) = j
      end if
    end do
    ! zero modes (degenerate saddles only): the eigenvalues at 0, two per mode
    if (.not. present(zero_dirs)) then
      nz = 0
      if (deg) nz = count(abs(wr) <= 1.0e-8_wp*scale .and. abs(wi) <= 1.0e-8_wp*scale)/2
    end if
    if (lambda <= 0 .or. nc + nz /= n2/2 - 1 .or. size(omegas) < nc + nz) then
      stat = TUBES_EINPUT    ! not a saddle x centre^(N-1)
      return
    end if
    call sort_indices(ic(1:nc), wi)     ! ascending frequencies
    evec = 0
    evec(:, 1) = vr(:, iu)
    evec(:, 2) = vr(:, is)
    omegas = 0
    do k = 1, nc
      omegas(nz + k) = wi(ic(k))
      evec(:, 2*(nz + k) + 1) = vr(:, ic(k))
      evec(:, 2*(nz + k) + 2) = vr(:, ic(k) + 1)
    end do
    do k = 1, n2
      v = evec(:, k)
      nrm = sqrt(sum(v**2))
      if (nrm > 0) v = v/nrm
      if (v(maxloc(abs(v), 1)) < 0 .and. k <= 2) v = -v
      evec(:, k) = v
    end do
  end subroutine linearize

  !> Names by the model's scheme (docs/models.md, "Naming of equilibria").
  subroutine name_all(model, eqs)
    class(hamiltonian_t), intent(in) :: model
    type(equilibrium_t), intent(inout) :: eqs(:)
    integer :: k, nr, wa, wb, scheme, st
    logical :: oka, okb
    real(wp), allocatable :: qa(:), qb(:), vecs(:, :), ev(:)
    scheme = model%naming()
    if (scheme == NAMES_QUADRANT .and. size(eqs) > 0) then
      select type (model)
      class is (natural_t)
        nr = 0
        do k = 1, size(eqs)
          if (eqs(k)%nzero > 0) cycle   ! a degenerate point: no quadrant name, the generic ones
          select case (eqs(k)%morse)
          case (0)       ! a well on an axis has no quadrant: the generic names (W1, ...)
            if (quadrant(eqs(k)%q) > 0) write (eqs(k)%name, '(a,i0)') 'W', quadrant(eqs(k)%q)
          case (1)
            allocate (vecs(size(eqs(k)%q), size(eqs(k)%q)), ev(size(eqs(k)%q)))
            call hessian_eigs(model, eqs(k)%q, ev, vecs, st)
            qa = eqs(k)%q + 1.0e-3_wp*vecs(:, 1)
            qb = eqs(k)%q - 1.0e-3_wp*vecs(:, 1)
            call descend(model, qa, oka)
            call descend(model, qb, okb)
            wa = quadrant(qa)
            wb = quadrant(qb)
            ! a failed eigen-solve or descent leaves the name empty: generic names are used
            if (st == TUBES_OK .and. oka .and. okb .and. min(wa, wb) > 0) &
              write (eqs(k)%name, '(a,i0,i0)') 'S', min(wa, wb), max(wa, wb)
            deallocate (vecs, ev)
          case default
            nr = nr + 1
            write (eqs(k)%name, '(a,i0)') 'R', nr
          end select
        end do
        if (unique_names(eqs)) return
      end select
    else if (scheme == NAMES_LAGRANGE) then
      call name_lagrange(eqs)
      if (unique_names(eqs)) return
    end if
    call name_generic(eqs)
  end subroutine name_all

  logical function unique_names(eqs)
    type(equilibrium_t), intent(in) :: eqs(:)
    integer :: i, j
    unique_names = .true.
    do i = 1, size(eqs)
      if (len_trim(eqs(i)%name) == 0) unique_names = .false.
      do j = 1, i - 1
        if (eqs(i)%name == eqs(j)%name) unique_names = .false.
      end do
    end do
  end function unique_names

  !> W<k> (index 0, no zero mode: all centres), S<k> (rank-1), D<k> (degenerate index-1
  !> saddles), R<k> (others, a degenerate index-0 point among them), k by ascending energy, then
  !> q1, then q2.
  subroutine name_generic(eqs)
    type(equilibrium_t), intent(inout) :: eqs(:)
    integer :: i, j, k, cls(size(eqs))
    character, parameter :: LETTER(0:3) = ['W', 'S', 'R', 'D']
    do i = 1, size(eqs)
      cls(i) = 2
      if (eqs(i)%morse == 0 .and. eqs(i)%nzero == 0) cls(i) = 0
      if (eqs(i)%rank1) cls(i) = 1
      if (eqs(i)%degenerate) cls(i) = 3
    end do
    do i = 1, size(eqs)
      k = 1
      do j = 1, size(eqs)
        if (j /= i .and. cls(j) == cls(i) .and. earlier(eqs(j), eqs(i))) k = k + 1
      end do
      write (eqs(i)%name, '(a,i0)') LETTER(cls(i)), k
    end do
  contains
    pure logical function earlier(a, b)
      type(equilibrium_t), intent(in) :: a, b
      real(wp) :: tol
      integer :: d
      tol = 1.0e-9_wp*max(1.0_wp, abs(a%energy), abs(b%energy))
      if (abs(a%energy - b%energy) > tol) then
        earlier = a%energy < b%energy
        return
      end if
      do d = 1, size(a%q)
        if (abs(a%q(d) - b%q(d)) > 1.0e-9_wp*max(1.0_wp, abs(a%q(d)))) then
          earlier = a%q(d) < b%q(d)
          return
        end if
      end do
      earlier = .false.
    end function earlier
  end subroutine name_generic

  !> The CR3BP's L1..L5: collinear points (y = 0) by x: L3 < L1 < L2; L4 at y > 0, L5 at y < 0.
  subroutine name_lagrange(eqs)
    type(equilibrium_t), intent(inout) :: eqs(:)
    integer :: i, j, ncol, col(size(eqs)), rank
    character(2), parameter :: COLLINEAR(3) = ['L3', 'L1', 'L2']
    ncol = 0
    do i = 1, size(eqs)
      eqs(i)%name = ''
      if (abs(eqs(i)%q(2)) <= 1.0e-10_wp) then
        ncol = ncol + 1
        col(ncol) = i
      else if (eqs(i)%q(2) > 0) then
        eqs(i)%name = 'L4'
      else
        eqs(i)%name = 'L5'
      end if
    end do
    if (ncol /= 3) return
    do i = 1, 3
      rank = 1
      do j = 1, 3
        if (eqs(col(j))%q(1) < eqs(col(i))%q(1)) rank = rank + 1
      end do
      eqs(col(i))%name = COLLINEAR(rank)
    end do
  end subroutine name_lagrange

  pure logical function before(a, b)
    type(equilibrium_t), intent(in) :: a, b
    if (a%morse /= b%morse) then
      before = a%morse < b%morse
    else
      before = llt(a%name, b%name)
    end if
  end function before
end module tubes_equilibria
