!> The model layer: an autonomous Hamiltonian system with N degrees of freedom, state
!> x = (q_1..q_N, p_1..p_N). Every analysis (equilibria, orbits, tubes, transport) sees a model
!> only through hamiltonian_t; integrators see it as a vector_field_t. Theory: docs/theory.md,
!> "The model layer"; the library of systems: docs/models.md.
!>
!> - hamiltonian_t: H, its gradient and Hessian (analytic in every built-in model), the
!>   dimension, coordinate names; Hamilton's equations dx/dt = J grad H and their Jacobian
!>   J Hess H by default (models may override them with faster or more accurate forms).
!> - natural_t: H = T(q, p) + V(q), T = 1/2 p^T A(q) p positive definite, so that rest points
!>   have p = 0, brake orbits, zero-velocity curves and releases from rest make sense.
!>   V = potential_scale() * shape(q) (the rolling ball: g times the surface's height; 1 for
!>   the others): rest points are the critical points of shape, with V's Morse index.
!> - damped_t: any Hamiltonian with the viscous force -c p added to dp/dt (not Hamiltonian:
!>   a vector field for integration only, dE/dt = -c p . dH/dp).
module tubes_hamiltonian
  use, intrinsic :: iso_fortran_env, only: int64
  use tubes_kinds, only: wp
  use tubes_lapack, only: dgesv
  use tubes_field, only: vector_field_t, jet_spec_t
  use tubes_status, only: TUBES_OK, TUBES_EINPUT, TUBES_ENOCONV
  implicit none
  private

  integer, parameter, public :: NAMES_GENERIC = 0    !! W/S/R + number by energy (docs/models.md)
  integer, parameter, public :: NAMES_QUADRANT = 1   !! the four-well: W<quadrant>, S<ij>, R<k>
  integer, parameter, public :: NAMES_LAGRANGE = 2   !! the CR3BP: L1..L5

  integer, parameter, public :: LEN_NAME = 16        !! length of coordinate names
  !> |q|_1 beyond this is a blown-up (escaped) state: the models refuse it
  real(wp), parameter, public :: BLOWUP_Q = 1.0e6_wp
  !> State dimension 2N at most for the default eval and Jacobian: fixed-size locals there,
  !> since gfortran puts automatic arrays on the heap (one malloc per right-hand side)
  integer, parameter :: MAX_STATE = 16

  !> An autonomous Hamiltonian H(q, p) with N degrees of freedom.
  type, abstract, extends(vector_field_t), public :: hamiltonian_t
    !> the model as a formula (a tubes-expression spec, set by the library's constructors in
    !> src/models/tubes_models.f90): the Taylor method's jet is generated from it
    character(:), allocatable :: formula
    integer :: nd = 2   !! N, the degrees of freedom (a model's constructor sets it when not 2)
  contains
    procedure :: ndof => ham_ndof                   !! N
    procedure(energy_i), deferred :: energy         !! H(x)
    procedure(gradient_i), deferred :: gradient     !! dH/dx (2N)
    procedure(hessian_i), deferred :: hessian       !! d2H/dx2 (2N x 2N)
    procedure :: dim => ham_dim                     !! 2N
    procedure :: eval => ham_eval                   !! J grad H
    procedure :: jacobian => ham_jacobian           !! J Hess H
    procedure :: coordinate_name => ham_coordinate_name  !! 'q1'.. 'p1'.. unless overridden
    procedure :: is_natural => ham_is_natural       !! .false. unless natural_t
    procedure :: naming => ham_naming               !! NAMES_* scheme of its equilibria
    procedure :: length_scale => ham_length_scale   !! typical configuration distance [units of q]
    procedure :: reversor => ham_reversor           !! +1/-1 per component: a time-reversal symmetry
    procedure :: rest_momenta => ham_rest_momenta   !! p with dH/dp(q, p) = 0 (zero velocity)
    procedure :: jet_spec => ham_jet_spec           !! its formula, if it has one
    procedure :: jacobi_factor => ham_jacobi_factor !! C = factor H (0: no Jacobi constant)
  end type hamiltonian_t

  !> A natural system H = 1/2 p^T A(q) p + potential_scale() shape(q).
  type, abstract, extends(hamiltonian_t), public :: natural_t
  contains
    procedure(shape_i), deferred :: shape               !! shape(q)
    procedure(shape_derivs_i), deferred :: shape_derivs !! its gradient and Hessian
    procedure(kinetic_i), deferred :: kinetic_matrix    !! A(q) = d2T/dp2
    procedure :: rest_kinetic_matrix => nat_rest_kinetic !! A at a rest point (grad V = 0)
    procedure :: potential => nat_potential             !! V(q)
    procedure :: potential_scale => nat_potential_scale !! V / shape (> 0)
    procedure :: is_natural => nat_is_natural
    procedure :: rest_momenta => nat_rest_momenta       !! p = 0
    procedure :: reversor => nat_reversor               !! (q, p, t) -> (q, -p, -t)
  end type natural_t

  !> A natural system with constant diagonal masses, H = sum_i p_i^2/(2 m_i) + shape(q): its
  !> energy, gradient, Hessian and kinetic matrix from the masses and the shape (a model gives
  !> masses, shape and shape_derivs). A state with |q|_1 > BLOWUP_Q is refused (stat -1).
  type, abstract, extends(natural_t), public :: separable_t
  contains
    procedure(masses_i), deferred :: masses          !! m_i, i = 1..N
    procedure :: energy => sep_energy
    procedure :: gradient => sep_gradient
    procedure :: hessian => sep_hessian
    procedure :: kinetic_matrix => sep_kinetic
  end type separable_t

  !> A separable system of two modes with masses m_a (x) and m_b (y): the masses written once for
  !> tubes_coupled_quartic and tubes_de_leon_berne.
  type, abstract, extends(separable_t), public :: two_mode_t
    real(wp) :: m_a   !! mass of the x mode
    real(wp) :: m_b   !! mass of the y mode
  contains
    procedure :: masses => two_mode_masses
  end type two_mode_t

  !> Dissipation on the momenta of a Hamiltonian model: viscous damping -c p, and rolling
  !> resistance, a force of magnitude f opposing the velocity in the kinetic metric, -f sigma p /
  !> sqrt(s^2 + v_reg^2) with s^2 = sigma p . dH/dp the squared path speed (sigma = 1/m_eff: 5/7
  !> for the ball, whose p = (7/5) M v; docs/dissipation.md): dE/dt = -2 c T - f s^2/sqrt(s^2 +
  !> v_reg^2), an energy loss of f per unit path length where s >> v_reg.
  type, extends(vector_field_t), public :: damped_t
    class(hamiltonian_t), allocatable :: base   !! the conservative model
    real(wp) :: c = 0                           !! damping rate [1/time]
    real(wp) :: f = 0                           !! rolling drag [length/time^2] (0: none)
    real(wp) :: sigma = 1                       !! 1/m_eff of the path speed
    real(wp) :: v_reg = 0                       !! regularisation speed at rest [length/time]
    !> white noise on the momenta, dp = ... dt + S(q) dW: S S^T = 2 noise I, or with temperature > 0
    !> the fluctuation-dissipation relation S S^T = 2 c temperature A(q)^-1 (A = d2H/dp2); an
    !> integrator of this field is then the stochastic one (tubes_sde)
    real(wp) :: noise = 0                       !! D [momentum^2/time]
    real(wp) :: temperature = 0                 !! theta [energy] (with c > 0)
    real(wp) :: h_noise = 0                     !! the stochastic method's default step [time]
    integer(int64) :: seed = 0                  !! the noise's key (the run's seed)
  contains
    procedure :: dim => damped_dim
    procedure :: eval => damped_eval
    procedure :: jacobian => damped_jacobian
    procedure :: jet_spec => damped_jet_spec
    procedure :: noisy => damped_noisy
    procedure :: noise_factor => damped_noise_factor
  end type damped_t

  public :: make_damped, quadratic_parts, veff, quadratic_in_p
  public :: jacobi_of_energy, energy_of_jacobi

  abstract interface
    pure real(wp) function energy_i(self, x)
      import :: hamiltonian_t, wp
      class(hamiltonian_t), intent(in) :: self
      real(wp), intent(in) :: x(:)      !! (q, p)
    end function energy_i
    pure subroutine gradient_i(self, x, g, stat)
      import :: hamiltonian_t, wp
      class(hamiltonian_t), intent(in) :: self
      real(wp), intent(in) :: x(:)
      real(wp), intent(out) :: g(:)     !! dH/dx_i
      integer, intent(out) :: stat      !! 0, or -1 where H is not defined (NaN, singularity)
    end subroutine gradient_i
    pure subroutine hessian_i(self, x, h, stat)
      import :: hamiltonian_t, wp
      class(hamiltonian_t), intent(in) :: self
      real(wp), intent(in) :: x(:)
      real(wp), intent(out) :: h(:, :)  !! d2H/dx_i dx_j
      integer, intent(out) :: stat
    end subroutine hessian_i
    pure real(wp) function shape_i(self, q)
      import :: natural_t, wp
      class(natural_t), intent(in) :: self
      real(wp), intent(in) :: q(:)
    end function shape_i
    pure subroutine shape_derivs_i(self, q, grad, hess)
      import :: natural_t, wp
      class(natural_t), intent(in) :: self
      real(wp), intent(in) :: q(:)
      real(wp), intent(out) :: grad(:), hess(:, :)
    end subroutine shape_derivs_i
    pure subroutine kinetic_i(self, q, a)
      import :: natural_t, wp
      class(natural_t), intent(in) :: self
      real(wp), intent(in) :: q(:)
      real(wp), intent(out) :: a(:, :)   !! T = 1/2 p^T a p
    end subroutine kinetic_i
    pure subroutine masses_i(self, m)
      import :: separable_t, wp
      class(separable_t), intent(in) :: self
      real(wp), intent(out) :: m(:)      !! m_i (N)
    end subroutine masses_i
  end interface

