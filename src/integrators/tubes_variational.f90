!> Variational equations: the state x and its state transition matrix Phi = dx(t)/dx(0)
!> integrated together, d/dt [x, Phi] = [f(x), J(x) Phi], with any integrator.
!> Layout of the extended state: (x(1:n), Phi(:, 1), ..., Phi(:, n)), n + n^2 components.
module tubes_variational
  use tubes_kinds, only: wp
  use tubes_field, only: vector_field_t, jet_spec_t
  implicit none
  private

  !> The flow and the n x m matrix W carried by its linearisation, d/dt [x, W] = [f(x), J(x) W],
  !> W stored column by column after x: the state transition matrix (m = n, variational_t) or
  !> one tangent vector (m = 1, tangent_t). Both are this type; make_variational and
  !> make_tangent set which.
  type, extends(vector_field_t) :: linearised_t
    class(vector_field_t), allocatable :: base   !! the model whose flow is linearised
    logical :: stm = .true.                      !! W is Phi (m = n), else one vector (m = 1)
  contains
    procedure :: dim => lin_dim
    procedure :: eval => lin_eval
    procedure :: jet_spec => lin_jet_spec
  end type linearised_t

  !> The state and its state transition matrix Phi (n + n^2 components).
  type, extends(linearised_t), public :: variational_t
  end type variational_t

  !> The flow and one tangent vector: d/dt [x, w] = [f(x), J(x) w] (dimension 2n): the
  !> transport of a vector by the linearised flow at the cost of n, not n^2, more equations.
  type, extends(linearised_t), public :: tangent_t
  end type tangent_t

  public :: make_variational, stm_start, make_tangent

contains

  !> Wrap a model (allocate with source=, see STYLE.md).
  subroutine make_variational(var, base)
    type(variational_t), intent(out) :: var
    class(vector_field_t), intent(in) :: base
    allocate (var%base, source=base)
  end subroutine make_variational

  !> Wrap a model.
  subroutine make_tangent(tan, base)
    type(tangent_t), intent(out) :: tan
    class(vector_field_t), intent(in) :: base
    allocate (tan%base, source=base)
    tan%stm = .false.
  end subroutine make_tangent

  !> m, the number of columns of W.
  pure integer function columns(self)
    class(linearised_t), intent(in) :: self
    columns = 1
    if (self%stm) columns = self%base%dim()
  end function columns

  pure integer function lin_dim(self)
    class(linearised_t), intent(in) :: self
    integer :: n
    n = self%base%dim()
    lin_dim = n + n*columns(self)
  end function lin_dim

  pure subroutine lin_eval(self, t, x, dxdt, stat)
    class(linearised_t), intent(in) :: self
    real(wp), intent(in)  :: t, x(:)
    real(wp), intent(out) :: dxdt(:)
    integer, intent(out)  :: stat
    call eval_with_columns(self%base, t, x, columns(self), dxdt, stat)
  end subroutine lin_eval

  !> (f(x), J(x) W) for the base model, the n x m matrix W stored column by column after x:
  !> m = 1 a tangent vector, m = n the state transition matrix.
  pure subroutine eval_with_columns(base, t, x, m, dxdt, stat)
    class(vector_field_t), intent(in) :: base
    real(wp), intent(in)  :: t, x(:)
    integer, intent(in) :: m
    real(wp), intent(out) :: dxdt(:)
    integer, intent(out)  :: stat
    real(wp) :: jac(base%dim(), base%dim())
    integer :: n
    n = base%dim()
    call base%eval(t, x(1:n), dxdt(1:n), stat)
    if (stat /= 0) return
    call base%jacobian(t, x(1:n), jac, stat)
    if (stat /= 0) return
    dxdt(n + 1:n + n*m) = reshape(matmul(jac, reshape(x(n + 1:n + n*m), [n, m])), [n*m])
  end subroutine eval_with_columns

  !> The base model's formula, with its variational equations or the tangent vector.
  pure function lin_jet_spec(self) result(spec)
    class(linearised_t), intent(in) :: self
    type(jet_spec_t) :: spec
    spec = self%base%jet_spec()
    if (self%stm) then
      spec%variational = .true.
    else
      spec%tangent = .true.
    end if
  end function lin_jet_spec

  !> Extended initial state (x0, identity).
  pure function stm_start(x0) result(z)
    real(wp), intent(in) :: x0(:)
    real(wp) :: z(size(x0) + size(x0)**2)
    integer :: n, j
    n = size(x0)
    z = 0
    z(1:n) = x0
    do j = 1, n
      z(n + (j - 1)*n + j) = 1
    end do
  end function stm_start
end module tubes_variational
