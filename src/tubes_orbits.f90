!> Lyapunov (brake) periodic orbits around a rank-1 saddle: single shooting on the brake
!> representation, multiple shooting with a Gauss-Newton least-squares corrector (segments in
!> parallel with OpenMP), continuation in energy, monodromy, Floquet multipliers and action.
!> Theory and conventions: docs/orbits.md.
module tubes_orbits
  use tubes_kinds, only: wp
  use tubes_status, only: TUBES_OK, TUBES_EINPUT, TUBES_ENOCONV, TUBES_EFAULT
  use tubes_par, only: par_t, par_here, par_share, par_bcast, par_fault_item
  use tubes_field, only: vector_field_t
  use tubes_ball, only: ball_t
  use tubes_variational, only: variational_t, make_variational, stm_start
  use tubes_dop853, only: dop853_t
  use tubes_integrator, only: propagate
  use tubes_sampler, only: sampler_t
  use tubes_equilibria, only: equilibrium_t
  implicit none
  private

  real(wp), parameter :: PI = acos(-1.0_wp)

  integer, parameter, public :: END_NONE = 0        !! the family did not end in the range
  integer, parameter, public :: END_EQUILIBRIUM = 1 !! the orbit runs into another equilibrium
  integer, parameter, public :: END_PERIOD = 2      !! period grows without bound
  integer, parameter, public :: END_NOCONV = 3      !! correction fails even for tiny steps

  !> Options of the corrector and the continuation.
  type, public :: orbit_opts_t
    integer :: n_segments = 1         !! 1: single shooting (brake orbit); >= 2: multiple shooting
    real(wp) :: tol = 1.0e-11_wp      !! Newton tolerance on the scaled residual [1]
    real(wp) :: rtol = 1.0e-13_wp     !! integration tolerance (relative)
    real(wp) :: atol = 1.0e-13_wp     !! integration tolerance (absolute)
    integer :: max_iter = 25          !! Newton iterations per orbit
    integer :: n_samples = 201        !! samples along one period in the output
    real(wp) :: period_max = 20       !! periods beyond period_max * T_po end the family [1]
    logical :: local = .false.        !! multiple shooting on this MPI rank alone (the caller
                                      !! has dealt out a coarser level); default: all ranks
  end type orbit_opts_t

  !> One periodic orbit.
  type, public :: orbit_t
    real(wp) :: de = 0                !! excess energy E - E_e [(cm/s)^2]
    real(wp) :: energy = 0            !! E [(cm/s)^2]
    real(wp) :: period = 0            !! T [s]
    real(wp) :: x0(4) = 0             !! state at t = 0 (a rest point for single shooting)
    real(wp) :: action = 0            !! integral of p dq over one period [cm^2/s]
    real(wp) :: monodromy(4, 4) = 0   !! state transition matrix over one period
    real(wp) :: mu_unstable = 0       !! largest Floquet multiplier
    real(wp) :: mu_stable = 0         !! smallest Floquet multiplier
    real(wp) :: mu_trivial(2) = 0     !! real parts of the trivial pair (both 1 exactly)
    real(wp) :: mu_trivial_imag(2) = 0 !! imaginary parts of the trivial pair
    real(wp) :: stability_index = 0   !! (mu_unstable + mu_stable) / 2
    real(wp) :: residual = 0          !! corrector residual: max of the periodicity mismatch
                                      !! [cm, cm/s] and |H - E| / E
    real(wp) :: closure = 0           !! max |x(T) - x(0)| [cm, cm/s] of one integration over a
                                      !! period (grows like mu_unstable x integration error)
    real(wp) :: min_eq_distance = 0   !! closest approach to another equilibrium [cm]
    integer :: iterations = 0         !! Newton iterations used
    logical :: converged = .false.
    real(wp), allocatable :: history(:)  !! scaled residual after each iteration
    real(wp), allocatable :: t(:)        !! sample times [s]
    real(wp), allocatable :: x(:, :)     !! samples (4, n_samples)
  end type orbit_t

  !> Integral of p . dq/dt alongside the flow: dimension 5.
  type, extends(vector_field_t) :: action_field_t
    type(ball_t) :: ball
  contains
    procedure :: dim => action_dim
    procedure :: eval => action_eval
  end type action_field_t

  public :: linear_guess, correct_brake, correct_multiple, finish_orbit, orbit_family

  interface
    subroutine dgesv(n, nrhs, a, lda, ipiv, b, ldb, info)
      import :: wp
      integer, intent(in) :: n, nrhs, lda, ldb
      real(wp), intent(inout) :: a(lda, *), b(ldb, *)
      integer, intent(out) :: ipiv(*), info
    end subroutine dgesv
    subroutine dgels(trans, m, n, nrhs, a, lda, b, ldb, work, lwork, info)
      import :: wp
      character, intent(in) :: trans
      integer, intent(in) :: m, n, nrhs, lda, ldb, lwork
      real(wp), intent(inout) :: a(lda, *), b(ldb, *)
      real(wp), intent(out) :: work(*)
      integer, intent(out) :: info
    end subroutine dgels
    subroutine dgeev(jobvl, jobvr, n, a, lda, wr, wi, vl, ldvl, vr, ldvr, work, lwork, info)
      import :: wp
      character, intent(in) :: jobvl, jobvr
      integer, intent(in) :: n, lda, ldvl, ldvr, lwork
      real(wp), intent(inout) :: a(lda, *)
      real(wp), intent(out) :: wr(*), wi(*), vl(ldvl, *), vr(ldvr, *), work(*)
      integer, intent(out) :: info
    end subroutine dgeev
  end interface