contains

  pure integer function ham_ndof(self)
    class(hamiltonian_t), intent(in) :: self
    ham_ndof = self%nd
  end function ham_ndof

  pure integer function ham_dim(self)
    class(hamiltonian_t), intent(in) :: self
    ham_dim = 2*self%ndof()
  end function ham_dim

  !> dq/dt = dH/dp, dp/dt = -dH/dq.
  pure subroutine ham_eval(self, t, x, dxdt, stat)
    class(hamiltonian_t), intent(in) :: self
    real(wp), intent(in)  :: t, x(:)
    real(wp), intent(out) :: dxdt(:)
    integer, intent(out)  :: stat
    real(wp) :: g(MAX_STATE)
    integer :: n
    n = size(x)/2
    if (2*n > MAX_STATE) error stop '[tubes_hamiltonian:ham_eval] more than 8 degrees of freedom'
    call self%gradient(x, g(1:2*n), stat)
    dxdt(1:n) = g(n + 1:2*n)
    dxdt(n + 1:2*n) = -g(1:n)
    if (stat == 0 .and. .not. all(abs(dxdt(1:2*n)) <= huge(1.0_wp))) stat = -1
  end subroutine ham_eval

  !> Jacobian of Hamilton's equations: J Hess H.
  pure subroutine ham_jacobian(self, t, x, jac, stat)
    class(hamiltonian_t), intent(in) :: self
    real(wp), intent(in)  :: t, x(:)
    real(wp), intent(out) :: jac(:, :)
    integer, intent(out)  :: stat
    real(wp) :: h(MAX_STATE, MAX_STATE)
    integer :: n
    n = size(x)/2
    if (2*n > MAX_STATE) error stop '[tubes_hamiltonian:ham_jacobian] more than 8 degrees of freedom'
    call self%hessian(x, h(1:2*n, 1:2*n), stat)
    jac(1:n, 1:2*n) = h(n + 1:2*n, 1:2*n)
    jac(n + 1:2*n, 1:2*n) = -h(1:n, 1:2*n)
    if (stat == 0 .and. .not. all(abs(jac(1:2*n, 1:2*n)) <= huge(1.0_wp))) stat = -1
  end subroutine ham_jacobian

  !> x, y, (z), px, py, (pz) for N <= 3; q1..qN, p1..pN beyond.
  pure function ham_coordinate_name(self, k) result(name)
    class(hamiltonian_t), intent(in) :: self
    integer, intent(in) :: k          !! 1..2N
    character(LEN_NAME) :: name
    character(1), parameter :: XYZ(3) = ['x', 'y', 'z']
    integer :: n
    n = self%ndof()
    if (n <= 3) then
      if (k <= n) then
        name = XYZ(k)
      else
        name = 'p'//XYZ(k - n)
      end if
    else if (k <= n) then
      write (name, '(a,i0)') 'q', k
    else
      write (name, '(a,i0)') 'p', k - n
    end if
  end function ham_coordinate_name

  pure logical function ham_is_natural(self)
    class(hamiltonian_t), intent(in) :: self
    ham_is_natural = .false.
  end function ham_is_natural

  pure integer function ham_naming(self)
    class(hamiltonian_t), intent(in) :: self
    ham_naming = NAMES_GENERIC
  end function ham_naming

  pure real(wp) function ham_length_scale(self)
    class(hamiltonian_t), intent(in) :: self
    ham_length_scale = 1
  end function ham_length_scale

  !> The Jacobi constant C = factor H of a model that defines one (the CR3BP: -2); 0 for a model
  !> that does not (the default). jacobi_of_energy and energy_of_jacobi are the only conversions.
  pure real(wp) function ham_jacobi_factor(self)
    class(hamiltonian_t), intent(in) :: self
    ham_jacobi_factor = 0
  end function ham_jacobi_factor

  !> The Jacobi constant at energy e: C = jacobi_factor e (0 for a model without one).
  pure real(wp) function jacobi_of_energy(model, e) result(c)
    class(hamiltonian_t), intent(in) :: model
    real(wp), intent(in) :: e
    c = model%jacobi_factor()*e
  end function jacobi_of_energy

  !> The energy at Jacobi constant c: E = c / jacobi_factor (a model with one only).
  pure real(wp) function energy_of_jacobi(model, c) result(e)
    class(hamiltonian_t), intent(in) :: model
    real(wp), intent(in) :: c
    e = c/model%jacobi_factor()
  end function energy_of_jacobi

  !> No known reversor: all zeros.
  pure function ham_reversor(self) result(r)
    class(hamiltonian_t), intent(in) :: self
    integer :: r(2*self%ndof())
    r = 0
  end function ham_reversor

  !> Momenta of zero velocity at q: dH/dp(q, p) = 0 by Newton from p (exact in one step when
  !> H is quadratic in p, as in every built-in model). stat = TUBES_ENOCONV if it fails.
  subroutine ham_rest_momenta(self, q, p, stat)
    class(hamiltonian_t), intent(in) :: self
    real(wp), intent(in) :: q(:)
    real(wp), intent(inout) :: p(:)     !! start, on return the rest momenta
    integer, intent(out) :: stat
    real(wp) :: x(2*size(q)), g(2*size(q)), h(2*size(q), 2*size(q)), a(size(q), size(q)), b(size(q))
    integer :: n, it, ipiv(size(q)), info
    n = size(q)
    do it = 1, 20
      x = [q, p]
      call self%gradient(x, g, stat)
      if (stat /= 0) return
      if (maxval(abs(g(n + 1:2*n))) <= 1.0e-14_wp*max(1.0_wp, maxval(abs(p)))) then
        stat = TUBES_OK
        return
      end if
      call self%hessian(x, h, stat)
      if (stat /= 0) return
      a = h(n + 1:2*n, n + 1:2*n)
      b = -g(n + 1:2*n)
      call dgesv(n, 1, a, n, ipiv, b, n, info)
      if (info /= 0) then
        stat = TUBES_ENOCONV
        return
      end if
      p = p + b
    end do
    stat = TUBES_ENOCONV
  end subroutine ham_rest_momenta

  pure real(wp) function sep_energy(self, x) result(e)
    class(separable_t), intent(in) :: self
    real(wp), intent(in) :: x(:)
    real(wp) :: m(MAX_STATE)
    integer :: n, i
    n = self%ndof()
    call self%masses(m(1:n))
    e = x(n + 1)**2/(2*m(1))
    do i = 2, n
      e = e + x(n + i)**2/(2*m(i))
    end do
    e = e + self%shape(x(1:n))
  end function sep_energy

  pure subroutine sep_gradient(self, x, g, stat)
    class(separable_t), intent(in) :: self
    real(wp), intent(in) :: x(:)
    real(wp), intent(out) :: g(:)
    integer, intent(out) :: stat
    real(wp) :: m(MAX_STATE), hs(MAX_STATE, MAX_STATE)
    integer :: n
    n = self%ndof()
    call self%masses(m(1:n))
    call self%shape_derivs(x(1:n), g(1:n), hs(1:n, 1:n))
    g(n + 1:2*n) = x(n + 1:2*n)/m(1:n)
    stat = 0
    if (.not. all(abs(g(1:2*n)) <= huge(1.0_wp)) .or. sum(abs(x(1:n))) > BLOWUP_Q) stat = -1
  end subroutine sep_gradient

  pure subroutine sep_hessian(self, x, h, stat)
    class(separable_t), intent(in) :: self
    real(wp), intent(in) :: x(:)
    real(wp), intent(out) :: h(:, :)
    integer, intent(out) :: stat
    real(wp) :: m(MAX_STATE), gr(MAX_STATE)
    integer :: n, i
    n = self%ndof()
    call self%masses(m(1:n))
    h(1:2*n, 1:2*n) = 0
    call self%shape_derivs(x(1:n), gr(1:n), h(1:n, 1:n))
    do i = 1, n
      h(n + i, n + i) = 1/m(i)
    end do
    stat = 0
    if (.not. all(abs(h(1:n, 1:n)) <= huge(1.0_wp)) .or. sum(abs(x(1:n))) > BLOWUP_Q) stat = -1
  end subroutine sep_hessian

  pure subroutine sep_kinetic(self, q, a)
    class(separable_t), intent(in) :: self
    real(wp), intent(in) :: q(:)
    real(wp), intent(out) :: a(:, :)
    real(wp) :: m(MAX_STATE)
    integer :: n, i
    n = self%ndof()
    call self%masses(m(1:n))
    a(1:n, 1:n) = 0
    do i = 1, n
      a(i, i) = 1/m(i)
    end do
  end subroutine sep_kinetic

  !> The masses of the two modes.
  pure subroutine two_mode_masses(self, m)
    class(two_mode_t), intent(in) :: self
    real(wp), intent(out) :: m(:)
    m(1:2) = [self%m_a, self%m_b]
  end subroutine two_mode_masses

  pure real(wp) function nat_potential(self, q)
    class(natural_t), intent(in) :: self
    real(wp), intent(in) :: q(:)
    nat_potential = self%potential_scale()*self%shape(q)
  end function nat_potential

  !> The kinetic matrix at a rest point q (grad V(q) = 0); models whose A(q) simplifies
  !> there override it.
  pure subroutine nat_rest_kinetic(self, q, a)
    class(natural_t), intent(in) :: self
    real(wp), intent(in) :: q(:)
    real(wp), intent(out) :: a(:, :)
    call self%kinetic_matrix(q, a)
  end subroutine nat_rest_kinetic

  pure real(wp) function nat_potential_scale(self)
    class(natural_t), intent(in) :: self
    nat_potential_scale = 1
  end function nat_potential_scale

  pure logical function nat_is_natural(self)
    class(natural_t), intent(in) :: self
    nat_is_natural = .true.
  end function nat_is_natural

  subroutine nat_rest_momenta(self, q, p, stat)
    class(natural_t), intent(in) :: self
    real(wp), intent(in) :: q(:)
    real(wp), intent(inout) :: p(:)
    integer, intent(out) :: stat
    p = 0
    stat = TUBES_OK
  end subroutine nat_rest_momenta

  !> (q, p) -> (q, -p): brake orbits are the orbits symmetric under it.
  pure function nat_reversor(self) result(r)
    class(natural_t), intent(in) :: self
    integer :: r(2*self%ndof())
    integer :: n
    n = self%ndof()
    r(1:n) = 1
    r(n + 1:2*n) = -1
  end function nat_reversor

  !> Wrap a conservative model with damping rate c (allocate with source=, see STYLE.md).
  subroutine make_damped(d, base, c)
    type(damped_t), intent(out) :: d
    class(hamiltonian_t), intent(in) :: base
    real(wp), intent(in) :: c    !! damping rate [1/time]
    allocate (d%base, source=base)
    d%c = c
  end subroutine make_damped

  pure integer function damped_dim(self)
    class(damped_t), intent(in) :: self
    damped_dim = self%base%dim()
  end function damped_dim

  pure subroutine damped_eval(self, t, x, dxdt, stat)
    class(damped_t), intent(in) :: self
    real(wp), intent(in)  :: t, x(:)
    real(wp), intent(out) :: dxdt(:)
    integer, intent(out)  :: stat
    integer :: n
    real(wp) :: r
    n = size(x)/2
    call self%base%eval(t, x, dxdt, stat)
    dxdt(n + 1:2*n) = dxdt(n + 1:2*n) - self%c*x(n + 1:2*n)
    if (self%f > 0) then
      r = sqrt(max(self%sigma*dot_product(x(n + 1:2*n), dxdt(1:n)), 0.0_wp) + self%v_reg**2)
      dxdt(n + 1:2*n) = dxdt(n + 1:2*n) - (self%f*self%sigma/r)*x(n + 1:2*n)
    end if
  end subroutine damped_eval

  pure function ham_jet_spec(self) result(spec)
    class(hamiltonian_t), intent(in) :: self
    type(jet_spec_t) :: spec
    if (allocated(self%formula)) spec%text = self%formula
    spec%nq = self%ndof()               ! eval's refusal of an escaped state (BLOWUP_Q)
    spec%q_bound = BLOWUP_Q
  end function ham_jet_spec

  !> The base model's formula with the damping rate, and with rolling resistance the line
  !> 'rolling SIGMA VREG2' (python/tubes/codegen.py adds the drag; its rate f sigma is a parameter).
  pure function damped_jet_spec(self) result(spec)
    class(damped_t), intent(in) :: self
    type(jet_spec_t) :: spec
    character(20) :: a, b
    spec = self%base%jet_spec()
    spec%damping = self%c
    if (self%f > 0 .and. allocated(spec%text)) then
      write (a, '(a, z16.16)') 'f64:', transfer(self%sigma, 0_int64)
      write (b, '(a, z16.16)') 'f64:', transfer(self%v_reg**2, 0_int64)
      spec%text = spec%text // 'rolling ' // a // ' ' // b // new_line('a')
      spec%rolling = self%f*self%sigma
    end if
  end function damped_jet_spec

  !> Does the field carry noise (an integrator of it is the stochastic one)?
  pure logical function damped_noisy(self)
    class(damped_t), intent(in) :: self
    damped_noisy = self%noise > 0 .or. self%temperature > 0
  end function damped_noisy

  !> The noise's factor S at state x: dp = ... dt + S dW (S lower triangular, n x n, n = N): S =
  !> sqrt(2 noise) I, or with the fluctuation-dissipation relation S S^T = 2 c temperature A(q)^-1
  !> (its Cholesky factor), whose stationary density is exp(-H/temperature). stat /= 0 where A is
  !> not defined or not positive definite.
  subroutine damped_noise_factor(self, x, s, stat)
    class(damped_t), intent(in) :: self
    real(wp), intent(in) :: x(:)
    real(wp), intent(out) :: s(:, :)
    integer, intent(out) :: stat
    real(wp) :: a(size(s, 1), size(s, 1)), ai(size(s, 1), size(s, 1)), pc(size(s, 1)), v
    integer :: n, i, ipiv(size(s, 1))
    n = size(s, 1)
    s = 0
    stat = 0
    if (.not. self%temperature > 0) then
      do i = 1, n
        s(i, i) = sqrt(2*self%noise)
      end do
      return
    end if
    call quadratic_parts(self%base, x(1:n), a, pc, v, stat)
    if (stat /= 0) return
    ai = 0
    do i = 1, n
      ai(i, i) = 1
    end do
    call dgesv(n, n, a, n, ipiv, ai, n, stat)        ! A^-1
    if (stat /= 0) return
    ai = 2*self%c*self%temperature*ai
    call cholesky_lower(ai, s, stat)                  ! S S^T = 2 c theta A^-1
  end subroutine damped_noise_factor

  !> The Cholesky factor of a symmetric positive definite a: l lower triangular (its upper part 0),
  !> l l^T = a; stat = -1 (l unfinished) where a pivot is not > 0 (a not positive definite).
  pure subroutine cholesky_lower(a, l, stat)
    real(wp), intent(in) :: a(:, :)
    real(wp), intent(out) :: l(:, :)
    integer, intent(out) :: stat
    integer :: i, j, n
    n = size(a, 1)
    l = 0
    stat = 0
    do j = 1, n
      l(j, j) = a(j, j) - sum(l(j, 1:j - 1)**2)
      if (.not. l(j, j) > 0) then
        stat = -1
        return
      end if
      l(j, j) = sqrt(l(j, j))
      do i = j + 1, n
        l(i, j) = (a(i, j) - sum(l(i, 1:j - 1)*l(j, 1:j - 1)))/l(j, j)
      end do
    end do
  end subroutine cholesky_lower

  pure subroutine damped_jacobian(self, t, x, jac, stat)
    class(damped_t), intent(in) :: self
    real(wp), intent(in)  :: t, x(:)
    real(wp), intent(out) :: jac(:, :)
    integer, intent(out)  :: stat
    integer :: n, k
    real(wp) :: v(size(x)), du(size(x)), r, kf
    n = size(x)/2
    call self%base%jacobian(t, x, jac, stat)
    if (stat /= 0) return
    do k = n + 1, 2*n
      jac(k, k) = jac(k, k) - self%c
    end do
    if (.not. self%f > 0) return
    ! F = -kf p / r, r = sqrt(u + v_reg^2), u = sigma p . v (v = dq/dt, its derivatives the base
    ! Jacobian's first n rows): dF/dx = -kf I_p / r + kf p (du/dx)^T / (2 r^3)
    call self%base%eval(t, x, v, stat)
    if (stat /= 0) return
    kf = self%f*self%sigma
    r = sqrt(max(self%sigma*dot_product(x(n + 1:2*n), v(1:n)), 0.0_wp) + self%v_reg**2)
    du = self%sigma*matmul(x(n + 1:2*n), jac(1:n, :))
    du(n + 1:2*n) = du(n + 1:2*n) + self%sigma*v(1:n)
    do k = 1, 2*n
      jac(n + 1:2*n, k) = jac(n + 1:2*n, k) + kf*x(n + 1:2*n)*du(k)/(2*r**3)
    end do
    do k = n + 1, 2*n
      jac(k, k) = jac(k, k) - kf/r
    end do
  end subroutine damped_jacobian
  !> H(q, p) = 1/2 (p - pc)^T A (p - pc) + V_eff(q) for a model quadratic in the momenta: A(q) =
  !> d2H/dp2, pc(q) = -A^-1 dH/dp(q, 0), V_eff = H(q, 0) - 1/2 pc^T A pc (natural models: their own
  !> A, pc = 0, V; gyroscopic ones, the CR3BP: V_eff is the Jacobi effective potential). stat /= 0
  !> where H is not defined at (q, 0).
  subroutine quadratic_parts(model, q, a, pc, v, stat)
    class(hamiltonian_t), intent(in) :: model
    real(wp), intent(in) :: q(:)
    real(wp), intent(out) :: a(:, :), pc(:), v
    integer, intent(out) :: stat
    real(wp) :: x(2*size(q)), g(2*size(q)), h(2*size(q), 2*size(q)), l(size(q), size(q))
    integer :: nd, i
    nd = size(q)
    stat = 0
    select type (model)
    class is (natural_t)
      call model%kinetic_matrix(q, a)
      pc = 0
      v = model%potential(q)
      return
    end select
    x = 0
    x(1:nd) = q
    call model%gradient(x, g, stat)
    if (stat /= 0) return
    call model%hessian(x, h, stat)
    if (stat /= 0) return
    a = h(nd + 1:, nd + 1:)
    ! pc = -A^-1 b by Cholesky (A is positive definite for a kinetic energy)
    call cholesky_lower(a, l, stat)
    if (stat /= 0) return
    pc = -g(nd + 1:)
    do i = 1, nd
      pc(i) = (pc(i) - sum(l(i, 1:i - 1)*pc(1:i - 1)))/l(i, i)
    end do
    do i = nd, 1, -1
      pc(i) = (pc(i) - sum(l(i + 1:nd, i)*pc(i + 1:nd)))/l(i, i)
    end do
    v = model%energy(x) - dot_product(pc, matmul(a, pc))/2
  end subroutine quadratic_parts

  !> V_eff(q) (quadratic_parts); +huge where H is not defined. A natural model's is its potential,
  !> taken directly (quadratic_parts' value, without the kinetic matrix it would build and discard).
  real(wp) function veff(model, q) result(v)
    class(hamiltonian_t), intent(in) :: model
    real(wp), intent(in) :: q(:)
    real(wp) :: a(size(q), size(q)), pc(size(q))
    integer :: st
    select type (model)
    class is (natural_t)
      v = model%potential(q)
      return
    end select
    call quadratic_parts(model, q, a, pc, v, st)
    if (st /= 0) v = huge(1.0_wp)
  end function veff

  !> Whether H(q, p) is the quadratic of quadratic_parts in p at q (three momenta checked to
  !> 1e-9 relative): the premise of the flux's sampling and of a plane section (tubes_section_kinds).
  logical function quadratic_in_p(model, q) result(ok)
    class(hamiltonian_t), intent(in) :: model
    real(wp), intent(in) :: q(:)
    real(wp) :: a(size(q), size(q)), pc(size(q)), v, x(2*size(q)), p(size(q)), hq
    integer :: st, k, nd, i
    nd = size(q)
    call quadratic_parts(model, q, a, pc, v, st)
    ok = st == 0
    if (.not. ok) return
    do k = 1, 3
      p = [(0.3_wp*k + 0.17_wp*i, i = 1, nd)]
      x(1:nd) = q
      x(nd + 1:) = p
      hq = dot_product(p - pc, matmul(a, p - pc))/2 + v
      ok = ok .and. abs(model%energy(x) - hq) <= 1.0e-9_wp*max(1.0_wp, abs(hq), abs(v))
    end do
  end function quadratic_in_p

end module tubes_hamiltonian
