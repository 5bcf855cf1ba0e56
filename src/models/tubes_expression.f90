!> Models written as formulas (docs/models.md, "Models from the input file"): the compiled code
!> that python/tubes/codegen.py generated from the formula (SymPy's exact derivatives) and
!> src/io/tubes_expr.c built and loaded. The procedures come through include/tubes.h's
!> tubes_expr_lib_t; each is pure (a function of its arguments only).
!>
!> - expr_hamiltonian_t: any H(q, p) with N <= 3 degrees of freedom;
!> - expr_natural_t: one that codegen found to be natural, H = 1/2 p^T A(q) p + V(q)
!>   (rest points, brake orbits, releases from rest);
!> - expr_surface_t: a rolling ball's surface z = h(x, y) (tubes_ball rolls on it).
module tubes_expression
  use, intrinsic :: iso_c_binding, only: c_int, c_double, c_char, c_funptr, c_f_procpointer
  use tubes_kinds, only: wp
  use tubes_hamiltonian, only: hamiltonian_t, natural_t, LEN_NAME
  use tubes_surface, only: surface_t
  use tubes_status, only: TUBES_OK, TUBES_EINPUT
  implicit none
  private

  integer, parameter, public :: KIND_HAMILTONIAN = 1, KIND_SURFACE = 2
  integer, parameter :: MAXDOF = 3

  !> include/tubes.h tubes_expr_lib_t
  type, bind(C), public :: expr_lib_t
    integer(c_int) :: kind, ndof, natural
    type(c_funptr) :: fn(7)
    integer(c_int) :: reversor(2*MAXDOF)
    character(kind=c_char) :: names(16, 2*MAXDOF)
    character(kind=c_char) :: formula(160)
  end type expr_lib_t

  abstract interface
    pure subroutine expr_fn_i(x, y) bind(C)
      import :: c_double
      real(c_double), intent(in) :: x(*)
      real(c_double), intent(out) :: y(*)
    end subroutine expr_fn_i
  end interface

  !> The generated procedures of a Hamiltonian.
  type :: expr_fns_t
    integer :: n = 0                          !! degrees of freedom
    character(LEN_NAME) :: names(2*MAXDOF) = ''
    integer :: reversor(2*MAXDOF) = 0           !! signs of a reversor of H, or zeros
    procedure(expr_fn_i), pointer, nopass :: energy => null(), field => null(), &
      gradient => null(), hessian => null(), shape => null(), shape_derivs => null(), &
      kinetic => null()
  end type expr_fns_t

  type, extends(hamiltonian_t), public :: expr_hamiltonian_t
    type(expr_fns_t) :: f
  contains
    procedure :: energy => gen_energy
    procedure :: gradient => gen_gradient
    procedure :: hessian => gen_hessian
    procedure :: eval => gen_eval
    procedure :: coordinate_name => gen_name
    procedure :: reversor => gen_reversor
  end type expr_hamiltonian_t

  type, extends(natural_t), public :: expr_natural_t
    type(expr_fns_t) :: f
  contains
    procedure :: energy => nat_energy
    procedure :: gradient => nat_gradient
    procedure :: hessian => nat_hessian
    procedure :: eval => nat_eval
    procedure :: coordinate_name => nat_name
    procedure :: shape => nat_shape
    procedure :: shape_derivs => nat_shape_derivs
    procedure :: kinetic_matrix => nat_kinetic
  end type expr_natural_t

  type, extends(surface_t), public :: expr_surface_t
    procedure(expr_fn_i), pointer, nopass :: h => null(), d12 => null(), d3 => null()
  contains
    procedure :: height => surf_height
    procedure :: derivs => surf_derivs
    procedure :: third => surf_third
  end type expr_surface_t

  public :: expr_model, expr_surface

contains

  !> The Hamiltonian of a loaded library (lib%kind == KIND_HAMILTONIAN).
  subroutine expr_model(lib, model, stat)
    type(expr_lib_t), intent(in) :: lib
    class(hamiltonian_t), allocatable, intent(out) :: model
    integer, intent(out) :: stat
    type(expr_fns_t) :: f
    integer :: k
    stat = TUBES_EINPUT
    if (lib%kind /= KIND_HAMILTONIAN .or. lib%ndof < 1 .or. lib%ndof > MAXDOF) return
    f%n = lib%ndof
    f%reversor = lib%reversor
    do k = 1, 2*f%n
      f%names(k) = c_name(lib%names(:, merge(k, MAXDOF + k - f%n, k <= f%n)))
    end do
    call c_f_procpointer(lib%fn(1), f%energy)
    call c_f_procpointer(lib%fn(2), f%field)
    call c_f_procpointer(lib%fn(3), f%gradient)
    call c_f_procpointer(lib%fn(4), f%hessian)
    if (lib%natural /= 0) then
      call c_f_procpointer(lib%fn(5), f%shape)
      call c_f_procpointer(lib%fn(6), f%shape_derivs)
      call c_f_procpointer(lib%fn(7), f%kinetic)
      allocate (model, source=expr_natural_t(f=f, nd=f%n))
    else
      allocate (model, source=expr_hamiltonian_t(f=f, nd=f%n))
    end if
    stat = TUBES_OK
  end subroutine expr_model

  !> The surface of a loaded library (lib%kind == KIND_SURFACE).
  subroutine expr_surface(lib, surf, stat)
    type(expr_lib_t), intent(in) :: lib
    type(expr_surface_t), intent(out) :: surf
    integer, intent(out) :: stat
    stat = TUBES_EINPUT
    if (lib%kind /= KIND_SURFACE) return
    call c_f_procpointer(lib%fn(1), surf%h)
    call c_f_procpointer(lib%fn(2), surf%d12)
    call c_f_procpointer(lib%fn(3), surf%d3)
    stat = TUBES_OK
  end subroutine expr_surface

  pure function c_name(c) result(s)
    character(kind=c_char), intent(in) :: c(:)
    character(LEN_NAME) :: s
    integer :: k
    s = ''
    do k = 1, min(size(c), LEN_NAME)
      if (c(k) == char(0)) exit
      s(k:k) = c(k)
    end do
  end function c_name

  ! ---- shared by both Hamiltonian kinds: stat = -1 where the formula is not finite

  pure real(wp) function f_energy(f, x)
    type(expr_fns_t), intent(in) :: f
    real(wp), intent(in) :: x(:)
    real(wp) :: e(1)
    call f%energy(x, e)
    f_energy = e(1)
  end function f_energy

  pure subroutine f_gradient(f, x, g, stat)
    type(expr_fns_t), intent(in) :: f
    real(wp), intent(in) :: x(:)
    real(wp), intent(out) :: g(:)
    integer, intent(out) :: stat
    call f%gradient(x, g)
    stat = merge(0, -1, all(abs(g(1:2*f%n)) <= huge(1.0_wp)))
  end subroutine f_gradient

  pure subroutine f_hessian(f, x, h, stat)
    type(expr_fns_t), intent(in) :: f
    real(wp), intent(in) :: x(:)
    real(wp), intent(out) :: h(:, :)
    integer, intent(out) :: stat
    real(wp) :: a(4*MAXDOF*MAXDOF)
    integer :: m
    m = 2*f%n
    call f%hessian(x, a)
    h(1:m, 1:m) = reshape(a(1:m*m), [m, m])
    stat = merge(0, -1, all(abs(a(1:m*m)) <= huge(1.0_wp)))
  end subroutine f_hessian

  pure subroutine f_eval(f, x, dxdt, stat)
    type(expr_fns_t), intent(in) :: f
    real(wp), intent(in) :: x(:)
    real(wp), intent(out) :: dxdt(:)
    integer, intent(out) :: stat
    call f%field(x, dxdt)
    stat = merge(0, -1, all(abs(dxdt(1:2*f%n)) <= huge(1.0_wp)))
  end subroutine f_eval

  ! ---- expr_hamiltonian_t

  pure real(wp) function gen_energy(self, x)
    class(expr_hamiltonian_t), intent(in) :: self
    real(wp), intent(in) :: x(:)
    gen_energy = f_energy(self%f, x)
  end function gen_energy

  pure subroutine gen_gradient(self, x, g, stat)
    class(expr_hamiltonian_t), intent(in) :: self
    real(wp), intent(in) :: x(:)
    real(wp), intent(out) :: g(:)
    integer, intent(out) :: stat
    call f_gradient(self%f, x, g, stat)
  end subroutine gen_gradient

  pure subroutine gen_hessian(self, x, h, stat)
    class(expr_hamiltonian_t), intent(in) :: self
    real(wp), intent(in) :: x(:)
    real(wp), intent(out) :: h(:, :)
    integer, intent(out) :: stat
    call f_hessian(self%f, x, h, stat)
  end subroutine gen_hessian

  pure subroutine gen_eval(self, t, x, dxdt, stat)
    class(expr_hamiltonian_t), intent(in) :: self
    real(wp), intent(in)  :: t, x(:)
    real(wp), intent(out) :: dxdt(:)
    integer, intent(out)  :: stat
    call f_eval(self%f, x, dxdt, stat)
  end subroutine gen_eval

  pure function gen_name(self, k) result(name)
    class(expr_hamiltonian_t), intent(in) :: self
    integer, intent(in) :: k
    character(LEN_NAME) :: name
    name = self%f%names(k)
  end function gen_name

  !> The reversor codegen found (python/tubes/codegen.py: reversor), or zeros.
  pure function gen_reversor(self) result(r)
    class(expr_hamiltonian_t), intent(in) :: self
    integer :: r(2*self%ndof())
    r = self%f%reversor(1:2*self%f%n)
  end function gen_reversor

  ! ---- expr_natural_t

  pure real(wp) function nat_energy(self, x)
    class(expr_natural_t), intent(in) :: self
    real(wp), intent(in) :: x(:)
    nat_energy = f_energy(self%f, x)
  end function nat_energy

  pure subroutine nat_gradient(self, x, g, stat)
    class(expr_natural_t), intent(in) :: self
    real(wp), intent(in) :: x(:)
    real(wp), intent(out) :: g(:)
    integer, intent(out) :: stat
    call f_gradient(self%f, x, g, stat)
  end subroutine nat_gradient

  pure subroutine nat_hessian(self, x, h, stat)
    class(expr_natural_t), intent(in) :: self
    real(wp), intent(in) :: x(:)
    real(wp), intent(out) :: h(:, :)
    integer, intent(out) :: stat
    call f_hessian(self%f, x, h, stat)
  end subroutine nat_hessian

  pure subroutine nat_eval(self, t, x, dxdt, stat)
    class(expr_natural_t), intent(in) :: self
    real(wp), intent(in)  :: t, x(:)
    real(wp), intent(out) :: dxdt(:)
    integer, intent(out)  :: stat
    call f_eval(self%f, x, dxdt, stat)
  end subroutine nat_eval

  pure function nat_name(self, k) result(name)
    class(expr_natural_t), intent(in) :: self
    integer, intent(in) :: k
    character(LEN_NAME) :: name
    name = self%f%names(k)
  end function nat_name

  pure real(wp) function nat_shape(self, q)
    class(expr_natural_t), intent(in) :: self
    real(wp), intent(in) :: q(:)
    real(wp) :: v(1)
    call self%f%shape(q, v)
    nat_shape = v(1)
  end function nat_shape

  pure subroutine nat_shape_derivs(self, q, grad, hess)
    class(expr_natural_t), intent(in) :: self
    real(wp), intent(in) :: q(:)
    real(wp), intent(out) :: grad(:), hess(:, :)
    real(wp) :: a(MAXDOF + MAXDOF*MAXDOF)
    integer :: n
    n = self%f%n
    call self%f%shape_derivs(q, a)
    grad(1:n) = a(1:n)
    hess(1:n, 1:n) = reshape(a(n + 1:n + n*n), [n, n])
  end subroutine nat_shape_derivs

  pure subroutine nat_kinetic(self, q, a)
    class(expr_natural_t), intent(in) :: self
    real(wp), intent(in) :: q(:)
    real(wp), intent(out) :: a(:, :)
    real(wp) :: b(MAXDOF*MAXDOF)
    integer :: n
    n = self%f%n
    call self%f%kinetic(q, b)
    a(1:n, 1:n) = reshape(b(1:n*n), [n, n])
  end subroutine nat_kinetic

  ! ---- expr_surface_t

  pure function surf_height(self, x, y) result(h)
    class(expr_surface_t), intent(in) :: self
    real(wp), intent(in) :: x, y
    real(wp) :: h, v(1)
    call self%h([x, y], v)
    h = v(1)
  end function surf_height

  pure subroutine surf_derivs(self, x, y, grad, hess)
    class(expr_surface_t), intent(in) :: self
    real(wp), intent(in)  :: x, y
    real(wp), intent(out) :: grad(2), hess(2, 2)
    real(wp) :: a(6)
    call self%d12([x, y], a)
    grad = a(1:2)
    hess = reshape(a(3:6), [2, 2])
  end subroutine surf_derivs

  pure subroutine surf_third(self, x, y, t3)
    class(expr_surface_t), intent(in) :: self
    real(wp), intent(in)  :: x, y
    real(wp), intent(out) :: t3(2, 2, 2)
    real(wp) :: a(8)
    call self%d3([x, y], a)
    t3 = reshape(a, [2, 2, 2])
  end subroutine surf_third
end module tubes_expression