contains

  pure integer function action_dim(self)
    class(action_field_t), intent(in) :: self
    action_dim = 5
  end function action_dim

  pure subroutine action_eval(self, t, x, dxdt, stat)
    class(action_field_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:)
    real(wp), intent(out) :: dxdt(:)
    integer, intent(out) :: stat
    call self%ball%eval(t, x(1:4), dxdt(1:4), stat)
    dxdt(5) = x(3)*dxdt(1) + x(4)*dxdt(2)   ! p . dq/dt
  end subroutine action_eval

  !> Linear (small-amplitude) brake orbit at excess energy de: rest point q_s + A e2 with
  !> (1/2) g kappa_2 A^2 = de, e2 the positive-curvature direction pointing away from the
  !> origin, and half period pi / omega.
  subroutine linear_guess(ball, sad, de, q0, tau)
    type(ball_t), intent(in) :: ball
    type(equilibrium_t), intent(in) :: sad
    real(wp), intent(in) :: de
    real(wp), intent(out) :: q0(2), tau
    real(wp) :: gr(2), k(2, 2), e2(2), kap, b, c, disc
    call ball%surf%derivs(sad%q(1), sad%q(2), gr, k)
    b = 0.5_wp*(k(1, 1) + k(2, 2))
    c = k(1, 1)*k(2, 2) - k(1, 2)**2
    disc = sqrt(max(b*b - c, 0.0_wp))
    kap = b + disc                      ! larger Hessian eigenvalue
    if (abs(k(1, 2)) > 0) then
      e2 = [k(1, 2), kap - k(1, 1)]
    else if (k(1, 1) >= k(2, 2)) then
      e2 = [1.0_wp, 0.0_wp]
    else
      e2 = [0.0_wp, 1.0_wp]
    end if
    e2 = e2/sqrt(sum(e2**2))
    if (dot_product(e2, sad%q) < 0) e2 = -e2
    q0 = sad%q + sqrt(2*de/(ball%g*kap))*e2
    tau = PI/sad%omega
  end subroutine linear_guess

  !> Propagate the variational equations from (q, p = 0) for time tau: returns x(tau), Phi.
  subroutine flow_stm(ball, x0, tau, opts, x, phi, stat)
    type(ball_t), intent(in) :: ball
    real(wp), intent(in) :: x0(4), tau
    type(orbit_opts_t), intent(in) :: opts
    real(wp), intent(out) :: x(4), phi(4, 4)
    integer, intent(out) :: stat
    type(variational_t) :: var
    type(dop853_t) :: ig
    real(wp) :: z(20)
    call make_variational(var, ball)
    call ig%init(var, 0.0_wp)
    ig%rtol = opts%rtol
    ig%atol = opts%atol
    z = stm_start(x0)
    call propagate(ig, z, tau, stat)
    x = z(1:4)
    phi = reshape(z(5:20), [4, 4])
  end subroutine flow_stm

  !> Single shooting for a brake orbit: unknowns (q0, tau) with p(0) = 0, conditions
  !> p(tau) = 0 and g H(q0) = E. Newton with the state transition matrix.
  subroutine correct_brake(ball, energy, de, q0, tau, opts, orb, stat)
    type(ball_t), intent(in) :: ball
    real(wp), intent(in) :: energy
    real(wp), intent(in) :: de        !! excess energy: sets the residual's scales
    real(wp), intent(inout) :: q0(2), tau
    type(orbit_opts_t), intent(in) :: opts
    type(orbit_t), intent(inout) :: orb
    integer, intent(out) :: stat
    real(wp) :: x(4), phi(4, 4), f(4), jac(3, 3), r(3), gr(2), hs(2, 2), pscale, res, du(3)
    integer :: it, ipiv(3), info
    pscale = 1                          ! residual in cm/s (momenta) and relative to E (energy)
    if (allocated(orb%history)) deallocate (orb%history)
    allocate (orb%history(0))
    orb%converged = .false.
    do it = 1, opts%max_iter
      if (diverging(orb%history)) exit
      call flow_stm(ball, [q0, 0.0_wp, 0.0_wp], tau, opts, x, phi, stat)
      if (stat < 0) return
      call ball%eval(0.0_wp, x, f, stat)
      call ball%surf%derivs(q0(1), q0(2), gr, hs)
      r = [x(3), x(4), ball%potential(q0(1), q0(2)) - energy]
      res = max(abs(r(1))/pscale, abs(r(2))/pscale, abs(r(3))/abs(energy))
      orb%history = [orb%history, res]
      orb%iterations = it
      if (res <= opts%tol) then
        orb%converged = .true.
        exit
      end if
      jac = 0
      jac(1:2, 1:2) = phi(3:4, 1:2)
      jac(1:2, 3) = f(3:4)
      jac(3, 1:2) = ball%g*gr
      du = -r
      call dgesv(3, 1, jac, 3, ipiv, du, 3, info)
      if (info /= 0) then
        stat = TUBES_ENOCONV
        return
      end if
      ! damp steps that leave the neighbourhood (0.5 cm, 20 % of tau)
      du = du*min(1.0_wp, 0.5_wp/max(1.0e-300_wp, sqrt(sum(du(1:2)**2))), &
                  0.2_wp*tau/max(1.0e-300_wp, abs(du(3))))
      q0 = q0 + du(1:2)
      tau = tau + du(3)
      if (tau <= 0) then
        stat = TUBES_ENOCONV
        return
      end if
    end do
    if (.not. orb%converged) orb%converged = stagnated(orb%history, opts%tol)
    stat = merge(TUBES_OK, TUBES_ENOCONV, orb%converged)
    orb%x0 = [q0, 0.0_wp, 0.0_wp]
    orb%period = 2*tau
    orb%energy = energy
  end subroutine correct_brake

  !> Multiple shooting with n = opts%n_segments nodes x_i (4 n unknowns) and the period T:
  !> x_{i+1} = phi_{T/n}(x_i) (cyclic), H(x_1) = E, and the phase condition
  !> (x_1 - x_ref) . f(x_ref) = 0. The 4n + 2 equations (one redundant by energy
  !> conservation) are solved by Gauss-Newton least squares (LAPACK dgels) on row-equilibrated
  !> equations. The segments are propagated in parallel (OpenMP), each with its own integrator.
  subroutine correct_multiple(ball, energy, de, nodes, period, opts, orb, stat)
    type(ball_t), intent(in) :: ball
    real(wp), intent(in) :: energy
    real(wp), intent(in) :: de        !! excess energy: sets the residual's scales
    real(wp), intent(inout) :: nodes(:, :)   !! (4, n)
    real(wp), intent(inout) :: period
    type(orbit_opts_t), intent(in) :: opts
    type(orbit_opts_t) :: o
    type(orbit_t), intent(inout) :: orb
    integer, intent(out) :: stat
    integer :: n, m, nu, i, j, it, info, lwork, st(size(nodes, 2)), kf
    type(par_t) :: pp
    real(wp), allocatable :: a(:, :), b(:), work(:), y(:, :), phis(:, :, :), fy(:, :)
    real(wp) :: xref(4), fref(4), gr(2), hs(2, 2), res, rowmax, pscale, scale(4), xref_grad(4)
    n = size(nodes, 2)
    m = 4*n + 2
    nu = 4*n + 1
    o = opts
    lwork = 64*m
    allocate (a(m, nu), b(m), work(lwork), y(4, n), phis(4, 4, n), fy(4, n))
    pp = par_here(opts%local)
    kf = par_fault_item('segment')
    xref = nodes(:, 1)
    call ball%eval(0.0_wp, xref, fref, stat)
    pscale = 1
    scale = 1                          ! residual in cm and cm/s
    if (allocated(orb%history)) deallocate (orb%history)
    allocate (orb%history(0))
    orb%converged = .false.
    stat = TUBES_OK
    do it = 1, opts%max_iter
      if (diverging(orb%history)) exit
      ! segments dealt out over MPI ranks (tubes_par) and threads, from rank 0's nodes
      call par_bcast(nodes, pp)
      call par_bcast(period, pp)
      y = 0
      phis = 0
      fy = 0
      st = TUBES_OK
      !$omp parallel do schedule(static) default(shared) private(i)
      do i = 1, n
        if (.not. pp%mine(i)) cycle
        if (i == kf) then
          st(i) = TUBES_EFAULT
          cycle
        end if
        call flow_stm(ball, nodes(:, i), period/n, o, y(:, i), phis(:, :, i), st(i))
        if (st(i) >= 0) call ball%eval(0.0_wp, y(:, i), fy(:, i), st(i))
      end do
      !$omp end parallel do
      call par_share(y, pp)
      call par_share(phis, pp)
      call par_share(fy, pp)
      call par_share(st, pp)
      if (any(st < 0)) then
        stat = minval(st)
        return
      end if
      a = 0
      do i = 1, n
        j = mod(i, n) + 1
        b(4*i - 3:4*i) = nodes(:, j) - y(:, i)
        a(4*i - 3:4*i, 4*i - 3:4*i) = -phis(:, :, i)
        a(4*i - 3:4*i, 4*j - 3:4*j) = a(4*i - 3:4*i, 4*j - 3:4*j) + identity4()
        a(4*i - 3:4*i, nu) = -fy(:, i)/n
      end do
      call ball%surf%derivs(nodes(1, 1), nodes(2, 1), gr, hs)
      b(m - 1) = ball%energy(nodes(:, 1)) - energy
      call energy_gradient(ball, nodes(:, 1), xref_grad)
      a(m - 1, 1:4) = xref_grad
      b(m) = dot_product(nodes(:, 1) - xref, fref)
      a(m, 1:4) = fref
      res = 0
      do i = 1, n
        res = max(res, maxval(abs(b(4*i - 3:4*i))/scale))
      end do
      res = max(res, abs(b(m - 1))/abs(energy))
      orb%history = [orb%history, res]
      orb%iterations = it
      if (res <= opts%tol) then
        orb%converged = .true.
        exit
      end if
      do i = 1, m            ! equilibrate rows (the root is unchanged: the system is consistent)
        rowmax = maxval(abs(a(i, :)))
        if (rowmax > 0) then
          a(i, :) = a(i, :)/rowmax
          b(i) = b(i)/rowmax
        end if
      end do
      b = -b
      call dgels('N', m, nu, 1, a, m, b, m, work, lwork, info)
      if (info /= 0) then
        stat = TUBES_ENOCONV
        return
      end if
      do i = 1, n
        nodes(:, i) = nodes(:, i) + b(4*i - 3:4*i)
      end do
      period = period + b(nu)
      if (period <= 0) then
        stat = TUBES_ENOCONV
        return
      end if
    end do
    if (.not. orb%converged) orb%converged = stagnated(orb%history, opts%tol)
    stat = merge(TUBES_OK, TUBES_ENOCONV, orb%converged)
    orb%x0 = nodes(:, 1)
    orb%period = period
    orb%energy = energy
  end subroutine correct_multiple

  !> A Newton sequence is hopeless when it has not reduced its residual for 4 iterations.
  pure logical function diverging(h)
    real(wp), intent(in) :: h(:)
    integer :: n
    n = size(h)
    diverging = .false.
    if (n >= 5) diverging = minval(h(n - 3:n)) >= h(n - 4)
  end function diverging

  !> Newton stopped at the integration's noise floor: the last residual is within 100 tol.
  pure logical function stagnated(h, tol)
    real(wp), intent(in) :: h(:), tol
    stagnated = .false.
    if (size(h) > 0) stagnated = h(size(h)) <= 100*tol
  end function stagnated

  pure function identity4() result(e)
    real(wp) :: e(4, 4)
    integer :: i
    e = 0
    do i = 1, 4
      e(i, i) = 1
    end do
  end function identity4

  !> Gradient of the energy by the vector field: dE/dq = -dp/dt, dE/dp = dq/dt.
  subroutine energy_gradient(ball, x, g)
    type(ball_t), intent(in) :: ball
    real(wp), intent(in) :: x(4)
    real(wp), intent(out) :: g(4)
    real(wp) :: f(4)
    integer :: stat
    call ball%eval(0.0_wp, x, f, stat)
    g = [-f(3), -f(4), f(1), f(2)]
  end subroutine energy_gradient

  !> Monodromy, Floquet multipliers, action, samples and the periodicity residual of a
  !> corrected orbit; distance of closest approach to the other equilibria eqs.
  subroutine finish_orbit(ball, orb, opts, eqs, isad, stat)
    type(ball_t), intent(in) :: ball
    type(orbit_t), intent(inout) :: orb
    type(orbit_opts_t), intent(in) :: opts
    type(equilibrium_t), intent(in) :: eqs(:)
    integer, intent(in) :: isad
    integer, intent(out) :: stat
    type(action_field_t) :: af
    type(dop853_t) :: ig
    type(sampler_t) :: obs
    real(wp) :: x(4), phi(4, 4), z(5), wr(4), wi(4), vl(1, 1), vr(1, 1), work(64), mono(4, 4), d
    integer :: info, k, iu, is, j, itr(2)
    call flow_stm(ball, orb%x0, orb%period, opts, x, phi, stat)
    if (stat < 0) return
    orb%monodromy = phi
    orb%closure = maxval(abs(x - orb%x0))
    orb%residual = orb%history(size(orb%history))
    mono = phi
    call dgeev('N', 'N', 4, mono, 4, wr, wi, vl, 1, vr, 1, work, 64, info)
    if (info /= 0) then
      stat = TUBES_ENOCONV
      return
    end if
    iu = maxloc(wr, 1)
    is = minloc(wr, 1)
    orb%mu_unstable = wr(iu)
    orb%mu_stable = wr(is)
    j = 0
    do k = 1, 4
      if (k /= iu .and. k /= is .and. j < 2) then
        j = j + 1
        itr(j) = k
      end if
    end do
    orb%mu_trivial = wr(itr)
    orb%mu_trivial_imag = wi(itr)
    orb%stability_index = 0.5_wp*(orb%mu_unstable + orb%mu_stable)
    ! action and samples in one pass
    af%ball = ball
    call ig%init(af, 0.0_wp)
    ig%rtol = opts%rtol
    ig%atol = opts%atol
    z = [orb%x0, 0.0_wp]
    call obs%start(0.0_wp, orb%period/(opts%n_samples - 1), z, opts%n_samples)
    call propagate(ig, z, orb%period, stat, observer=obs)
    if (stat < 0) return
    orb%action = z(5)
    if (allocated(orb%t)) deallocate (orb%t, orb%x)
    allocate (orb%t(opts%n_samples), orb%x(4, opts%n_samples))
    orb%t = obs%t(1:opts%n_samples)
    orb%x = obs%x(1:4, 1:opts%n_samples)
    orb%t(opts%n_samples) = orb%period
    orb%x(:, opts%n_samples) = z(1:4)
    orb%min_eq_distance = huge(1.0_wp)
    do k = 1, size(eqs)
      if (k == isad) cycle
      do j = 1, opts%n_samples
        d = sqrt(sum((orb%x(1:2, j) - eqs(k)%q)**2))
        orb%min_eq_distance = min(orb%min_eq_distance, d)
      end do
    end do
    stat = TUBES_OK
  end subroutine finish_orbit

  !> Nodes for multiple shooting: n points a period apart/n along the trajectory from x0.
  subroutine nodes_from(ball, x0, period, n, opts, nodes, stat)
    type(ball_t), intent(in) :: ball
    real(wp), intent(in) :: x0(4), period
    integer, intent(in) :: n
    type(orbit_opts_t), intent(in) :: opts
    real(wp), intent(out) :: nodes(4, n)
    integer, intent(out) :: stat
    type(dop853_t) :: ig
    real(wp) :: x(4)
    integer :: i
    x = x0
    nodes(:, 1) = x0
    call ig%init(ball, 0.0_wp)
    ig%rtol = opts%rtol
    ig%atol = opts%atol
    stat = TUBES_OK
    do i = 2, n
      call propagate(ig, x, (i - 1)*period/n, stat)
      if (stat < 0) return
      nodes(:, i) = x
    end do
  end subroutine nodes_from

  !> Solve one orbit at excess energy de from the brake guess (q0, tau) with the method of
  !> opts (single or multiple shooting).
  subroutine solve_orbit(ball, sad, de, q0, tau, opts, eqs, isad, orb, stat)
    type(ball_t), intent(in) :: ball
    type(equilibrium_t), intent(in) :: sad
    real(wp), intent(in) :: de
    real(wp), intent(inout) :: q0(2), tau
    type(orbit_opts_t), intent(in) :: opts
    type(equilibrium_t), intent(in) :: eqs(:)
    integer, intent(in) :: isad
    type(orbit_t), intent(out) :: orb
    integer, intent(out) :: stat
    real(wp), allocatable :: nodes(:, :)
    real(wp) :: period
    orb%de = de
    if (opts%n_segments <= 1) then
      call correct_brake(ball, sad%energy + de, de, q0, tau, opts, orb, stat)
    else
      allocate (nodes(4, opts%n_segments))
      call nodes_from(ball, [q0, 0.0_wp, 0.0_wp], 2*tau, opts%n_segments, opts, nodes, stat)
      if (stat < 0) return
      period = 2*tau
      call correct_multiple(ball, sad%energy + de, de, nodes, period, opts, orb, stat)
      if (stat == TUBES_OK) then
        q0 = nodes(1:2, 1)
        tau = period/2
      end if
    end if
    orb%de = de
    if (stat == TUBES_OK) call finish_orbit(ball, orb, opts, eqs, isad, stat)
  end subroutine solve_orbit

  !> The family of Lyapunov orbits of saddle eqs(isad) at the requested excess energies
  !> des (ascending), by continuation from de -> 0 with an adaptive step in sqrt(de) and a
  !> secant predictor. When the family ends (period > period_max T_po, approach to another
  !> equilibrium, or failure of the corrector for steps below 1e-6 of de) the continuation
  !> stops: end_de estimates the limit, end_reason says why, and orbits past it are not
  !> computed (converged = .false.). stat < 0 only for invalid input.
  subroutine orbit_family(ball, eqs, isad, des, opts, orbits, end_de, end_reason, stat)
    type(ball_t), intent(in) :: ball
    type(equilibrium_t), intent(in) :: eqs(:)
    integer, intent(in) :: isad
    real(wp), intent(in) :: des(:)
    type(orbit_opts_t), intent(in) :: opts
    type(orbit_t), intent(out) :: orbits(size(des))
    real(wp), intent(out) :: end_de
    integer, intent(out) :: end_reason
    integer, intent(out) :: stat
    type(orbit_t) :: orb
    real(wp) :: s, s_prev, s_last, ds, q0(2), tau, qa(2), ta, qb(2), tb, s_target, t_po
    real(wp) :: hist_s(3), hist_t(3), t_pred
    integer :: k, st, nhist
    logical :: have_prev
    stat = TUBES_OK
    end_de = -1
    end_reason = END_NONE
    if (size(des) == 0) return
    if (any(des <= 0)) then
      stat = TUBES_EINPUT
      return
    end if
    do k = 2, size(des)
      if (des(k) <= des(k - 1)) then
        stat = TUBES_EINPUT
        return
      end if
    end do
    t_po = 2*PI/eqs(isad)%omega
    ! continuation in s = sqrt(de): the brake point moves linearly in s near s = 0
    s_last = 0
    s = min(sqrt(des(1)), 0.5_wp)
    call linear_guess(ball, eqs(isad), s*s, q0, tau)
    have_prev = .false.
    qa = q0; ta = tau; qb = q0; tb = tau; s_prev = 0
    ds = s
    k = 1
    nhist = 0
    do while (k <= size(des))
      s_target = sqrt(des(k))
      if (s > s_target) s = s_target
      ! predictor
      if (have_prev) then
        q0 = qb + (qb - qa)*(s - s_last)/(s_last - s_prev)
        tau = tb + (tb - ta)*(s - s_last)/(s_last - s_prev)
      else if (s_last > 0) then
        q0 = qb + (qb - eqs(isad)%q)*(s - s_last)/s_last
        tau = tb
      else
        call linear_guess(ball, eqs(isad), s*s, q0, tau)
      end if
      t_pred = 2*tau
      call solve_orbit(ball, eqs(isad), s*s, q0, tau, opts, eqs, isad, orb, st)
      if (st == TUBES_OK .and. orb%period > opts%period_max*t_po) then
        end_reason = END_PERIOD
        st = TUBES_ENOCONV
      end if
      ! the corrector may converge to another family past the end: accept only an orbit close
      ! to the prediction (period within 10 % of the predicted change + 1 % of T)
      if (st == TUBES_OK .and. have_prev) then
        if (abs(orb%period - t_pred) > 0.1_wp*abs(t_pred - tb*2) + 0.01_wp*tb*2) st = TUBES_ENOCONV
      end if
      if (st /= TUBES_OK) then
        ds = ds/4
        s = s_last + ds
        if (ds < 1.0e-6_wp*max(s_last, 1.0e-3_wp)) then
          if (end_reason == END_NONE) end_reason = END_NOCONV
          exit
        end if
        cycle
      end if
      ! accepted
      nhist = min(nhist + 1, 3)
      hist_s = [hist_s(2:3), s]
      hist_t = [hist_t(2:3), orb%period]
      if (s_last > 0) have_prev = .true.
      s_prev = s_last; qa = qb; ta = tb
      s_last = s; qb = q0; tb = tau
      if (abs(s - s_target) <= 1.0e-14_wp*s_target) then
        orbits(k) = orb
        orbits(k)%de = des(k)
        k = k + 1
      end if
      if (orb%iterations <= 4) then
        ds = min(2*ds, 0.25_wp*s + 0.1_wp)
      else if (orb%iterations > 8) then
        ds = ds/2
      end if
      s = s_last + ds
    end do
    if (k <= size(des)) then
      ! the family ended before des(k): estimate the limit from the last periods
      if (orb%min_eq_distance < 0.05_wp .and. end_reason /= END_PERIOD) end_reason = END_EQUILIBRIUM
      if (end_reason == END_NOCONV .and. nhist == 3) end_reason = END_PERIOD
      end_de = limit_estimate(hist_s, hist_t, nhist, s_last)
      do while (k <= size(des))
        orbits(k)%de = des(k)
        orbits(k)%converged = .false.
        k = k + 1
      end do
    end if
  end subroutine orbit_family

  !> Limiting de of a family whose period grows like T = a - b ln(L - de): solve the three
  !> equations of the last three accepted points for L (bisection); falls back to the last de.
  pure real(wp) function limit_estimate(hs, ht, n, s_last) result(l)
    real(wp), intent(in) :: hs(3), ht(3), s_last
    integer, intent(in) :: n
    real(wp) :: d(3), lo, hi, mid, flo, fmid
    integer :: it
    l = s_last**2
    if (n < 3) return
    d = hs**2
    if (.not. (ht(3) > ht(2) .and. ht(2) > ht(1))) return
    lo = d(3)*(1 + 1.0e-12_wp)
    hi = d(3) + 100*(d(3) - d(1)) + 1
    flo = g(lo)
    if (flo*g(hi) > 0) return
    do it = 1, 200
      mid = 0.5_wp*(lo + hi)
      fmid = g(mid)
      if (fmid*flo > 0) then
        lo = mid
        flo = fmid
      else
        hi = mid
      end if
    end do
    l = 0.5_wp*(lo + hi)
  contains
    pure real(wp) function g(x)
      real(wp), intent(in) :: x
      ! (T3 - T2)/(T2 - T1) = ln((x - d2)/(x - d3)) / ln((x - d1)/(x - d2))
      g = (ht(3) - ht(2))*log((x - d(1))/(x - d(2))) - (ht(2) - ht(1))*log((x - d(2))/(x - d(3)))
    end function g
  end function limit_estimate
end module tubes_orbits
