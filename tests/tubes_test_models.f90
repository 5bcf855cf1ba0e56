!> The test oscillator shared by the integrator and event tests: x'' = -x as the state (x, v),
!> whose exact flow is a rotation, and two failing variants. (It was written out in six tests.)
module tubes_test_models
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
  use tubes_kinds, only: wp
  use tubes_field, only: vector_field_t, jet_spec_t
  implicit none
  private
  public :: oscillator_t, nan_oscillator_t, shy_oscillator_t, rotate, osc_eval

  !> x' = v, v' = -x.
  type, extends(vector_field_t) :: oscillator_t
  contains
    procedure :: dim => osc_dim
    procedure :: eval => osc_eval
    procedure :: jacobian => osc_jacobian
    procedure :: jet_spec => osc_jet_spec
  end type oscillator_t

  !> The oscillator, but x < 1/2 gives NaN and stat = -1 (fatal).
  type, extends(oscillator_t) :: nan_oscillator_t
  contains
    procedure :: eval => nan_eval
  end type nan_oscillator_t

  !> The oscillator, but x < 1/2 gives stat = +1 (retry with a smaller step).
  type, extends(oscillator_t) :: shy_oscillator_t
  contains
    procedure :: eval => shy_eval
  end type shy_oscillator_t

contains

  pure integer function osc_dim(self)
    class(oscillator_t), intent(in) :: self
    osc_dim = 2
  end function osc_dim

  pure subroutine osc_eval(self, t, x, dxdt, stat)
    class(oscillator_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:)
    real(wp), intent(out) :: dxdt(:)
    integer, intent(out) :: stat
    dxdt(1) = x(2)
    dxdt(2) = -x(1)
    stat = 0
  end subroutine osc_eval

  !> Its formula, H = (p^2 + q^2)/2 (the Taylor method's source).
  pure function osc_jet_spec(self) result(spec)
    class(oscillator_t), intent(in) :: self
    type(jet_spec_t) :: spec
    character, parameter :: NL = new_line('a')
    spec%text = 'tubes-expression 1' // NL // 'kind hamiltonian' // NL // 'expr (p^2 + q^2)/2' // NL // &
                'coordinates q' // NL // 'momenta p' // NL
  end function osc_jet_spec

  !> The exact Jacobian [[0, 1], [-1, 0]] (implicit and Newton-corrected methods).
  pure subroutine osc_jacobian(self, t, x, jac, stat)
    class(oscillator_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:)
    real(wp), intent(out) :: jac(:, :)
    integer, intent(out) :: stat
    jac = reshape([0.0_wp, -1.0_wp, 1.0_wp, 0.0_wp], [2, 2])
    stat = 0
  end subroutine osc_jacobian

  pure subroutine nan_eval(self, t, x, dxdt, stat)
    class(nan_oscillator_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:)
    real(wp), intent(out) :: dxdt(:)
    integer, intent(out) :: stat
    call osc_eval(self, t, x, dxdt, stat)
    if (x(1) < 0.5_wp) then
      dxdt = ieee_value(1.0_wp, ieee_quiet_nan)
      stat = -1
    end if
  end subroutine nan_eval

  pure subroutine shy_eval(self, t, x, dxdt, stat)
    class(shy_oscillator_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:)
    real(wp), intent(out) :: dxdt(:)
    integer, intent(out) :: stat
    call osc_eval(self, t, x, dxdt, stat)
    if (x(1) < 0.5_wp) stat = 1
  end subroutine shy_eval

  !> Exact oscillator flow over time s: (x, v) -> (x cos s + v sin s, -x sin s + v cos s).
  pure function rotate(x, s) result(y)
    real(wp), intent(in) :: x(2), s
    real(wp) :: y(2)
    y(1) = x(1)*cos(s) + x(2)*sin(s)
    y(2) = -x(1)*sin(s) + x(2)*cos(s)
  end function rotate
end module tubes_test_models
