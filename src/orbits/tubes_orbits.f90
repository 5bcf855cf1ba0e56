!> Lyapunov (brake) periodic orbits around a rank-1 saddle: single shooting on the brake
!> representation, multiple shooting with a Gauss-Newton least-squares corrector (segments in
!> parallel with OpenMP), continuation in energy, monodromy, Floquet multipliers and action.
!> Theory and conventions: docs/orbits.md.
module tubes_orbits
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite, ieee_value, ieee_positive_inf
  use tubes_kinds, only: wp, PI
  use tubes_lapack, only: dgesv, dgels, eigen, dsyev
  use tubes_status, only: TUBES_OK, TUBES_EINPUT, TUBES_ENOCONV, TUBES_EFAULT
  use tubes_ensemble, only: ensemble_t, ens_out_t, ens_run, ens_agree, ens_reuse_ok
  use tubes_field, only: vector_field_t, jet_spec_t
  use tubes_hamiltonian, only: hamiltonian_t, natural_t
  use tubes_variational, only: variational_t, make_variational, stm_start
  use tubes_methods, only: integ_choice_t, make_integrator
  use tubes_integrator, only: integrator_t
  use tubes_integrator, only: propagate
  use tubes_sampler, only: sampler_t
  use tubes_equilibria, only: equilibrium_t, rest_jacobian
  implicit none
  private


  integer, parameter, public :: END_NONE = 0        !! the family did not end in the range
  integer, parameter, public :: END_EQUILIBRIUM = 1 !! the orbit runs into another equilibrium
  integer, parameter, public :: END_PERIOD = 2      !! period grows without bound
  integer, parameter, public :: END_NOCONV = 3      !! correction fails even for tiny steps
  integer, parameter, public :: END_FOLD = 4        !! the branch's energy turns back (a fold)
  integer, parameter, public :: END_NOBRANCH = 5    !! no branch point below the largest dE
  integer, parameter, public :: END_STEPS = 6       !! an arc (guess_family, branch_arc) took ARC_MAX_STEPS
  integer, parameter, public :: END_RETURN = 7      !! past a fold, the arc's energy returned to its start's
  integer, parameter, public :: END_NOGUESS = 8     !! the guess (opts%guess) did not converge
  integer, parameter, public :: END_NOTBRANCH = 9   !! no requested energy on the branch's side
  integer, parameter, public :: END_LOOP = 10       !! a branch's arc closed: a fold at its start's energy
  integer, parameter, public :: END_NOMODE = 11     !! a family by name ('vertical', 'lyapunov', 'axial')
                                                    !! the saddle's centre modes do not define
  integer, parameter, public :: ARC_MAX_STEPS = 2000 !! steps of one pseudo-arclength arc, at most
  !> opts%family codes of the family that branches off the highest-frequency centre mode's
  !> family (N - 1) at its first branch point (the spatial CR3BP's halo family off the planar
  !> Lyapunov family): PLUS the side whose orbits' larger excursion in q_N is positive
  !> ('halo_north'), MINUS negative ('halo_south'). docs/orbits.md, "Branch switching".
  integer, parameter, public :: FAMILY_BRANCH_PLUS = -1, FAMILY_BRANCH_MINUS = -2
  !> opts%family codes of the families by name (docs/orbits.md, "Branch switching"): 'vertical' the
  !> centre mode whose eigenvector lies in (q_N, p_N) (3 DOF), 'lyapunov' the planar one (3 DOF; else
  !> family 1), 'axial' the family off the planar one at its first branch point whose tangent is odd
  !> under the reversor (the spatial CR3BP's axial family, which ends on the vertical family)
  integer, parameter, public :: FAMILY_VERTICAL = -3, FAMILY_PLANAR = -4, FAMILY_AXIAL = -5

  !> Options of the corrector and the continuation.
  type, public :: orbit_opts_t
    integer :: n_segments = 1         !! 1: single shooting of a symmetric orbit (the brake orbit
                                      !! of natural systems); >= 2: multiple shooting
    real(wp) :: tol = 1.0e-11_wp      !! Newton tolerance on the scaled residual [1]
    real(wp) :: rtol = 1.0e-13_wp     !! integration tolerance (relative)
    real(wp) :: atol = 1.0e-13_wp     !! integration tolerance (absolute)
    integer :: max_iter = 25          !! Newton iterations per orbit
    integer :: n_samples = 201        !! samples along one period in the output
    integer :: family = 1             !! the family of the saddle's family-th centre mode (1..N-1)
    real(wp) :: period_max = 20       !! periods beyond period_max * T_po end the family [1]
    type(integ_choice_t) :: integ     !! the integrator (default DOP853)
    logical :: local = .false.        !! multiple shooting on this MPI rank alone (the caller
                                      !! has dealt out a coarser level); default: all ranks
    !> a family from a guess (guess_family) when allocated: the start state (2N) and its period
    !> guess_period [time]; corrected by multiple shooting (n_segments segments) at H(guess)
    real(wp), allocatable :: guess(:)
    real(wp) :: guess_period = 0
    integer :: branch = 0             !! K > 0: the family branching off the parent family (this
                                      !! one with branch = 0) at its K-th bifurcation (tubes_study)
  end type orbit_opts_t

  !> A fold of an arc: the energy along the family turns back (dE/ds = 0 in arclength s).
  type, public :: fold_t
    real(wp) :: de = 0                !! excess energy at the fold [energy]
    real(wp) :: period = 0            !! period there [time]
    real(wp) :: width = 0             !! the final bracket in arclength (units of the unknowns)
    real(wp), allocatable :: x0(:)    !! the orbit's start there (2N)
    real(wp), allocatable :: tangent(:) !! the family's tangent's state part at x0 (unit)
    real(wp), allocatable :: monodromy(:, :) !! its monodromy (2N, 2N)
  end type fold_t

  !> The equations of a pseudo-arclength arc in unknowns w (arc_step): rows(w, wref) gives the
  !> residual f(w) (m rows) and its Jacobian (m x size(w)) whose null space is the family's
  !> tangent; wref is the last accepted point (for a phase condition).
  type, abstract :: arc_system_t
    integer :: n_raw = 0   !! the first n_raw rows are not equilibrated (one segment's I - M)
  contains
    procedure(arc_rows_i), deferred :: rows
  end type arc_system_t

  abstract interface
    subroutine arc_rows_i(self, w, wref, f, jac, stat)
      import :: arc_system_t, wp
      class(arc_system_t), intent(in) :: self
      real(wp), intent(in) :: w(:), wref(:)
      real(wp), allocatable, intent(out) :: f(:), jac(:, :)
      integer, intent(out) :: stat
    end subroutine arc_rows_i
  end interface

  !> The symmetric orbit with the energy free (branch_family): w = (x0's components on the
  !> reversor's fixed set ev, the half period tau); rows: x(tau)'s odd components od (nd rows), the
  !> Jacobian (nd x (nd + 1)) phi(od, ev) and f(x(tau))(od).
  type, extends(arc_system_t) :: symmetric_arc_t
    class(hamiltonian_t), allocatable :: model
    type(orbit_opts_t) :: opts
    integer, allocatable :: ev(:), od(:)
  contains
    procedure :: rows => symmetric_rows
  end type symmetric_arc_t

  !> Multiple shooting with the energy free: w = (the n nodes (2N each), the period T); rows:
  !> x_{i+1} - phi_{T/n}(x_i) (cyclic, 2N n), and the phase (x_1 - x_ref) . f(x_ref) / |f(x_ref)|
  !> (x_ref wref's first node). One periodicity row is redundant (energy conservation): the
  !> (2N n + 1) x (2N n + 1) Jacobian has rank 2N n at a regular orbit, its null vector the
  !> family's tangent.
  type, extends(arc_system_t) :: shooting_arc_t
    class(hamiltonian_t), allocatable :: model
    type(orbit_opts_t) :: opts
    integer :: n = 1
  contains
    procedure :: rows => shooting_rows
  end type shooting_arc_t

  !> Multiple shooting's segments: item i flows node i over tau = T/n, into its end state, its
  !> state transition matrix and the field there.
  type, extends(ensemble_t) :: segment_ens_t
    class(hamiltonian_t), allocatable :: model
    real(wp), allocatable :: nodes(:, :)       !! (2N, n)
    real(wp) :: tau = 0
    type(orbit_opts_t) :: opts
  contains
    procedure :: item => segment_item
  end type segment_ens_t

  !> One periodic orbit.
  type, public :: orbit_t
    real(wp) :: de = 0                !! excess energy E - E_e [energy]
    real(wp) :: energy = 0            !! E [energy]
    real(wp) :: period = 0            !! T [time]
    real(wp), allocatable :: x0(:)    !! state at t = 0 (on the reversor's fixed set for single
                                      !! shooting: a rest point for natural systems) (2N)
    real(wp) :: action = 0            !! integral of p dq over one period [energy x time]
    real(wp), allocatable :: monodromy(:, :)  !! state transition matrix over one period (2N, 2N)
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
    logical :: off_branch = .false.   !! a branch's orbit that the corrector at its energy, started on
                                      !! the branch's arc, took off the branch (to the parent family or
                                      !! the mirror branch): not returned (converged false)
    real(wp), allocatable :: history(:)  !! scaled residual after each iteration
    real(wp), allocatable :: t(:)        !! sample times [s]
    real(wp), allocatable :: x(:, :)     !! samples (2N, n_samples)
  end type orbit_t

  real(wp), parameter :: S_START = 0.5_wp    ! the continuation's first step in sqrt(de), at most
  real(wp), parameter :: START_AMP = 0.02_wp  ! ... and at most where the linear orbit's amplitude is
                                              ! this fraction of the distance to the next equilibrium

  !> The continuation's state before an attempt (orbit_family): the next step's s = sqrt(de),
  !> the step, the last two accepted points and the last three periods.
  type :: cont_state_t
    real(wp) :: s = 0, ds = 0, s_last = 0, s_prev = 0, ta = 0, tb = 0
    real(wp), allocatable :: xa(:), xb(:)   !! the orbits' start points at s_prev and s_last
    !> multiple shooting: the orbits' nodes at s_prev and s_last (the predictor's secant on them)
    real(wp), allocatable :: na(:, :), nb(:, :)
    real(wp) :: hist_s(3) = 0, hist_t(3) = 0
    integer :: nhist = 0
    integer :: end_reason = END_NONE
    real(wp) :: last_min_eq = 0   !! the last attempt's closest approach to another equilibrium
    logical :: have_prev = .false.
    logical :: ended = .false.    !! the corrector failed for steps below 1e-6 of s: no next attempt
  end type cont_state_t

  !> One family as a run continues it (orbit_family): the states before each step of the
  !> continuation towards no target (the ladder), and the orbits found at the energies asked
  !> for. Kept by the caller between calls of one model, saddle and options.
  type, public :: family_path_t
    real(wp) :: s_start = 0                        !! the first step (start_step), 0 until known
    type(cont_state_t), allocatable :: ladder(:)   !! ladder(j): the state before step j
    real(wp), allocatable :: des(:)                !! the energies of orbs
    type(orbit_t), allocatable :: orbs(:)          !! the orbit at des(i) (converged or not)
    real(wp), allocatable :: end_de(:)             !! where the family ends, for an orbit past it
    integer, allocatable :: end_reason(:)
    !> a branch family (branch_family): its branch point on the parent family, once found: the
    !> fixed-set unknowns and half-period there (w) and the branch's tangent (t)
    real(wp), allocatable :: branch_w(:), branch_t(:)
  end type family_path_t

  !> Integral of p . dq/dt alongside the flow: dimension 2N + 1.
  type, extends(vector_field_t) :: action_field_t
    class(hamiltonian_t), allocatable :: model
  contains
    procedure :: dim => action_dim
    procedure :: eval => action_eval
    procedure :: jet_spec => action_jet_spec
  end type action_field_t

  public :: linear_guess, correct_symmetric, correct_multiple, finish_orbit, orbit_family, floquet_indices, &
            floquet_tangent, branch_arc, named_mode, tilt_of, branch_ladder


contains

  pure integer function action_dim(self)
    class(action_field_t), intent(in) :: self
    action_dim = self%model%dim() + 1
  end function action_dim

  !> The model's formula, with the action integral.
  pure function action_jet_spec(self) result(spec)
    class(action_field_t), intent(in) :: self
    type(jet_spec_t) :: spec
    spec = self%model%jet_spec()
    spec%action = .true.
  end function action_jet_spec

  pure subroutine action_eval(self, t, x, dxdt, stat)
    class(action_field_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:)
    real(wp), intent(out) :: dxdt(:)
    integer, intent(out) :: stat
    integer :: n, k
    real(wp) :: acc
    n = self%model%ndof()
    call self%model%eval(t, x(1:2*n), dxdt(1:2*n), stat)
    acc = x(n + 1)*dxdt(1)                   ! p . dq/dt
    do k = 2, n
      acc = acc + x(n + k)*dxdt(k)
    end do
    dxdt(2*n + 1) = acc
  end subroutine action_eval

  !> Linear (small-amplitude) orbit of the saddle's centre mode at excess energy de, started on
  !> the fixed set of the model's reversor (a rest point for natural systems): x0 and the half
  !> period tau = pi / omega. Natural 2-DOF systems whose kinetic matrix is isotropic at the
  !> saddle: the rest point q_s + A e2 with (1/2) V_22 A^2 = de, e2 the positive-curvature
  !> direction of V pointing away from the origin. Otherwise: the centre eigenvector, phased
  !> onto the fixed set, scaled so that its quadratic energy is de.
  subroutine linear_guess(model, sad, de, x0, tau)
    class(hamiltonian_t), intent(in) :: model
    type(equilibrium_t), intent(in) :: sad
    real(wp), intent(in) :: de
    real(wp), intent(out) :: x0(:), tau
    real(wp) :: gr(2), k(2, 2), e2(2), kap, b, c, disc, a(2, 2)
    real(wp) :: hs(size(x0), size(x0)), v(size(x0)), re(size(x0)), im(size(x0)), aa, bb, ab, phi
    integer :: n, rev(size(x0)), st
    n = size(x0)/2
    tau = PI/sad%omega
    select type (model)
    class is (natural_t)
      if (n == 2) then
        call model%rest_kinetic_matrix(sad%q, a)
        if (a(1, 2) == 0 .and. a(2, 1) == 0 .and. a(1, 1) == a(2, 2)) then
          call model%shape_derivs(sad%q, gr, k)
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
          x0 = 0
          x0(1:2) = sad%q + sqrt(2*de/(model%potential_scale()*kap))*e2
          return
        end if
      end if
    end select
    ! general: v = cos(phi) Re c - sin(phi) Im c with the reversor's odd components minimal
    re = sad%evec(:, 3)
    im = sad%evec(:, 4)
    rev = model%reversor()
    aa = sum(re**2, mask=rev < 0)
    bb = sum(im**2, mask=rev < 0)
    ab = sum(re*im, mask=rev < 0)
    phi = 0
    if (any(rev < 0)) phi = 0.5_wp*atan2(2*ab, -(aa - bb))
    v = cos(phi)*re - sin(phi)*im
    where (rev < 0) v = 0
    call model%hessian(sad%x, hs, st)
    b = 0.5_wp*dot_product(v, matmul(hs, v))
    if (st /= 0 .or. .not. b > 0) b = 1
    if (dot_product(v(1:n), sad%q) < 0) v = -v
    x0 = sad%x + sqrt(de/b)*v
  end subroutine linear_guess

  !> Propagate the variational equations from x0 for time tau: returns x(tau), Phi.
  subroutine flow_stm(model, x0, tau, opts, x, phi, stat)
    class(hamiltonian_t), intent(in) :: model
    real(wp), intent(in) :: x0(:), tau
    type(orbit_opts_t), intent(in) :: opts
    real(wp), intent(out) :: x(:), phi(:, :)
    integer, intent(out) :: stat
    type(variational_t) :: var
    class(integrator_t), allocatable :: ig
    real(wp) :: z(size(x0) + size(x0)**2)
    integer :: n2
    n2 = size(x0)
    x = 0
    phi = 0
    call make_variational(var, model)
    call make_integrator(opts%integ, ig, stat, extended=.true., f=var, rtol=opts%rtol, atol=opts%atol)
    if (stat /= TUBES_OK) return
    z = stm_start(x0)
    call propagate(ig, z, tau, stat)
    x = z(1:n2)
    phi = reshape(z(n2 + 1:), [n2, n2])
  end subroutine flow_stm

  subroutine segment_item(self, k, out)
    class(segment_ens_t), intent(in) :: self
    integer, intent(in) :: k
    type(ens_out_t), intent(inout) :: out
    real(wp) :: y(size(self%nodes, 1)), phi(size(self%nodes, 1), size(self%nodes, 1)), fy(size(self%nodes, 1))
    integer :: d
    d = size(y)
    fy = 0
    call flow_stm(self%model, self%nodes(:, k), self%tau, self%opts, y, phi, out%st(k))
    if (out%st(k) >= 0) call self%model%eval(0.0_wp, y, fy, out%st(k))
    out%r(:, k) = [y, reshape(phi, [d*d]), fy]
  end subroutine segment_item

  !> The scale of the energy residual H(x0) - E of a Newton step: |E|, but at least dE (E may be 0)
  !> and at most 1e4 dE: an additive constant in H (the ball's h0, De Leon-Berne's eps_s) must not
  !> loosen it (relative to |E| = 1e10, tol 1e-11 let dE = 1 drift by 0.1, and the action by 0.3 %).
  pure real(wp) function energy_scale(energy, de) result(s)
    real(wp), intent(in) :: energy, de
    s = max(min(max(abs(energy), abs(de)), 1.0e4_wp*abs(de)), tiny(1.0_wp))
  end function energy_scale

  !> Single shooting of an orbit symmetric under the model's reversor R (for natural systems
  !> R: p -> -p, the brake orbit): unknowns the even components of x0 (R = +1; the odd ones are
  !> 0) and the half period tau, conditions: the odd components of x(tau) vanish and H(x0) = E.
  !> Newton with the state transition matrix.
  subroutine correct_symmetric(model, energy, de, x0, tau, opts, orb, stat)
    class(hamiltonian_t), intent(in) :: model
    real(wp), intent(in) :: energy
    real(wp), intent(in) :: de        !! excess energy: sets the residual's scales
    real(wp), intent(inout) :: x0(:), tau
    type(orbit_opts_t), intent(in) :: opts
    type(orbit_t), intent(inout) :: orb
    integer, intent(out) :: stat
    real(wp) :: x(size(x0)), phi(size(x0), size(x0)), f(size(x0)), gr(size(x0)), pscale, res
    real(wp), allocatable :: jac(:, :), r(:), du(:)
    integer :: it, info, n2, nf, no, k
    integer, allocatable :: ipiv(:), ev(:), od(:)
    integer :: rev(size(x0))
    n2 = size(x0)
    rev = model%reversor()
    ev = pack([(k, k = 1, n2)], rev > 0)
    od = pack([(k, k = 1, n2)], rev < 0)
    nf = size(ev)
    no = size(od)
    if (nf + no /= n2 .or. no /= nf) then
      stat = TUBES_EINPUT              ! no reversor of this kind: use multiple shooting
      return
    end if
    allocate (jac(no + 1, nf + 1), r(no + 1), du(nf + 1), ipiv(nf + 1))
    pscale = 1                          ! residual in momentum units and relative to E (energy)
    if (allocated(orb%history)) deallocate (orb%history)
    allocate (orb%history(0))
    orb%converged = .false.
    x0(od) = 0
    do it = 1, opts%max_iter
      if (diverging(orb%history)) exit
      call flow_stm(model, x0, tau, opts, x, phi, stat)
      if (stat < 0) return
      call model%eval(0.0_wp, x, f, stat)
      if (stat /= 0) then
        stat = TUBES_ENOCONV
        return
      end if
      call model%gradient(x0, gr, stat)
      if (stat /= 0) then
        stat = TUBES_ENOCONV
        return
      end if
      r(1:no) = x(od)
      r(no + 1) = model%energy(x0) - energy
      res = max(res_norm(r(1:no)/pscale), res_norm(r(no + 1:no + 1)/energy_scale(energy, de)))
      if (newton_met(orb, it, res, opts%tol)) exit
      jac = 0
      jac(1:no, 1:nf) = phi(od, ev)
      jac(1:no, nf + 1) = f(od)
      jac(no + 1, 1:nf) = gr(ev)
      du = -r
      call dgesv(nf + 1, 1, jac, no + 1, ipiv, du, nf + 1, info)
      if (info /= 0) then
        stat = TUBES_ENOCONV
        return
      end if
      ! damp steps that leave the neighbourhood (half a length scale, 20 % of tau)
      du = du*min(1.0_wp, 0.5_wp*model%length_scale()/max(1.0e-300_wp, sqrt(sum(du(1:nf)**2))), &
                  0.2_wp*tau/max(1.0e-300_wp, abs(du(nf + 1))))
      x0(ev) = x0(ev) + du(1:nf)
      tau = tau + du(nf + 1)
      if (tau <= 0) then
        stat = TUBES_ENOCONV
        return
      end if
    end do
    call newton_verdict(orb, opts%tol, stat)
    orb%x0 = x0
    orb%period = 2*tau
    orb%energy = energy
  end subroutine correct_symmetric

  !> Multiple shooting with n = opts%n_segments nodes x_i (2N n unknowns) and the period T:
  !> x_{i+1} = phi_{T/n}(x_i) (cyclic), H(x_1) = E, and the phase condition
  !> (x_1 - x_ref) . f(x_ref) = 0. The 2N n + 2 equations (one redundant by energy
  !> conservation) are solved by Gauss-Newton least squares (LAPACK dgels) on row-equilibrated
  !> equations. The segments are propagated in parallel (OpenMP), each with its own integrator.
  !> Assumes no symmetry: works for any model.
  subroutine correct_multiple(model, energy, de, nodes, period, opts, orb, stat)
    class(hamiltonian_t), intent(in) :: model
    real(wp), intent(in) :: energy
    real(wp), intent(in) :: de        !! excess energy: sets the residual's scales
    real(wp), intent(inout) :: nodes(:, :)   !! (2N, n)
    real(wp), intent(inout) :: period
    type(orbit_opts_t), intent(in) :: opts
    type(orbit_opts_t) :: o
    type(orbit_t), intent(inout) :: orb
    integer, intent(out) :: stat
    integer :: n, m, nu, i, it, info, lwork, d
    real(wp), allocatable :: a(:, :), b(:), work(:)
    real(wp) :: xref(size(nodes, 1)), fref(size(nodes, 1)), res, rowmax, pscale, &
                scale(size(nodes, 1)), xref_grad(size(nodes, 1)), amax
    d = size(nodes, 1)
    n = size(nodes, 2)
    m = d*n + 2
    nu = d*n + 1
    o = opts
    lwork = 64*m
    allocate (a(m, nu), b(m), work(lwork))
    xref = nodes(:, 1)
    call model%eval(0.0_wp, xref, fref, stat)
    if (stat /= 0) then
      stat = TUBES_ENOCONV                 ! the first node is not a state the model accepts
      return
    end if
    pscale = 1
    scale = 1                          ! residual in the state's units
    if (allocated(orb%history)) deallocate (orb%history)
    allocate (orb%history(0))
    orb%converged = .false.
    stat = TUBES_OK
    do it = 1, opts%max_iter
      if (diverging(orb%history)) exit
      call periodicity_rows(model, nodes, period, o, a, b, stat)
      if (stat < 0) return
      b(m - 1) = model%energy(nodes(:, 1)) - energy
      call model%gradient(nodes(:, 1), xref_grad, stat)
      if (stat /= 0) then
        stat = TUBES_ENOCONV
        return
      end if
      a(m - 1, :) = 0
      a(m - 1, 1:d) = xref_grad
      b(m) = dot_product(nodes(:, 1) - xref, fref)
      a(m, :) = 0
      a(m, 1:d) = fref
      res = res_norm(b(m - 1:m - 1)/energy_scale(energy, de))
      do i = 1, n
        res = max(res, res_norm(b(d*(i - 1) + 1:d*i)/scale))
      end do
      if (newton_met(orb, it, res, opts%tol)) exit
      ! equilibrate rows (the root is unchanged: the system is consistent); with one segment the
      ! periodicity rows (I - M) are left alone: their redundant row vanishes at the orbit (for a
      ! 1-DOF motion identically) and, scaled up, weighed its linearisation's error as much as the
      ! others (Newton converged linearly, by ~0.27 per iteration, on Henon-Heiles' y-axis orbit)
      amax = maxval(abs(a))
      do i = 1, m
        rowmax = maxval(abs(a(i, :)))
        if (n == 1 .and. i <= d) rowmax = 0
        if (rowmax > 1.0e-6_wp*amax) then
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
        nodes(:, i) = nodes(:, i) + b(d*(i - 1) + 1:d*i)
      end do
      period = period + b(nu)
      if (period <= 0) then
        stat = TUBES_ENOCONV
        return
      end if
    end do
    call newton_verdict(orb, opts%tol, stat)
    orb%x0 = nodes(:, 1)
    orb%period = period
    orb%energy = energy
  end subroutine correct_multiple

  !> Multiple shooting's periodicity rows (correct_multiple, shooting_arc_t): a(1:dn, 1:dn + 1)
  !> and b(1:dn) (d = 2N, n nodes) of x_{i+1} - phi_{T/n}(x_i) (cyclic) in the unknowns (nodes,
  !> T), the other entries of a and b untouched. The segments are propagated in parallel
  !> (OpenMP and MPI ranks: tubes_ensemble), each with its own integrator, from rank 0's nodes.
  subroutine periodicity_rows(model, nodes, period, opts, a, b, stat)
    class(hamiltonian_t), intent(in) :: model
    real(wp), intent(inout) :: nodes(:, :), period
    type(orbit_opts_t), intent(in) :: opts
    real(wp), intent(inout) :: a(:, :), b(:)
    integer, intent(out) :: stat
    type(segment_ens_t) :: segs
    type(ens_out_t) :: out
    real(wp) :: y(size(nodes, 1), size(nodes, 2)), phis(size(nodes, 1), size(nodes, 1), size(nodes, 2)), &
                fy(size(nodes, 1), size(nodes, 2))
    integer :: d, n, i, j, i0, j0
    d = size(nodes, 1)
    n = size(nodes, 2)
    allocate (segs%model, source=model)
    segs%opts = opts
    call ens_agree(nodes, opts%local)
    call ens_agree(period, opts%local)
    segs%nodes = nodes
    segs%tau = period/n
    call ens_run(segs, n, out, d*(d + 2), 0, fault='segment', local=opts%local)
    y = out%r(1:d, :)
    phis = reshape(out%r(d + 1:d + d*d, :), [d, d, n])
    fy = out%r(d + d*d + 1:, :)
    if (any(out%st < 0)) then
      stat = minval(out%st)
      return
    end if
    stat = TUBES_OK
    a(1:d*n, 1:d*n + 1) = 0
    do i = 1, n
      j = mod(i, n) + 1
      i0 = d*(i - 1)
      j0 = d*(j - 1)
      b(i0 + 1:i0 + d) = nodes(:, j) - y(:, i)
      a(i0 + 1:i0 + d, i0 + 1:i0 + d) = -phis(:, :, i)
      a(i0 + 1:i0 + d, j0 + 1:j0 + d) = a(i0 + 1:i0 + d, j0 + 1:j0 + d) + identity(d)
      a(i0 + 1:i0 + d, d*n + 1) = -fy(:, i)/n
    end do
  end subroutine periodicity_rows

  !> The rows of symmetric_arc_t (wref unused: the symmetry fixes the phase).
  subroutine symmetric_rows(self, w, wref, f, jac, stat)
    class(symmetric_arc_t), intent(in) :: self
    real(wp), intent(in) :: w(:), wref(:)
    real(wp), allocatable, intent(out) :: f(:), jac(:, :)
    integer, intent(out) :: stat
    real(wp) :: x0(size(self%ev) + size(self%od)), x(size(x0)), phi(size(x0), size(x0)), fx(size(x0))
    integer :: nd
    nd = size(self%od)
    allocate (f(nd), jac(nd, nd + 1))
    x0 = 0
    x0(self%ev) = w(1:nd)
    call flow_stm(self%model, x0, w(nd + 1), self%opts, x, phi, stat)
    if (stat < 0) return
    call self%model%eval(0.0_wp, x, fx, stat)
    if (stat /= 0) then
      stat = TUBES_ENOCONV
      return
    end if
    f = x(self%od)
    jac(:, 1:nd) = phi(self%od, self%ev)
    jac(:, nd + 1) = fx(self%od)
    stat = TUBES_OK
  end subroutine symmetric_rows

  !> The rows of shooting_arc_t: periodicity (periodicity_rows) and the phase condition.
  subroutine shooting_rows(self, w, wref, f, jac, stat)
    class(shooting_arc_t), intent(in) :: self
    real(wp), intent(in) :: w(:), wref(:)
    real(wp), allocatable, intent(out) :: f(:), jac(:, :)
    integer, intent(out) :: stat
    real(wp) :: nodes(size(wref) - 1), period, fref(size(wref) - 1)
    integer :: d, n
    n = self%n
    d = (size(w) - 1)/n
    allocate (f(d*n + 1), jac(d*n + 1, d*n + 1))
    nodes = w(1:d*n)
    period = w(d*n + 1)
    block
      real(wp) :: nd(d, n)
      nd = reshape(nodes, [d, n])
      call periodicity_rows(self%model, nd, period, self%opts, jac, f, stat)
    end block
    if (stat < 0) return
    call self%model%eval(0.0_wp, wref(1:d), fref(1:d), stat)
    if (stat /= 0) then
      stat = TUBES_ENOCONV
      return
    end if
    fref(1:d) = fref(1:d)/max(sqrt(sum(fref(1:d)**2)), tiny(1.0_wp))
    jac(d*n + 1, :) = 0
    jac(d*n + 1, 1:d) = fref(1:d)
    f(d*n + 1) = dot_product(w(1:d) - wref(1:d), fref(1:d))
    stat = TUBES_OK
  end subroutine shooting_rows
  !> A Newton sequence is hopeless when it has not reduced its residual for 4 iterations.
  pure logical function diverging(h)
    real(wp), intent(in) :: h(:)
    integer :: n
    n = size(h)
    diverging = .false.
    if (n >= 5) diverging = minval(h(n - 3:n)) >= h(n - 4)
  end function diverging

  !> The residual norm max_k |r(k)|, +Inf when any r(k) is NaN or infinite: Fortran's max()
  !> and maxval() may drop a NaN (gfortran's max(0, NaN) is 0), which would read as converged.
  pure real(wp) function res_norm(r)
    real(wp), intent(in) :: r(:)
    if (all(ieee_is_finite(r))) then
      res_norm = 0
      if (size(r) > 0) res_norm = maxval(abs(r))
    else
      res_norm = ieee_value(1.0_wp, ieee_positive_inf)
    end if
  end function res_norm

  !> Iteration it's residual res into the orbit's history; true when the iteration stops:
  !> converged (res meets tol, orb%converged set) or a non-finite residual (not converged).
  logical function newton_met(orb, it, res, tol) result(met)
    type(orbit_t), intent(inout) :: orb
    integer, intent(in) :: it
    real(wp), intent(in) :: res, tol
    orb%history = [orb%history, res]
    orb%iterations = it
    met = res <= tol
    if (met) orb%converged = .true.
    if (.not. ieee_is_finite(res)) met = .true.
  end function newton_met

  !> The correctors' verdict: converged, or stopped at the integration's noise floor (the last
  !> residual within 100 tol); stat TUBES_OK or TUBES_ENOCONV.
  subroutine newton_verdict(orb, tol, stat)
    type(orbit_t), intent(inout) :: orb
    real(wp), intent(in) :: tol
    integer, intent(out) :: stat
    integer :: n
    n = size(orb%history)
    if (.not. orb%converged .and. n > 0) orb%converged = orb%history(n) <= 100*tol
    stat = merge(TUBES_OK, TUBES_ENOCONV, orb%converged)
  end subroutine newton_verdict

  pure function identity(n) result(e)
    integer, intent(in) :: n
    real(wp) :: e(n, n)
    integer :: i
    e = 0
    do i = 1, n
      e(i, i) = 1
    end do
  end function identity

  !> Monodromy, Floquet multipliers, action, samples and the periodicity residual of a
  !> corrected orbit; distance of closest approach (in configuration) to the other
  !> equilibria eqs.
  subroutine finish_orbit(model, orb, opts, eqs, isad, stat)
    class(hamiltonian_t), intent(in) :: model
    type(orbit_t), intent(inout) :: orb
    type(orbit_opts_t), intent(in) :: opts
    type(equilibrium_t), intent(in) :: eqs(:)
    integer, intent(in) :: isad
    integer, intent(out) :: stat
    type(action_field_t) :: af
    class(integrator_t), allocatable :: ig
    type(sampler_t) :: obs
    real(wp), allocatable :: x(:), phi(:, :), z(:), wr(:), wi(:), dist1(:)
    real(wp) :: d
    integer :: k, iu, is, j, itr(2), n2, nd
    logical, allocatable :: free(:)
    n2 = size(orb%x0)
    nd = n2/2
    allocate (x(n2), phi(n2, n2), z(n2 + 1), wr(n2), wi(n2), dist1(n2), free(n2))
    call flow_stm(model, orb%x0, orb%period, opts, x, phi, stat)
    if (stat < 0) return
    orb%monodromy = phi
    orb%closure = maxval(abs(x - orb%x0))
    orb%residual = orb%history(size(orb%history))
    call eigen(phi, wr, wi, stat)
    if (stat /= TUBES_OK) return
    iu = maxloc(wr, 1)
    is = minloc(wr, 1)
    orb%mu_unstable = wr(iu)
    orb%mu_stable = wr(is)
    ! the trivial pair: of the others, the two closest to 1, in index order
    free = .true.
    free(iu) = .false.
    free(is) = .false.
    dist1 = abs(cmplx(wr - 1, wi, kind=wp))
    do k = 1, 2
      j = minloc(dist1, 1, mask=free)
      free(j) = .false.
      itr(k) = j
    end do
    if (itr(1) > itr(2)) itr = itr([2, 1])
    orb%mu_trivial = wr(itr)
    orb%mu_trivial_imag = wi(itr)
    orb%stability_index = 0.5_wp*(orb%mu_unstable + orb%mu_stable)
    ! action and samples in one pass
    allocate (af%model, source=model)
    call make_integrator(opts%integ, ig, stat, extended=.true., f=af, rtol=opts%rtol, atol=opts%atol)
    if (stat /= TUBES_OK) return
    z = [orb%x0, 0.0_wp]
    call obs%start(0.0_wp, orb%period/(opts%n_samples - 1), z, opts%n_samples)
    call propagate(ig, z, orb%period, stat, observer=obs)
    if (stat < 0) return
    ! the integral of (p - p_e) . dq, p_e the saddle's momentum (0 for a natural model): the same
    ! over a closed orbit, but the computed one closes only to its closure, which p . dq weighs with
    ! |p| = O(1) where p - p_e = O(sqrt dE) (the CR3BP, p_e = (-y_L, x_L): 2e-7 of the action off
    ! at dE = 1e-5, 1e-3 at 1e-11, against the tube's area)
    orb%action = z(n2 + 1) - dot_product(eqs(isad)%x(nd + 1:n2), z(1:nd) - orb%x0(1:nd))
    if (allocated(orb%t)) deallocate (orb%t, orb%x)
    allocate (orb%t(opts%n_samples), orb%x(n2, opts%n_samples))
    orb%t = obs%t(1:opts%n_samples)
    orb%x = obs%x(1:n2, 1:opts%n_samples)
    orb%t(opts%n_samples) = orb%period
    orb%x(:, opts%n_samples) = z(1:n2)
    orb%min_eq_distance = huge(1.0_wp)
    do k = 1, size(eqs)
      if (k == isad) cycle
      do j = 1, opts%n_samples
        d = sqrt(sum((orb%x(1:nd, j) - eqs(k)%q)**2))
        orb%min_eq_distance = min(orb%min_eq_distance, d)
      end do
    end do
    stat = TUBES_OK
  end subroutine finish_orbit

  !> The Floquet (stability) indices nu_i = (lambda + 1/lambda)/2 of the N - 1 nontrivial
  !> multiplier pairs of the monodromy m (2N x 2N) of a periodic orbit of an autonomous
  !> Hamiltonian system (docs/orbits.md, "Bifurcations"): nu > 1 a hyperbolic pair, -1 <= nu <= 1
  !> an elliptic one (lambda = exp(+-i theta), nu = cos theta), nu < -1 an inverse hyperbolic one,
  !> nu complex (nre +- i nim) a complex quartet off the unit circle. They are the roots of a
  !> polynomial whose coefficients come from the traces of m, m^2, ..., m^(N-1), the trivial pair
  !> taken as exactly 1: tr m^j = 2 + 2 sum_i T_j(nu_i), T_j the Chebyshev polynomials. Unlike
  !> m's eigenvalues near 1 (the trivial Jordan block, where an index crossing +1 makes a 4-fold
  !> eigenvalue) the traces are smooth functions of m. Ordered by descending real part.
  subroutine floquet_indices(m, nre, nim, stat)
    real(wp), intent(in) :: m(:, :)
    real(wp), intent(out) :: nre(:), nim(:)   !! (N - 1)
    integer, intent(out) :: stat
    real(wp), allocatable :: mj(:, :), c(:), pw(:), e(:), tc(:, :), comp(:, :), wr(:), wi(:)
    real(wp) :: d, s
    integer :: np, j, k, i
    np = size(m, 1)/2 - 1
    stat = TUBES_OK
    nre = 0
    nim = 0
    if (np < 1) return
    allocate (mj(size(m, 1), size(m, 1)), c(np), pw(0:np), e(0:np), tc(0:np, 0:np))
    ! c_j = (tr m^j - 2)/2 = sum_i T_j(nu_i)
    mj = m
    do j = 1, np
      if (j > 1) mj = matmul(mj, m)
      c(j) = 0
      do i = 1, size(m, 1)
        c(j) = c(j) + mj(i, i)
      end do
      c(j) = (c(j) - 2)/2
    end do
    ! the Chebyshev coefficients tc(j, k) of x^k in T_j
    tc = 0
    tc(0, 0) = 1
    if (np >= 1) tc(1, 1) = 1
    do j = 2, np
      tc(j, 1:np) = 2*tc(j - 1, 0:np - 1)
      tc(j, :) = tc(j, :) - tc(j - 2, :)
    end do
    ! the power sums pw(k) = sum_i nu_i^k (triangular: T_j's leading coefficient is 2^(j-1))
    pw(0) = np
    do j = 1, np
      pw(j) = (c(j) - dot_product(tc(j, 0:j - 1), pw(0:j - 1)))/tc(j, j)
    end do
    ! Newton's identities: the elementary symmetric polynomials e(k) of the nu_i
    e(0) = 1
    do k = 1, np
      s = 0
      do i = 1, k
        s = s + (-1)**(i - 1)*e(k - i)*pw(i)
      end do
      e(k) = s/k
    end do
    select case (np)
    case (1)
      nre(1) = e(1)
    case (2)
      ! z^2 - e1 z + e2: d = ((nu1 - nu2)/2)^2 from the power sums (no e2 cancellation)
      d = (2*pw(2) - pw(1)**2)/4
      if (d >= 0) then
        nre = [pw(1)/2 + sqrt(d), pw(1)/2 - sqrt(d)]
      else
        nre = pw(1)/2
        nim = [sqrt(-d), -sqrt(-d)]
      end if
      ! a strongly hyperbolic pair (|nu| > 10: the L1 Lyapunov orbits' ~1e3) takes the other
      ! index's digits out of tr m^2 (rounding ~1e-16 nu^2): then nu_1 from m's largest real
      ! eigenvalue (well separated, well conditioned) and nu_2 = c_1 - nu_1 from tr m alone
      if (max(abs(nre(1)), abs(nre(2))) > 10 .and. all(nim == 0)) then
        allocate (wr(size(m, 1)), wi(size(m, 1)))
        call eigen(m, wr, wi, stat)
        if (stat /= TUBES_OK) return
        i = maxloc(abs(wr), 1, mask=wi == 0)
        s = (wr(i) + 1/wr(i))/2
        nre = [s, c(1) - s]
        if (nre(2) > nre(1)) nre = nre([2, 1])
      end if
    case default
      allocate (comp(np, np), wr(np), wi(np))
      comp = 0
      do k = 1, np   ! the companion matrix of z^np - e1 z^(np-1) + e2 z^(np-2) - ...
        comp(1, k) = (-1)**(k - 1)*e(k)
      end do
      do k = 2, np
        comp(k, k - 1) = 1
      end do
      call eigen(comp, wr, wi, stat)
      if (stat /= TUBES_OK) return
      do k = 1, np   ! descending real part
        i = maxloc(wr, 1)
        nre(k) = wr(i)
        nim(k) = wi(i)
        wr(i) = -huge(1.0_wp)
      end do
    end select
  end subroutine floquet_indices

  !> The eigenvector of the monodromy m for the multiplier sgn (+1: a branch point, -1: a period
  !> doubling) at a bifurcation, the new family's tangent there: the unit vector v with
  !> (m - sgn I) v = 0, for sgn = +1 also orthogonal to the flow direction f (the trivial
  !> eigenvector); the right singular vector of the smallest singular value of that (2N + 1) x 2N
  !> (or 2N x 2N) matrix, from the eigenvectors of its normal matrix (accurate to ~1e-16 |m|^2 over
  !> the gap to the next singular value squared). Its largest component is positive.
  subroutine floquet_tangent(m, f, sgn, v, stat)
    real(wp), intent(in) :: m(:, :), f(:)
    integer, intent(in) :: sgn
    real(wp), intent(out) :: v(:)
    integer, intent(out) :: stat
    real(wp), allocatable :: a(:, :), b(:, :), w(:), work(:)
    integer :: n2, i, info, nr
    n2 = size(m, 1)
    nr = n2 + merge(1, 0, sgn > 0)
    allocate (a(nr, n2), b(n2, n2), w(n2), work(max(1, 66*n2)))
    a(1:n2, :) = m
    do i = 1, n2
      a(i, i) = a(i, i) - sgn
    end do
    if (sgn > 0) a(nr, :) = f*(maxval(abs(m))/max(sqrt(sum(f**2)), tiny(1.0_wp)))
    b = matmul(transpose(a), a)
    call dsyev('V', 'U', n2, b, n2, w, work, size(work), info)
    stat = TUBES_OK
    if (info /= 0) then
      stat = TUBES_ENOCONV
      return
    end if
    v = b(:, 1)   ! ascending eigenvalues: the smallest first
    i = maxloc(abs(v), 1)
    if (v(i) < 0) v = -v
  end subroutine floquet_tangent

  !> Nodes for multiple shooting: n points a period apart/n along the trajectory from x0.
  subroutine nodes_from(model, x0, period, n, opts, nodes, stat)
    class(hamiltonian_t), intent(in) :: model
    real(wp), intent(in) :: x0(:), period
    integer, intent(in) :: n
    type(orbit_opts_t), intent(in) :: opts
    real(wp), intent(out) :: nodes(:, :)
    integer, intent(out) :: stat
    class(integrator_t), allocatable :: ig
    real(wp) :: x(size(x0))
    integer :: i
    x = x0
    nodes(:, 1) = x0
    call make_integrator(opts%integ, ig, stat, f=model, rtol=opts%rtol, atol=opts%atol)
    if (stat /= TUBES_OK) return
    stat = TUBES_OK
    do i = 2, n
      call propagate(ig, x, (i - 1)*period/n, stat)
      if (stat < 0) return
      nodes(:, i) = x
    end do
  end subroutine nodes_from

  !> True when the model has a reversor whose fixed set holds half the components (the
  !> symmetric single-shooting corrector applies).
  logical function has_reversor(model)
    class(hamiltonian_t), intent(in) :: model
    integer :: rev(model%dim())
    rev = model%reversor()
    has_reversor = count(rev > 0) == size(rev)/2 .and. count(rev < 0) == size(rev)/2
  end function has_reversor

  !> Solve one orbit at excess energy de from the guess (x0 on the reversor's fixed set, tau
  !> the half period) with the method of opts: single shooting of the symmetric orbit, or
  !> multiple shooting (also for models without a reversor).
  subroutine solve_orbit(model, sad, de, x0, tau, opts, eqs, isad, orb, stat, nodes)
    class(hamiltonian_t), intent(in) :: model
    type(equilibrium_t), intent(in) :: sad
    real(wp), intent(in) :: de
    real(wp), intent(inout) :: x0(:), tau
    type(orbit_opts_t), intent(in) :: opts
    type(equilibrium_t), intent(in) :: eqs(:)
    integer, intent(in) :: isad
    type(orbit_t), intent(out) :: orb
    integer, intent(out) :: stat
    !> multiple shooting: the nodes' guess on entry (when allocated with n_segments columns;
    !> otherwise the nodes are integrated from x0), the corrected nodes on return
    real(wp), allocatable, intent(inout) :: nodes(:, :)
    real(wp) :: period
    integer :: rev(size(x0)), ns
    orb%de = de
    if (opts%n_segments <= 1 .and. has_reversor(model)) then
      call correct_symmetric(model, sad%energy + de, de, x0, tau, opts, orb, stat)
    else
      ns = max(opts%n_segments, 1)
      if (allocated(nodes)) then
        if (any(shape(nodes) /= [size(x0), ns])) deallocate (nodes)
      end if
      if (.not. allocated(nodes)) then
        allocate (nodes(size(x0), ns))
        call nodes_from(model, x0, 2*tau, ns, opts, nodes, stat)
        if (stat < 0) return
      end if
      period = 2*tau
      call correct_multiple(model, sad%energy + de, de, nodes, period, opts, orb, stat)
      if (stat == TUBES_OK) then
        x0 = nodes(:, 1)
        rev = model%reversor()
        if (has_reversor(model)) where (rev < 0) x0 = 0   ! the next guess on the fixed set
        tau = period/2
      end if
    end if
    orb%de = de
    if (stat == TUBES_OK) call finish_orbit(model, orb, opts, eqs, isad, stat)
  end subroutine solve_orbit

  !> The family of Lyapunov orbits of saddle eqs(isad) at the requested excess energies
  !> des (ascending), by continuation from de -> 0 with an adaptive step in sqrt(de) and a
  !> secant predictor. When the family ends (period > period_max T_po, approach to another
  !> equilibrium, or failure of the corrector for steps below 1e-6 of de) the continuation
  !> stops: end_de estimates the limit, end_reason says why, and orbits past it are not
  !> computed (converged = .false.). stat < 0 only for invalid input.
  !>
  !> Each orbit is the continuation to its own energy alone, bit for bit, whatever else des
  !> holds: the continuation follows the family's ladder (its steps towards no target) until the
  !> ladder's next step would pass de, then steps to de (docs/orbits.md, "One family, each orbit
  !> once"). With path, a run keeps the ladder and the orbits found between calls: a later call
  !> of the same family (the caller's key: model, saddle and opts) takes them instead of
  !> continuing again. path is used only where ens_reuse_ok allows (one MPI rank, or opts%local).
  recursive subroutine orbit_family(model, eqs, isad, des, opts, orbits, end_de, end_reason, stat, path, folds)
    class(hamiltonian_t), intent(in) :: model
    type(equilibrium_t), intent(in) :: eqs(:)
    integer, intent(in) :: isad
    real(wp), intent(in) :: des(:)
    type(orbit_opts_t), intent(in) :: opts
    type(orbit_t), intent(out) :: orbits(size(des))
    real(wp), intent(out) :: end_de
    integer, intent(out) :: end_reason
    integer, intent(out) :: stat
    type(family_path_t), intent(inout), optional :: path   !! the run's path of this family
    type(fold_t), allocatable, intent(out), optional :: folds(:)  !! a guess's family: its folds
    type(family_path_t) :: own
    type(fold_t), allocatable :: fl(:)
    integer :: k
    logical :: ended
    stat = TUBES_OK
    end_de = -1
    end_reason = END_NONE
    if (present(folds)) allocate (folds(0))
    if (size(des) == 0) return
    if (allocated(opts%guess)) then   ! a family from a guess: any energies, ascending
      if (isad < 1 .or. isad > size(eqs) .or. .not. ascending(des)) then
        stat = TUBES_EINPUT
        return
      end if
      allocate (fl(0))
      call guess_family(model, eqs, isad, des, opts, orbits, end_de, end_reason, fl, stat)
      if (present(folds)) call move_alloc(fl, folds)
      return
    end if
    if (any(des <= 0) .or. isad < 1 .or. isad > size(eqs)) then
      stat = TUBES_EINPUT
      return
    end if
    if (.not. eqs(isad)%rank1) then
      stat = TUBES_EINPUT
      return
    end if
    if (opts%family == FAMILY_BRANCH_PLUS .or. opts%family == FAMILY_BRANCH_MINUS) then
      if (present(path) .and. ens_reuse_ok('segment', opts%local)) then   ! its branch point kept there
        call branch_family(model, eqs, isad, des, opts, orbits, end_de, end_reason, stat, path)
      else
        call branch_family(model, eqs, isad, des, opts, orbits, end_de, end_reason, stat)
      end if
      return
    end if
    if (opts%family /= 1) then   ! another centre mode's family: that mode first, then as family 1
      if (opts%family < 1 .or. opts%family > size(eqs(isad)%omegas)) then
        stat = TUBES_EINPUT
        return
      end if
      block
        type(equilibrium_t) :: e(size(eqs))
        type(orbit_opts_t) :: o
        integer :: j
        e = eqs
        j = opts%family
        e(isad)%omega = e(isad)%omegas(j)
        e(isad)%omegas([1, j]) = e(isad)%omegas([j, 1])
        e(isad)%evec(:, [3, 4, 2*j + 1, 2*j + 2]) = e(isad)%evec(:, [2*j + 1, 2*j + 2, 3, 4])
        o = opts
        o%family = 1
        call orbit_family(model, e, isad, des, o, orbits, end_de, end_reason, stat, path, folds)
        return
      end block
    end if
    if (.not. ascending(des)) then
      stat = TUBES_EINPUT
      return
    end if
    ended = .false.
    do k = 1, size(des)
      if (.not. ended) then
        if (present(path) .and. ens_reuse_ok('segment', opts%local)) then
          call path_orbit(path)
        else
          call path_orbit(own)
        end if
        ended = .not. orbits(k)%converged
      end if
      if (ended .and. .not. orbits(k)%converged) orbits(k) = orbit_t(de=des(k))   ! past the end
    end do
  contains
    subroutine path_orbit(p)   ! orbits(k) from p, else continued on p and kept
      type(family_path_t), intent(inout) :: p
      integer :: i
      if (.not. allocated(p%des)) allocate (p%des(0), p%orbs(0), p%end_de(0), p%end_reason(0))
      do i = 1, size(p%des)
        if (p%des(i) == des(k)) then
          orbits(k) = p%orbs(i)
          if (.not. orbits(k)%converged) then
            end_de = p%end_de(i)
            end_reason = p%end_reason(i)
          end if
          return
        end if
      end do
      call continue_to(model, eqs, isad, des(k), opts, p, orbits(k), end_de, end_reason)
      orbits(k)%de = des(k)
      call keep_orbit(p, des(k), orbits(k), end_de, end_reason)
    end subroutine path_orbit
  end subroutine orbit_family

  !> Are the energies des strictly ascending (no des(k) <= des(k - 1))? orbit_family's requirement
  !> of every family's des.
  pure logical function ascending(des)
    real(wp), intent(in) :: des(:)
    ascending = .not. any(des(2:) <= des(:size(des) - 1))
  end function ascending

  !> The symmetric family branching off family N - 1 at its first branch point (opts%family =
  !> FAMILY_BRANCH_PLUS or _MINUS), at the ascending excess energies des (docs/orbits.md, "Branch
  !> switching"): (1) family N - 1 on the ladder dE_1 2^j (dE_1 = 1e-2 s_0^2, s_0 the
  !> continuation's first step, start_step: the ladder does not depend on des) up to the first
  !> energy at or above des(n), its first change in the count of indices above +1, bisected to
  !> 1e-11 dE (the branch point: the same for any des that reach it, and kept on path); (2) there the monodromy's
  !> eigenvector for +1 off the flow (floquet_tangent), its part on the reversor's fixed set the
  !> tangent of the new branch; (3) pseudo-arclength continuation along the branch in the
  !> symmetric unknowns w = (x0 on the fixed set, tau), conditions: the odd components of
  !> x(tau) vanish and (w - w_pred) . t = 0 (the energy free), the step adapted (x1.5 after <= 3
  !> iterations, /2 on failure, down to 1e-6 of the first); (4) each requested energy passed
  !> between two steps: correct_symmetric at that energy from the chord between them. The
  !> continuation ends when the energy turns back (a fold: END_FOLD), the step falls below its
  !> floor (END_NOCONV), the period passes period_max T_po (END_PERIOD) or after 2000 steps.
  !> Needs a model with a reversor whose fixed set holds N components (single shooting). The grid's
  !> and the bisection's orbits of family N - 1 share one path (family_path_t: its ladder climbed
  !> once; each orbit bit for bit the one a path of its own gives). path: the caller's kept path of
  !> this branch family, which holds its branch point once found (a period search's probes find it
  !> once).
  subroutine branch_family(model, eqs, isad, des, opts, orbits, end_de, end_reason, stat, path)
    class(hamiltonian_t), intent(in) :: model
    type(equilibrium_t), intent(in) :: eqs(:)
    integer, intent(in) :: isad
    real(wp), intent(in) :: des(:)
    type(orbit_opts_t), intent(in) :: opts
    type(orbit_t), intent(out) :: orbits(size(des))
    real(wp), intent(out) :: end_de
    integer, intent(out) :: end_reason, stat
    type(orbit_opts_t) :: po
    type(orbit_t), allocatable :: grid(:)
    type(orbit_t) :: ob(1)
    real(wp), allocatable :: dg(:), w(:), wn(:), t(:), tn(:), wprev(:), xx(:), phi(:, :), fx(:), v(:)
    type(symmetric_arc_t) :: sys
    type(family_path_t), intent(inout), optional :: path
    type(family_path_t) :: pp   ! family N - 1's path: the grid's and the bisection's orbits
    real(wp) :: lo, hi, mid, e_sad, h, h0, e_prev, e_now, tau, zbig
    real(wp), allocatable :: wb(:), tb(:), tprev(:), wk(:)
    logical :: oriented
    integer :: n2, nd, k, c_lo, np, it, j, nstep, iz
    integer, allocatable :: ev(:), od(:), rev(:), cnt(:)
    real(wp) :: nre(size(eqs(isad)%x)/2 - 1), nim(size(eqs(isad)%x)/2 - 1)
    logical :: ok
    stat = TUBES_OK
    end_de = -1
    end_reason = END_NONE
    n2 = model%dim()
    nd = n2/2
    np = nd - 1
    if (np < 1 .or. .not. has_reversor(model)) then
      stat = TUBES_EINPUT
      return
    end if
    e_sad = eqs(isad)%energy
    rev = model%reversor()
    ev = pack([(k, k = 1, n2)], rev > 0)
    od = pack([(k, k = 1, n2)], rev < 0)
    iz = findloc(ev, nd, 1)          ! q_N among the fixed-set unknowns
    if (iz == 0) then
      stat = TUBES_EINPUT
      return
    end if
    po = opts
    po%family = np
    po%n_segments = 1
    allocate (t(nd + 1), tn(nd + 1), w(nd + 1), wn(nd + 1), wprev(nd + 1), tprev(nd + 1), wk(nd + 1))
    end_de = -1
    end_reason = END_NONE
    if (present(path)) then
      if (allocated(path%branch_w)) then
        w = path%branch_w
        t = path%branch_t
      end if
    end if
    if (.not. present(path)) then
      call branch_point(ok)
    else if (.not. allocated(path%branch_w)) then
      call branch_point(ok)
      if (ok) then
        path%branch_w = w
        path%branch_t = t
      end if
    else
      ok = .true.
    end if
    if (stat /= TUBES_OK .or. end_reason == END_NOBRANCH) return
    if (model%energy(state_of(w)) - e_sad > des(size(des))) then   ! every energy below the branch point
      end_reason = END_NOBRANCH
      orbits(:)%de = des
      return
    end if
    wb = w                                                 ! the branch point, for a restart
    tb = t
    oriented = .false.
    ! (3) pseudo-arclength along the branch
    allocate (xx(n2), phi(n2, n2))
    allocate (sys%model, source=model)
    sys%opts = opts
    sys%ev = ev
    sys%od = od
    h0 = 1.0e-2_wp*model%length_scale()
    h = h0
    e_prev = model%energy(state_of(w))
    k = 1
    orbits(:)%de = des
    do nstep = 1, 2000
      if (k > size(des)) exit
      call arc_step(sys, w, t, h, opts, wn, tn, it, ok)   ! the predictor, the corrector, the tangent
      stat = TUBES_OK
      if (.not. ok) then
        h = h/2
        if (h < 1.0e-6_wp*h0) then
          end_reason = END_NOCONV
          exit
        end if
        cycle
      end if
      if (.not. oriented) then
        ! north: the orbit's larger excursion in q_N (at one of its two fixed-set points, x0 and
        ! x(tau)) is positive; south: negative. The first step decides (its asymmetry ~15 %)
        oriented = .true.
        call flow_stm(model, state_of(wn), wn(nd + 1), opts, xx, phi, stat)
        if (stat < 0) return
        zbig = wn(iz)
        if (abs(xx(nd)) > abs(wn(iz))) zbig = xx(nd)
        if ((zbig < 0) .eqv. (opts%family == FAMILY_BRANCH_PLUS)) then
          w = wb
          t = -tb
          h = h0
          cycle
        end if
      end if
      wprev = w
      tprev = t
      w = wn
      t = tn
      e_now = model%energy(state_of(w))
      if (e_now < e_prev) then            ! the energy turns back: a fold
        end_reason = END_FOLD
        end_de = e_prev - e_sad
        exit
      end if
      if (w(nd + 1) > 0.5_wp*opts%period_max*2*PI/eqs(isad)%omega) then
        end_reason = END_PERIOD
        end_de = e_now - e_sad
        exit
      end if
      ! (4) the requested energies passed in this step
      do while (k <= size(des))
        if (e_sad + des(k) > e_now) exit
        if (e_sad + des(k) < e_prev) then   ! below the branch point: not on this branch
          orbits(k) = orbit_t(de=des(k))
          k = k + 1
          cycle
        end if
        ! the arc's own point at this energy (not the chord's: off the branch point the energy
        ! grows like the square of the arc length, and the chord's point fell in the corrector's
        ! basin of the planar orbit or of the mirror branch), corrected at the energy
        call arc_point_at(sys, model, ev, wprev, tprev, 0.0_wp, h, e_prev, e_now, wprev, w, e_sad + des(k), &
                          opts, wk)
        xx = state_of(wk)
        tau = wk(nd + 1)
        orbits(k)%de = des(k)
        call correct_symmetric(model, e_sad + des(k), des(k), xx, tau, opts, orbits(k), stat)
        if (stat < 0) return
        orbits(k)%de = des(k)
        if (stat == TUBES_OK) call finish_orbit(model, orbits(k), opts, eqs, isad, stat)
        if (stat < 0) return
        if (orbits(k)%converged) call check_on_branch(orbits(k), [orbits(k)%x0(ev), orbits(k)%period/2], wk, wb, &
                                                      nd, merge(1, -1, opts%family == FAMILY_BRANCH_PLUS), opts%tol* &
                                                      model%length_scale())
        stat = TUBES_OK
        k = k + 1
      end do
      e_prev = e_now
      if (it <= 3) h = min(1.5_wp*h, 20*h0)
    end do
    if (end_reason /= END_NONE .and. end_de < 0) end_de = e_prev - e_sad
    stat = TUBES_OK
  contains
    function state_of(u) result(x)   ! the state of the fixed-set unknowns
      real(wp), intent(in) :: u(:)
      real(wp) :: x(n2)
      x = 0
      x(ev) = u(1:nd)
    end function state_of
    ! (1) the first branch point of family N - 1 on the ladder dE_1 2^j (up to the first energy at
    ! or above des(n)) and (2) the branch's tangent there: w, t; END_NOBRANCH where none
    subroutine branch_point(found)
      logical, intent(out) :: found
      found = .false.
      dg = branch_ladder(model, eqs, isad, des(size(des)))
      allocate (grid(size(dg)), cnt(size(dg)))
      call parent_orbits(dg, grid)
      if (stat < 0) return
      cnt = -1
      do k = 1, size(dg)
        if (.not. grid(k)%converged) exit
        call floquet_indices(grid(k)%monodromy, nre, nim, stat)
        if (stat /= TUBES_OK) return
        cnt(k) = count(nre > 1 .and. nim == 0)
      end do
      j = 0
      do k = 1, size(dg) - 1
        if (cnt(k) >= 0 .and. cnt(k + 1) >= 0 .and. cnt(k) /= cnt(k + 1)) then
          j = k
          exit
        end if
      end do
      end_de = -1
      end_reason = END_NONE
      stat = TUBES_OK
      if (j == 0) then        ! no branch point below the largest energy: no branch to follow
        end_reason = END_NOBRANCH
        orbits(:)%de = des
        return
      end if
      lo = dg(j)
      hi = dg(j + 1)
      c_lo = cnt(j)
      do while (hi - lo > 1.0e-11_wp*hi)
        mid = lo + (hi - lo)/2
        call parent_orbits([mid], ob)
        if (stat < 0) return
        if (.not. ob(1)%converged) then
          stat = TUBES_ENOCONV
          return
        end if
        call floquet_indices(ob(1)%monodromy, nre, nim, stat)
        if (count(nre > 1 .and. nim == 0) == c_lo) then
          lo = mid
        else
          hi = mid
        end if
      end do
      call parent_orbits([lo + (hi - lo)/2], ob)
      if (stat < 0) return
      if (.not. ob(1)%converged) then
        stat = TUBES_ENOCONV
        return
      end if
      end_de = -1
      end_reason = END_NONE
      ! (2) the tangent on the fixed set
      allocate (fx(n2), v(n2))
      call model%eval(0.0_wp, ob(1)%x0, fx, stat)
      if (stat /= TUBES_OK) then
        stat = TUBES_ENOCONV
        return
      end if
      call floquet_tangent(ob(1)%monodromy, fx, 1, v, stat)
      if (stat /= TUBES_OK) return
      t = [v(ev), 0.0_wp]
      t = t/sqrt(sum(t**2))
      w = [ob(1)%x0(ev), ob(1)%period/2]
      found = .true.
    end subroutine branch_point
    subroutine parent_orbits(d, o)   ! family N - 1 at the energies d, on the call's path pp
      real(wp), intent(in) :: d(:)
      type(orbit_t), intent(out) :: o(size(d))
      call orbit_family(model, eqs, isad, d, po, o, end_de, end_reason, stat, pp)
    end subroutine parent_orbits
  end subroutine branch_family

  !> The energies on which a family's branch points are sought (branch_family, the axial family):
  !> the ladder dE_1 2^j, j = 0, 1, ..., up to the first at or above de_max (at most 200), dE_1 =
  !> 1e-2 s_0^2 with s_0 the continuation's first step (start_step). It does not depend on the
  !> energies asked for beyond their largest, so neither do the branch points found on it (bisected
  !> within one of its intervals): a period search's probes find the same point and keep it.
  function branch_ladder(model, eqs, isad, de_max) result(dg)
    class(hamiltonian_t), intent(in) :: model
    type(equilibrium_t), intent(in) :: eqs(:)
    integer, intent(in) :: isad
    real(wp), intent(in) :: de_max
    real(wp), allocatable :: dg(:)
    real(wp) :: d1
    integer :: k
    d1 = 1.0e-2_wp*start_step(model, eqs, isad)**2
    allocate (dg(0))
    do k = 1, 200
      dg = [dg, d1*2.0_wp**(k - 1)]
      if (dg(k) >= de_max) exit
    end do
  end function branch_ladder

  !> The point of an arc at the energy ek, between two of its points: wa + (steps of length h in
  !> [h1, h2] from wa along ta, arc_step; h = 0 is wa itself) whose ends w1, w2 have the energies e1
  !> and e2 (ek between them). The step length h with H(x(h)) = ek is found by the Illinois method
  !> (to 1e-6 of the nearer end's distance in energy, at most 60 steps), the state of a point w
  !> being x(ev) = w(1:size(ev)), 0 elsewhere. Off a branch point (and near a fold) the energy moves
  !> quadratically along the arc, and the chord's point at ek, linear in energy, lies short of
  !> the arc: at L1's halo branch 16 % to 40 % short in |z0| within 1e-5 of the branch point, where
  !> the corrector at fixed energy then went to the planar orbit or to the mirror branch
  !> (docs/orbits.md, "Branch switching"). Where an arc step fails, the chord's point (wk is
  !> always set).
  subroutine arc_point_at(sys, model, ev, wa, ta, h1, h2, e1, e2, w1, w2, ek, opts, wk)
    class(arc_system_t), intent(in) :: sys
    class(hamiltonian_t), intent(in) :: model
    integer, intent(in) :: ev(:)
    real(wp), intent(in) :: wa(:), ta(:), h1, h2, e1, e2, w1(:), w2(:), ek
    type(orbit_opts_t), intent(in) :: opts
    real(wp), intent(out) :: wk(:)
    real(wp) :: lo, hi, glo, ghi, hm, gm, etol, wm(size(wa)), tm(size(wa)), x(model%dim())
    integer :: it, its, side
    logical :: okm
    wk = w1
    if (e2 /= e1) wk = w1 + (ek - e1)/(e2 - e1)*(w2 - w1)     ! the chord's point: the fallback
    lo = h1
    hi = h2
    glo = e1 - ek
    ghi = e2 - ek
    if (glo == 0 .or. ghi == 0) then
      if (ghi == 0) wk = w2
      if (glo == 0) wk = w1
      return
    end if
    if (glo*ghi > 0) return
    etol = max(1.0e-6_wp*min(abs(glo), abs(ghi)), 4*epsilon(1.0_wp)*abs(ek))
    side = 0
    do it = 1, 60
      hm = (lo*ghi - hi*glo)/(ghi - glo)
      if (.not. (hm > min(lo, hi) .and. hm < max(lo, hi))) hm = lo + (hi - lo)/2
      call arc_step(sys, wa, ta, hm, opts, wm, tm, its, okm)
      if (.not. okm) return
      x = 0
      x(ev) = wm(1:size(ev))
      gm = model%energy(x) - ek
      wk = wm
      if (abs(gm) <= etol) exit
      if (gm*ghi > 0) then
        hi = hm
        ghi = gm
        if (side == -1) glo = glo/2
        side = -1
      else
        lo = hm
        glo = gm
        if (side == 1) ghi = ghi/2
        side = 1
      end if
      if (abs(hi - lo) <= 1.0e-14_wp*abs(h2)) exit
    end do
  end subroutine arc_point_at

  !> A branch's corrected orbit orb (its unknowns wo) against the arc's point wk at its energy it
  !> was corrected from (the bifurcation's point wb): on the branch when it stayed within 1/10 of
  !> wk's distance from wb (the parent family's orbit at that energy is ~ that distance away, the
  !> mirror branch's twice it: a pitchfork's branches leave its point like sqrt(dE - dE_b)); for
  !> the halo branches (iz > 0: q_iz the out-of-plane coordinate, side +1 north, -1 south) also
  !> the larger excursion of q_iz over the orbit's samples on the branch's side and above zmin.
  !> Off the branch: orb%off_branch, not converged (docs/orbits.md, "Branch switching").
  subroutine check_on_branch(orb, wo, wk, wb, iz, side, zmin)
    type(orbit_t), intent(inout) :: orb
    real(wp), intent(in) :: wo(:), wk(:), wb(:), zmin
    integer, intent(in) :: iz, side
    real(wp) :: zhi, zlo
    logical :: on
    on = norm2(wo - wk) <= 0.1_wp*norm2(wk - wb)
    if (on .and. iz > 0) then
      zhi = maxval(orb%x(iz, :))
      zlo = minval(orb%x(iz, :))
      if (side > 0) on = zhi > -zlo .and. zhi > zmin
      if (side < 0) on = -zlo > zhi .and. -zlo > zmin
    end if
    if (.not. on) then
      orb%off_branch = .true.
      orb%converged = .false.
    end if
  end subroutine check_on_branch

  !> One pseudo-arclength step of the arc system sys from the corrected point w with unit
  !> tangent t (docs/orbits.md, "Orbits from a guess"): the predictor w + h t, corrected by
  !> Gauss-Newton least squares on [f(w'); t . (w' - w - h t)] (rows equilibrated, LAPACK dgels)
  !> until max |f| <= tol (or, when Newton stalls, <= 100 tol: the integration's noise floor);
  !> the new tangent the null vector of f's Jacobian at the corrected point, oriented along t.
  !> ok false when Newton fails.
  subroutine arc_step(sys, w, t, h, opts, wn, tn, iters, ok)
    class(arc_system_t), intent(in) :: sys
    real(wp), intent(in) :: w(:), t(:), h
    type(orbit_opts_t), intent(in) :: opts
    real(wp), intent(out) :: wn(:), tn(:)
    integer, intent(out) :: iters
    logical, intent(out) :: ok
    real(wp), allocatable :: f(:), jac(:, :), a(:, :), b(:), work(:), hist(:)
    real(wp) :: wpred(size(w)), rowmax, res, amax
    integer :: m, nw, it, i, info, st
    nw = size(w)
    wpred = w + h*t
    wn = wpred
    tn = t
    ok = .false.
    iters = 0
    allocate (hist(0))
    do it = 1, opts%max_iter
      iters = it
      call sys%rows(wn, w, f, jac, st)
      if (st /= TUBES_OK) return
      res = res_norm(f)
      hist = [hist, res]
      if (res <= opts%tol) then
        ok = .true.
        exit
      end if
      if (diverging(hist) .or. it == opts%max_iter) then
        ok = res <= 100*opts%tol
        if (ok) exit
        return
      end if
      m = size(f) + 1
      if (allocated(a)) deallocate (a, b, work)
      allocate (a(m, nw), b(max(m, nw)), work(64*(m + nw)))
      a(1:m - 1, :) = jac
      a(m, :) = t
      b(1:m - 1) = f
      b(m) = dot_product(t, wn - wpred)
      amax = maxval(abs(a))
      do i = 1, m     ! equilibrated as in correct_multiple (one segment's periodicity rows left alone)
        rowmax = maxval(abs(a(i, :)))
        if (i <= sys%n_raw) rowmax = 0
        if (rowmax > 1.0e-6_wp*amax) then
          a(i, :) = a(i, :)/rowmax
          b(i) = b(i)/rowmax
        end if
      end do
      b = -b
      call dgels('N', m, nw, 1, a, m, b, size(b), work, size(work), info)
      if (info /= 0) return
      wn = wn + b(1:nw)
      if (.not. wn(nw) > 0) return            ! the period (the last unknown) must stay positive
    end do
    if (.not. ok) return
    call null_vector(jac, tn, info)
    if (info /= 0) then
      ok = .false.
      return
    end if
    if (dot_product(tn, t) < 0) tn = -tn
  end subroutine arc_step

  !> Pseudo-arclength continuation of the multiple-shooting arc sys (n nodes) from the corrected
  !> point w0 along the unit tangent t0, the energy free (docs/orbits.md, "Orbits from a guess").
  !> Each requested energy e_sad + des(k) with want(k) is taken at its first crossing along the
  !> arc: correct_multiple at that energy from the chord between the two arc points around it,
  !> then finish_orbit. dir: the energy's direction at the start (+1, -1); 0: the first step
  !> decides and the energies on the other side are dropped (a branch: they are not on it).
  !> Folds (the energy's derivative along the arc, grad H . t, changes sign) are located by
  !> bisection in the step's length to 1e-9 of it and appended to folds. The arc stops when every
  !> wanted energy is taken (END_NONE), the step falls below 1e-6 of the first (END_NOCONV), the
  !> period passes period_max times the start's (END_PERIOD), the energy after a fold returns
  !> past the start's (END_RETURN), or after ARC_MAX_STEPS steps (END_STEPS); end_de: the energy
  !> reached then (excess). stat < 0 only for a fault of the integration of an orbit taken.
  subroutine arc_run(sys, model, eqs, isad, w0, t0, n, dir, des, want, opts, orbits, end_de, end_reason, &
                     folds, stat, end_at_fold)
    class(arc_system_t), intent(in) :: sys
    class(hamiltonian_t), intent(in) :: model
    type(equilibrium_t), intent(in) :: eqs(:)
    integer, intent(in) :: isad, n, dir
    real(wp), intent(in) :: w0(:), t0(:), des(:)
    logical, intent(inout) :: want(:)
    type(orbit_opts_t), intent(in) :: opts
    type(orbit_t), intent(inout) :: orbits(:)
    real(wp), intent(out) :: end_de
    integer, intent(out) :: end_reason, stat
    type(fold_t), allocatable, intent(inout) :: folds(:)
    logical, intent(in), optional :: end_at_fold   !! stop at the first fold (END_FOLD, end_de the fold's)
    real(wp) :: w(size(w0)), t(size(w0)), wn(size(w0)), tn(size(w0)), wf(size(w0)), tf(size(w0))
    real(wp) :: h, h0, e_sad, e_start, e_prev, e_now, g_prev, g_now, ef, hf
    integer :: d, nw, nstep, it, sgn0, nfold, naccept, k
    logical :: ok, found(size(des))
    type(fold_t) :: fo
    integer, allocatable :: ev1(:)
    d = model%dim()
    nw = size(w0)
    e_sad = eqs(isad)%energy
    stat = TUBES_OK
    end_de = -1
    end_reason = END_NONE
    found = .false.
    ev1 = [(k, k = 1, d)]
    w = w0
    t = t0
    h0 = 1.0e-2_wp*model%length_scale()*sqrt(real(n, wp))
    h = h0
    e_start = model%energy(w(1:d))
    e_prev = e_start
    g_prev = slope(w, t)
    sgn0 = dir
    nfold = 0
    naccept = 0
    if (sgn0 /= 0) where ((e_sad + des - e_start)*sgn0 < 0) want = .false.
    end_reason = END_STEPS
    do nstep = 1, ARC_MAX_STEPS
      if (.not. any(want .and. .not. found)) then
        end_reason = END_NONE
        exit
      end if
      call arc_step(sys, w, t, h, opts, wn, tn, it, ok)
      if (.not. ok) then
        h = h/2
        if (h < 1.0e-6_wp*h0) then
          end_reason = END_NOCONV
          exit
        end if
        cycle
      end if
      naccept = naccept + 1
      e_now = model%energy(wn(1:d))
      g_now = slope(wn, tn)
      if (sgn0 == 0) then         ! a branch: its side of the start energy
        sgn0 = merge(1, -1, e_now >= e_start)
        where ((e_sad + des - e_start)*sgn0 < 0) want = .false.
        if (.not. any(want)) then
          end_reason = END_NOTBRANCH
          exit
        end if
      end if
      ! a fold inside this step (not in a branch's first: at the bifurcation dE/ds = 0, the energy
      ! moving quadratically off it, so the sign there is noise)
      if (g_now*g_prev < 0 .and. .not. (dir == 0 .and. naccept == 1)) then
        call locate_fold(w, t, h, g_prev, wf, tf, hf, fo)
        folds = [folds, fo]
        nfold = nfold + 1
        ef = model%energy(wf(1:d))
        call take(0.0_wp, hf, w, e_prev, wf, ef)
        if (stat < 0) return
        if (present(end_at_fold)) then
          if (end_at_fold) then
            end_reason = END_FOLD
            e_prev = ef
            exit
          end if
        end if
        ! a branch's arc back at its start's energy at a fold: the start is the bifurcation, where
        ! the energy is extremal, and the arc has come round to it (the branch and its mirror image
        ! close into a loop, as the axial family through the vertical and planar families' branch
        ! points): the energies it has not taken are not on it
        if (dir == 0 .and. nfold >= 2 .and. abs(ef - e_start) <= 1.0e-8_wp*max(abs(e_start - e_sad), &
            abs(e_start - e_prev), tiny(1.0_wp))) then
          end_reason = END_LOOP
          e_prev = ef
          exit
        end if
        call take(hf, h, wf, ef, wn, e_now)
      else
        call take(0.0_wp, h, w, e_prev, wn, e_now)
      end if
      if (stat < 0) return
      e_prev = e_now
      g_prev = g_now
      w = wn
      t = tn
      if (w(nw) > opts%period_max*w0(nw)) then
        end_reason = END_PERIOD
        exit
      end if
      if (nfold > 0 .and. (e_now - e_start)*sgn0 < 0) then
        end_reason = END_RETURN
        exit
      end if
      if (it <= 3) h = min(1.5_wp*h, 20*h0)
    end do
    if (end_reason /= END_NONE) end_de = e_prev - e_sad
    where (want .and. .not. found) want = .false.   ! said by their orbits (not converged)
    stat = TUBES_OK
  contains
    real(wp) function slope(u, tu)   ! dE/ds along the arc: grad H(x_1) . t's first node
      real(wp), intent(in) :: u(:), tu(:)
      real(wp) :: gr(d)
      integer :: st
      call model%gradient(u(1:d), gr, st)
      slope = dot_product(gr, tu(1:d))
      if (st /= 0) slope = 0
    end function slope

    subroutine locate_fold(wa, ta, ha, ga, wf, tf, hf, fo)   ! bisection in the step's length
      real(wp), intent(in) :: wa(:), ta(:), ha, ga
      real(wp), intent(out) :: wf(:), tf(:), hf        ! the fold's point, tangent and step length

      type(fold_t), intent(out) :: fo
      real(wp) :: lo, hi, mid, wm(size(wa)), tm(size(wa)), phi(d, d), xe(d)
      integer :: itf, st
      logical :: okm
      lo = 0
      hi = ha
      wf = wn
      tf = tn
      hf = ha
      do while (hi - lo > 1.0e-9_wp*ha)
        mid = lo + (hi - lo)/2
        call arc_step(sys, wa, ta, mid, opts, wm, tm, itf, okm)
        if (.not. okm) exit
        if (slope(wm, tm)*ga > 0) then
          lo = mid
        else
          hi = mid
          wf = wm
          tf = tm
          hf = mid
        end if
      end do
      mid = lo + (hi - lo)/2
      call arc_step(sys, wa, ta, mid, opts, wm, tm, itf, okm)
      if (okm) then
        wf = wm
        tf = tm
        hf = mid
      end if
      fo%de = model%energy(wf(1:d)) - e_sad
      fo%period = wf(nw)
      fo%width = hi - lo
      fo%x0 = wf(1:d)
      fo%tangent = tf(1:d)/max(sqrt(sum(tf(1:d)**2)), tiny(1.0_wp))
      call flow_stm(model, fo%x0, fo%period, opts, xe, phi, st)
      fo%monodromy = phi
    end subroutine locate_fold

    ! the wanted energies between ea and eb, the arc's points a step of length ha and hb along t from w,
    ! each from the arc's own point at its energy (arc_point_at)
    subroutine take(ha, hb, wa, ea, wb, eb)
      real(wp), intent(in) :: ha, hb, wa(:), ea, wb(:), eb
      real(wp) :: wc(size(wa)), nodes(d, n), period, ek
      integer :: k, st
      do k = 1, size(des)
        if (.not. want(k) .or. found(k)) cycle
        ek = e_sad + des(k)
        if (ek < min(ea, eb) .or. ek > max(ea, eb)) cycle
        call arc_point_at(sys, model, ev1, w, t, ha, hb, ea, eb, wa, wb, ek, opts, wc)
        nodes = reshape(wc(1:d*n), [d, n])
        period = wc(nw)
        found(k) = .true.
        call correct_multiple(model, ek, des(k), nodes, period, opts, orbits(k), st)
        orbits(k)%de = des(k)
        if (st < 0 .and. st /= TUBES_ENOCONV) then
          stat = st
          return
        end if
        if (st == TUBES_OK) call finish_orbit(model, orbits(k), opts, eqs, isad, st)
        if (st < 0 .and. st /= TUBES_ENOCONV) then
          stat = st
          return
        end if
        if (st /= TUBES_OK) orbits(k)%converged = .false.
        if (dir == 0 .and. orbits(k)%converged) &      ! a branch: its orbits on it
          call check_on_branch(orbits(k), [reshape(nodes, [d*n]), period], wc, w0, 0, 0, 0.0_wp)
      end do
    end subroutine take
  end subroutine arc_run

  !> The family through a guess (opts%guess, opts%guess_period; docs/orbits.md, "Orbits from a
  !> guess"): n = opts%n_segments nodes along the guess's trajectory over guess_period, corrected
  !> by correct_multiple at the guess's own energy H(guess) (no symmetry assumed), then continued
  !> by pseudo-arclength in (nodes, T), the energy free (arc_run): upwards in energy to the
  !> requested energies at or above H(guess), downwards to those below it. A guess that does not
  !> converge: end_reason END_NOGUESS, no orbit.
  subroutine guess_family(model, eqs, isad, des, opts, orbits, end_de, end_reason, folds, stat)
    class(hamiltonian_t), intent(in) :: model
    type(equilibrium_t), intent(in) :: eqs(:)
    integer, intent(in) :: isad
    real(wp), intent(in) :: des(:)
    type(orbit_opts_t), intent(in) :: opts
    type(orbit_t), intent(out) :: orbits(size(des))
    real(wp), intent(out) :: end_de
    integer, intent(out) :: end_reason, stat
    type(fold_t), allocatable, intent(inout) :: folds(:)
    type(shooting_arc_t) :: sys
    type(orbit_t) :: ob
    real(wp), allocatable :: nodes(:, :), w0(:), t0(:), f(:), jac(:, :), gr(:)
    real(wp) :: e0, period, ede
    integer :: n2, ns, info, reason, k
    logical :: want(size(des))
    n2 = model%dim()
    ns = max(opts%n_segments, 1)
    end_de = -1
    end_reason = END_NONE
    do k = 1, size(des)
      orbits(k)%de = des(k)
    end do
    stat = TUBES_EINPUT
    if (size(opts%guess) /= n2 .or. .not. opts%guess_period > 0) return
    e0 = model%energy(opts%guess)
    allocate (nodes(n2, ns))
    call nodes_from(model, opts%guess, opts%guess_period, ns, opts, nodes, stat)
    period = opts%guess_period
    if (stat == TUBES_OK) call correct_multiple(model, e0, e0 - eqs(isad)%energy, nodes, period, opts, ob, stat)
    if (stat /= TUBES_OK) then
      end_reason = END_NOGUESS
      stat = TUBES_OK
      return
    end if
    allocate (sys%model, source=model)
    sys%opts = opts
    sys%n = ns
    if (ns == 1) sys%n_raw = n2
    w0 = [reshape(nodes, [n2*ns]), period]
    call sys%rows(w0, w0, f, jac, stat)
    if (stat /= TUBES_OK) then
      end_reason = END_NOGUESS
      stat = TUBES_OK
      return
    end if
    allocate (t0(size(w0)), gr(n2))
    call null_vector(jac, t0, info)
    call model%gradient(w0(1:n2), gr, stat)
    if (info /= 0 .or. stat /= 0) then
      end_reason = END_NOGUESS
      stat = TUBES_OK
      return
    end if
    if (dot_product(gr, t0(1:n2)) < 0) t0 = -t0
    want = eqs(isad)%energy + des >= e0
    if (any(want)) then
      call arc_run(sys, model, eqs, isad, w0, t0, ns, 1, des, want, opts, orbits, end_de, end_reason, folds, stat)
      if (stat < 0) return
    end if
    want = eqs(isad)%energy + des < e0
    if (any(want)) then
      call arc_run(sys, model, eqs, isad, w0, -t0, ns, -1, des, want, opts, orbits, ede, reason, folds, stat)
      if (stat < 0) return
      if (end_reason == END_NONE) then
        end_de = ede
        end_reason = reason
      end if
    end if
  end subroutine guess_family

  !> The family branching off a parent family's orbit (x0, period) at a bifurcation whose
  !> multiplier is sgn (+1 a branch point, -1 a period doubling) along the monodromy's
  !> eigenvector v (floquet_tangent; docs/orbits.md, "Branch switching"): n = opts%n_segments
  !> nodes along the orbit over T' = period (sgn = +1) or 2 period (sgn = -1), the tangent
  !> phi(t_i) v at node i (the period's component 0), continued by pseudo-arclength (arc_run) to
  !> the requested energies on the side the first step goes to.
  subroutine branch_arc(model, eqs, isad, x0, period, v, sgn, des, opts, orbits, end_de, end_reason, folds, stat, &
                        end_at_fold)
    class(hamiltonian_t), intent(in) :: model
    type(equilibrium_t), intent(in) :: eqs(:)
    integer, intent(in) :: isad, sgn
    real(wp), intent(in) :: x0(:), period, v(:), des(:)
    type(orbit_opts_t), intent(in) :: opts
    type(orbit_t), intent(out) :: orbits(size(des))
    real(wp), intent(out) :: end_de
    integer, intent(out) :: end_reason, stat
    type(fold_t), allocatable, intent(inout) :: folds(:)
    logical, intent(in), optional :: end_at_fold   !! stop at the first fold (arc_run)
    type(shooting_arc_t) :: sys
    real(wp), allocatable :: nodes(:, :), w0(:), t0(:)
    real(wp) :: tp, xx(size(x0)), phi(size(x0), size(x0))
    integer :: n2, ns, i, k
    logical :: want(size(des))
    n2 = size(x0)
    ns = max(opts%n_segments, 1)
    end_de = -1
    end_reason = END_NONE
    do k = 1, size(des)
      orbits(k)%de = des(k)
    end do
    tp = merge(1, 2, sgn > 0)*period
    allocate (nodes(n2, ns), t0(n2*ns + 1))
    call nodes_from(model, x0, tp, ns, opts, nodes, stat)
    if (stat /= TUBES_OK) return
    t0 = 0
    t0(1:n2) = v
    do i = 2, ns
      call flow_stm(model, x0, (i - 1)*tp/ns, opts, xx, phi, stat)
      if (stat /= TUBES_OK) return
      t0(n2*(i - 1) + 1:n2*i) = matmul(phi, v)
    end do
    t0 = t0/sqrt(sum(t0**2))
    allocate (sys%model, source=model)
    sys%opts = opts
    sys%n = ns
    if (ns == 1) sys%n_raw = n2
    w0 = [reshape(nodes, [n2*ns]), tp]
    want = .true.
    call arc_run(sys, model, eqs, isad, w0, t0, ns, 0, des, want, opts, orbits, end_de, end_reason, folds, stat, &
                 end_at_fold)
  end subroutine branch_arc

  !> The saddle's centre mode of a family by name (code FAMILY_VERTICAL or FAMILY_PLANAR; docs/orbits.md,
  !> "Branch switching"): in 3 DOF (nd = 3) 'vertical' is the centre mode whose eigenvector (Re and Im
  !> parts, evec(:, 2j+1:2j+2)) has all its weight on (q_N, p_N) (to 1e-8 of its square norm), and
  !> 'lyapunov' the planar one, with none there, when a vertical one exists; in 1 or 2 DOF 'lyapunov'
  !> is family 1 and 'vertical' does not exist. 0 when the modes do not define the family.
  pure integer function named_mode(sad, nd, code) result(j)
    type(equilibrium_t), intent(in) :: sad
    integer, intent(in) :: nd, code
    real(wp) :: wt, tot
    integer :: k, jv, jp
    j = 0
    if (code == FAMILY_PLANAR .and. nd <= 2) j = 1   ! as family = 1, whatever that gives
    if (nd /= 3 .or. .not. allocated(sad%evec) .or. .not. allocated(sad%omegas)) return
    if (size(sad%evec, 2) < 2*nd) return
    jv = 0
    jp = 0
    do k = 1, size(sad%omegas)
      if (.not. sad%omegas(k) > 0) cycle
      tot = sum(sad%evec(:, 2*k + 1:2*k + 2)**2)
      wt = sum(sad%evec([nd, 2*nd], 2*k + 1:2*k + 2)**2)
      if (.not. tot > 0) cycle
      if (wt >= (1 - 1.0e-8_wp)*tot) jv = k
      if (wt <= 1.0e-8_wp*tot) jp = k
    end do
    if (jv == 0) return
    if (code == FAMILY_VERTICAL) j = jv
    if (code == FAMILY_PLANAR) j = jp
  end function named_mode

  !> The tilt of the branch leaving the orbit (x0, period) along v (a unit tangent of its state):
  !> the mean over the period of q_2(t) (phi(t) v)_N, the first-order change of the mean of
  !> q_2 q_N when q_N = 0 on the orbit (64 samples; docs/orbits.md, "Branch switching": 'axial' is
  !> the side of positive tilt). stat < 0 for a fault of the integration.
  real(wp) function tilt_of(model, x0, period, v, opts, stat) result(tl)
    class(hamiltonian_t), intent(in) :: model
    real(wp), intent(in) :: x0(:), period, v(:)
    type(orbit_opts_t), intent(in) :: opts
    integer, intent(out) :: stat
    integer, parameter :: M = 64
    real(wp) :: x(size(x0)), y(size(x0)), dv(size(x0)), phi(size(x0), size(x0))
    integer :: k, nd
    nd = size(x0)/2
    tl = 0
    x = x0
    dv = v
    stat = TUBES_OK
    do k = 1, M
      tl = tl + x(2)*dv(nd)/M
      call flow_stm(model, x, period/M, opts, y, phi, stat)
      if (stat < 0) return
      x = y
      dv = matmul(phi, dv)
    end do
    stat = TUBES_OK
  end function tilt_of

  !> The unit null vector of the m x n matrix a of rank n - 1 (m x (m + 1) of full rank m, or square
  !> with a one-dimensional null space): the eigenvector of a^T a for its smallest eigenvalue.
  subroutine null_vector(a, v, info)
    real(wp), intent(in) :: a(:, :)
    real(wp), intent(out) :: v(:)
    integer, intent(out) :: info
    real(wp) :: g(size(a, 2), size(a, 2)), w(size(a, 2)), work(66*size(a, 2))
    g = matmul(transpose(a), a)
    call dsyev('V', 'U', size(g, 1), g, size(g, 1), w, work, size(work), info)
    v = g(:, 1)
  end subroutine null_vector

  !> Append the orbit at de (and, when it did not converge, where the family ends) to p.
  subroutine keep_orbit(p, de, orb, end_de, end_reason)
    type(family_path_t), intent(inout) :: p
    real(wp), intent(in) :: de, end_de
    type(orbit_t), intent(in) :: orb
    integer, intent(in) :: end_reason
    type(orbit_t), allocatable :: orbs(:)
    integer :: n
    n = size(p%des)
    allocate (orbs(n + 1))
    orbs(1:n) = p%orbs
    orbs(n + 1) = orb
    call move_alloc(orbs, p%orbs)
    p%des = [p%des, de]
    p%end_de = [p%end_de, end_de]
    p%end_reason = [p%end_reason, end_reason]
  end subroutine keep_orbit

  !> The continuation to de alone, from the state before the ladder's first step that would pass
  !> de (for de < 1/4, from a start of its own: the first step is sqrt(de)). The ladder grows on p
  !> as needed. orb%converged = .false. where the family ends first (end_de, end_reason).
  subroutine continue_to(model, eqs, isad, de, opts, p, orb, end_de, end_reason)
    class(hamiltonian_t), intent(in) :: model
    type(equilibrium_t), intent(in) :: eqs(:)
    integer, intent(in) :: isad
    real(wp), intent(in) :: de
    type(orbit_opts_t), intent(in) :: opts
    type(family_path_t), intent(inout) :: p
    type(orbit_t), intent(out) :: orb
    real(wp), intent(out) :: end_de
    integer, intent(out) :: end_reason
    type(cont_state_t) :: c
    type(cont_state_t), allocatable :: grown(:)
    real(wp) :: s_target
    integer :: j, n
    logical :: hit
    end_de = -1
    end_reason = END_NONE
    s_target = sqrt(de)
    if (p%s_start == 0) p%s_start = start_step(model, eqs, isad)
    if (s_target < p%s_start) then
      c = cont_start(model, s_target)
    else
      if (.not. allocated(p%ladder)) then
        allocate (p%ladder(1))
        p%ladder(1) = cont_start(model, p%s_start)
      end if
      j = 1
      do
        if (j > size(p%ladder)) then   ! one more step of the ladder
          n = size(p%ladder)
          c = p%ladder(n)
          call cont_step(model, eqs, isad, opts, c, huge(1.0_wp), orb, hit)
          allocate (grown(n + 1))
          grown(1:n) = p%ladder
          grown(n + 1) = c
          call move_alloc(grown, p%ladder)
        end if
        if (p%ladder(j)%ended .or. p%ladder(j)%s > s_target .or. &
            abs(p%ladder(j)%s - s_target) <= 1.0e-14_wp*s_target) exit
        j = j + 1
      end do
      c = p%ladder(j)
    end if
    do while (.not. c%ended)
      call cont_step(model, eqs, isad, opts, c, s_target, orb, hit)
      if (hit) return
    end do
    ! the family ended before de: estimate the limit from the last periods
    if (c%last_min_eq < 0.05_wp*model%length_scale() .and. c%end_reason /= END_PERIOD) &
      c%end_reason = END_EQUILIBRIUM
    if (c%end_reason == END_NOCONV .and. c%nhist == 3) c%end_reason = END_PERIOD
    end_de = limit_estimate(c%hist_s, c%hist_t, c%nhist, c%s_last)
    end_reason = c%end_reason
    orb = orbit_t(de=de)
  end subroutine continue_to

  !> The continuation's first step in s = sqrt(de): S_START, or less where the linear orbit's
  !> amplitude there would exceed START_AMP of the distance from the saddle to the nearest other
  !> equilibrium (the model's length scale if there is none): a family is continued from small
  !> amplitudes in the model's own units (docs/orbits.md, "One family, each orbit once").
  real(wp) function start_step(model, eqs, isad) result(s0)
    class(hamiltonian_t), intent(in) :: model
    type(equilibrium_t), intent(in) :: eqs(:)
    integer, intent(in) :: isad
    real(wp) :: x0(model%dim()), tau, dist, amp
    integer :: k
    dist = huge(1.0_wp)
    do k = 1, size(eqs)
      if (k /= isad) dist = min(dist, sqrt(sum((eqs(k)%q - eqs(isad)%q)**2)))
    end do
    if (dist == huge(1.0_wp)) dist = model%length_scale()
    call linear_guess(model, eqs(isad), 1.0_wp, x0, tau)   ! the amplitude at de = 1 (s = 1)
    amp = sqrt(sum((x0(1:size(eqs(isad)%q)) - eqs(isad)%q)**2))
    s0 = S_START
    if (amp > 0) s0 = min(S_START, START_AMP*dist/amp)
  end function start_step

  !> The continuation's state at its start: the first step to s0 = sqrt(de) from the saddle.
  function cont_start(model, s0) result(c)
    class(hamiltonian_t), intent(in) :: model
    real(wp), intent(in) :: s0
    type(cont_state_t) :: c
    c%s = s0
    c%ds = s0
    allocate (c%xa(model%dim()), c%xb(model%dim()))
    c%xa = 0
    c%xb = 0
  end function cont_start

  !> One attempt of the continuation from state c, at c%s or at s_target where c%s passes it:
  !> predictor, corrector, and the step's acceptance and next size. hit: the attempt was
  !> accepted at s_target (orb is the orbit there).
  subroutine cont_step(model, eqs, isad, opts, c, s_target, orb, hit)
    class(hamiltonian_t), intent(in) :: model
    type(equilibrium_t), intent(in) :: eqs(:)
    integer, intent(in) :: isad
    type(orbit_opts_t), intent(in) :: opts
    type(cont_state_t), intent(inout) :: c
    real(wp), intent(in) :: s_target
    type(orbit_t), intent(out) :: orb
    logical, intent(out) :: hit
    real(wp) :: s, tau, t_pred, t_po, x0(model%dim())
    real(wp), allocatable :: nodes(:, :)
    integer :: st, rev(model%dim())
    hit = .false.
    s = c%s
    if (s > s_target) s = s_target
    ! predictor
    if (c%have_prev) then
      x0 = c%xb + (c%xb - c%xa)*(s - c%s_last)/(c%s_last - c%s_prev)
      tau = c%tb + (c%tb - c%ta)*(s - c%s_last)/(c%s_last - c%s_prev)
      ! multiple shooting: the secant on every node, not the nodes integrated from x0 over the
      ! period (their last mismatch is the whole period's closure, x0's error amplified by the
      ! monodromy's norm, ~1e7 on the Sun-Jupiter L1 family at dE = 0.04)
      if (allocated(c%na) .and. allocated(c%nb)) then
        nodes = c%nb + (c%nb - c%na)*(s - c%s_last)/(c%s_last - c%s_prev)
        if (has_reversor(model)) then   ! the first node on the fixed set, as x0
          rev = model%reversor()
          where (rev < 0) nodes(:, 1) = 0
        end if
      end if
    else if (c%s_last > 0) then
      x0 = c%xb + (c%xb - eqs(isad)%x)*(s - c%s_last)/c%s_last
      tau = c%tb
    else
      call linear_guess(model, eqs(isad), s*s, x0, tau)
    end if
    t_pred = 2*tau
    call solve_orbit(model, eqs(isad), s*s, x0, tau, opts, eqs, isad, orb, st, nodes)
    t_po = 2*PI/eqs(isad)%omega
    if (st == TUBES_OK .and. orb%period > opts%period_max*t_po) then
      c%end_reason = END_PERIOD
      st = TUBES_ENOCONV
    end if
    ! the corrector may converge to another family past the end: accept only an orbit close
    ! to the prediction (period within 10 % of the predicted change + 1 % of T)
    if (st == TUBES_OK .and. c%have_prev) then
      if (abs(orb%period - t_pred) > 0.1_wp*abs(t_pred - c%tb*2) + 0.01_wp*c%tb*2) st = TUBES_ENOCONV
    end if
    c%last_min_eq = orb%min_eq_distance
    if (st /= TUBES_OK) then
      c%ds = c%ds/4
      c%s = c%s_last + c%ds
      if (c%ds < 1.0e-6_wp*max(c%s_last, 1.0e-3_wp)) then
        if (c%end_reason == END_NONE) c%end_reason = END_NOCONV
        c%ended = .true.
      end if
      return
    end if
    ! accepted
    c%nhist = min(c%nhist + 1, 3)
    c%hist_s = [c%hist_s(2:3), s]
    c%hist_t = [c%hist_t(2:3), orb%period]
    if (c%s_last > 0) c%have_prev = .true.
    c%s_prev = c%s_last; c%xa = c%xb; c%ta = c%tb
    c%s_last = s; c%xb = x0; c%tb = tau
    if (allocated(nodes)) then   ! multiple shooting
      if (allocated(c%nb)) call move_alloc(c%nb, c%na)
      call move_alloc(nodes, c%nb)
    end if
    hit = abs(s - s_target) <= 1.0e-14_wp*s_target
    if (orb%iterations <= 4) then
      c%ds = min(2*c%ds, 0.25_wp*s + 0.1_wp)
    else if (orb%iterations > 8) then
      c%ds = c%ds/2
    end if
    c%s = c%s_last + c%ds
  end subroutine cont_step
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
