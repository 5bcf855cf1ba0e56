!> The abstract vector field dx/dt = f(t, x). Models extend it; integrators see only this.
module tubes_field
  use tubes_kinds, only: wp
  implicit none
  private
  public :: fd_jacobian

  !> What the Taylor method (src/integrators/tubes_taylor.f90) needs of a vector field: the text
  !> of its model's formula, a tubes-expression spec (docs/integrators-taylor.md) from which the
  !> jet kernel is generated, and what the field adds to the model's Hamilton's equations.
  type, public :: jet_spec_t
    character(:), allocatable :: text    !! the spec; unallocated: no formula (no Taylor method)
    real(wp) :: damping = 0              !! c of dp/dt -= c p [1/time]
    !> f sigma of the rolling drag dp/dt -= f sigma p / sqrt(sigma p . dq/dt + v_reg^2) (its sigma and
    !> v_reg^2 are in the text's 'rolling' line) [length/time^2]
    real(wp) :: rolling = 0
    logical :: variational = .false.     !! the state transition matrix follows the state
    logical :: action = .false.          !! the action integral of p . dq/dt follows the state
    logical :: tangent = .false.         !! one tangent vector w, dw/dt = (df/dx) w, follows the state
    !> the model refuses a state whose first nq components (its coordinates) exceed q_bound in
    !> |.|_1, as its eval does (a blown-up, escaped state): the Taylor method, which does not call
    !> eval, checks it after each step (0: no bound)
    integer :: nq = 0
    real(wp) :: q_bound = huge(1.0_wp)
  end type jet_spec_t

  type, abstract, public :: vector_field_t
  contains
    procedure(dim_i), deferred :: dim     !! state dimension
    procedure(eval_i), deferred :: eval   !! dx/dt = f(t, x)
    procedure :: jacobian => fd_jacobian  !! df/dx; default: central differences
    procedure :: jet_spec => field_jet_spec  !! its formula for the Taylor method; default: none
  end type vector_field_t

  abstract interface
    pure integer function dim_i(self)
      import :: vector_field_t
      class(vector_field_t), intent(in) :: self
    end function dim_i
    pure subroutine eval_i(self, t, x, dxdt, stat)
      import :: vector_field_t, wp
      class(vector_field_t), intent(in) :: self   ! a model is read-only while integrating
      real(wp), intent(in)  :: t, x(:)
      real(wp), intent(out) :: dxdt(:)
      integer, intent(out)  :: stat               !! 0 ok, >0 retry with a smaller step, <0 fatal
    end subroutine eval_i
  end interface

contains

  !> No formula: the Taylor method cannot integrate this field.
  pure function field_jet_spec(self) result(spec)
    class(vector_field_t), intent(in) :: self
    type(jet_spec_t) :: spec
    spec%damping = 0
  end function field_jet_spec

  !> Jacobian by central differences (step sqrt-ish of eps scaled by |x|): a fallback for models
  !> without an analytic one; error ~ 1e-10 relative. Models override it.
  pure subroutine fd_jacobian(self, t, x, jac, stat)
    class(vector_field_t), intent(in) :: self
    real(wp), intent(in)  :: t, x(:)
    real(wp), intent(out) :: jac(:, :)   !! jac(i, j) = df_i/dx_j
    integer, intent(out)  :: stat
    real(wp) :: xp(size(x)), fp(size(x)), fm(size(x)), d
    integer :: j
    do j = 1, size(x)
      d = epsilon(1.0_wp)**(1.0_wp/3)*max(1.0_wp, abs(x(j)))
      xp = x
      xp(j) = x(j) + d
      call self%eval(t, xp, fp, stat)
      if (stat /= 0) return
      xp(j) = x(j) - d
      call self%eval(t, xp, fm, stat)
      if (stat /= 0) return
      jac(:, j) = (fp - fm)/(2*d)
    end do
  end subroutine fd_jacobian
end module tubes_field
