!> Integration methods by code (the same numbers as TUBES_METHOD_* in include/tubes.h and
!> tubes.METHODS in python/tubes/__init__.py) and their options.
module tubes_methods
  use tubes_kinds, only: wp
  use tubes_integrator, only: integrator_t
  use tubes_field, only: vector_field_t
  use tubes_dop853, only: dop853_t
  use tubes_rk4, only: rk4_t
  use tubes_tao, only: tao_t, TAO_OMEGA_DEFAULT
  use tubes_gauss, only: gauss_t
  use tubes_gsl, only: gsl_t
  use tubes_sundials, only: cvode_t, arkode_t
  use tubes_taylor, only: taylor_t
  use tubes_sde, only: sde_t
  use tubes_hamiltonian, only: damped_t
  use tubes_status, only: TUBES_OK, TUBES_EINPUT
  implicit none
  private
  integer, parameter, public :: METHOD_DOP853 = 1   !! Hairer's DOP853, variable step
  integer, parameter, public :: METHOD_RK4 = 2      !! classical Runge-Kutta, fixed step
  integer, parameter, public :: METHOD_TAO2 = 3     !! Tao's explicit symplectic, order 2
  integer, parameter, public :: METHOD_TAO4 = 4     !! Tao, order 4 (triple jump)
  integer, parameter, public :: METHOD_TAO6 = 5     !! Tao, order 6
  integer, parameter, public :: METHOD_GAUSS4 = 6   !! Gauss-Legendre, 2 stages, order 4
  integer, parameter, public :: METHOD_GAUSS6 = 7   !! Gauss-Legendre, 3 stages, order 6
  integer, parameter, public :: METHOD_GAUSS8 = 8   !! Gauss-Legendre, 4 stages, order 8
  integer, parameter, public :: METHOD_GSL_RK8PD = 9     !! GSL odeiv2 rk8pd, variable step
  integer, parameter, public :: METHOD_GSL_RK4IMP = 10   !! GSL odeiv2 rk4imp (implicit), variable step
  integer, parameter, public :: METHOD_CVODE_ADAMS = 11  !! SUNDIALS CVODE, Adams, variable step/order
  integer, parameter, public :: METHOD_ARKODE_ERK8 = 12  !! SUNDIALS ARKODE ERKStep, Fehlberg 13-7-8
  integer, parameter, public :: METHOD_TAYLOR = 13       !! Taylor, adaptive order and step, from the formula
  !> the fastest measured for what is integrated (docs/integrators-taylor.md, "auto"): Taylor for
  !> a model's state (one trajectory or an ensemble in lanes), DOP853 for an extended state (the
  !> variational equations, the action), where Taylor's series of the n^2 matrix cost more
  integer, parameter, public :: METHOD_AUTO = 14
  integer, parameter, public :: METHOD_LAST = 14         !! largest code available

  !> Method-specific options; zero or blank means the method's default.
  type, public :: method_opts_t
    real(wp) :: omega_bind = 0       !! Tao's binding constant [1/s]; 0: TAO_OMEGA_DEFAULT
    integer :: solver = 0            !! Gauss stage solver: 0/1 simplified Newton, 2 fixed point
    integer :: max_iter = 0          !! Gauss iterations per step; 0: the solver's default
  end type method_opts_t

  !> The integrator an analysis uses: the input's &integrator method with its options (the
  !> tolerances stay each analysis's own).
  type, public :: integ_choice_t
    integer :: method = METHOD_DOP853     !! a METHOD_* code
    real(wp) :: h = 0                     !! fixed step [time] (fixed-step methods; > 0 there)
    type(method_opts_t) :: opts           !! method options
  end type integ_choice_t

  public :: new_integrator, is_fixed_step, make_integrator, uses_taylor, noisy, noise_stream

contains

  !> True for the methods that need &integrator h > 0.
  pure logical function is_fixed_step(method)
    integer, intent(in) :: method
    is_fixed_step = method >= METHOD_RK4 .and. method <= METHOD_GAUSS8
  end function is_fixed_step

  !> Allocate an integrator of the given method code with its options.
  subroutine new_integrator(method, ig, stat, opts)
    integer, intent(in) :: method
    class(integrator_t), allocatable, intent(out) :: ig
    integer, intent(out) :: stat
    type(method_opts_t), intent(in), optional :: opts
    type(method_opts_t) :: o
    type(tao_t) :: tao
    type(gauss_t) :: gauss
    if (present(opts)) o = opts
    stat = TUBES_OK
    select case (method)
    case (METHOD_DOP853)
      allocate (dop853_t :: ig)
    case (METHOD_RK4)
      allocate (rk4_t :: ig)
    case (METHOD_TAO2, METHOD_TAO4, METHOD_TAO6)
      tao%order = 2*(method - METHOD_TAO2 + 1)
      tao%omega_bind = TAO_OMEGA_DEFAULT
      if (o%omega_bind > 0) tao%omega_bind = o%omega_bind
      allocate (ig, source=tao)
    case (METHOD_GAUSS4, METHOD_GAUSS6, METHOD_GAUSS8)
      gauss%stages = method - METHOD_GAUSS4 + 2
      if (o%solver == 2) gauss%solver = 'fixed_point'
      gauss%max_iter = o%max_iter
      allocate (ig, source=gauss)
    case (METHOD_GSL_RK8PD)
      allocate (ig, source=gsl_t(kind='gsl_rk8pd'))
    case (METHOD_GSL_RK4IMP)
      allocate (ig, source=gsl_t(kind='gsl_rk4imp'))
    case (METHOD_CVODE_ADAMS)
      allocate (cvode_t :: ig)
    case (METHOD_ARKODE_ERK8)
      allocate (arkode_t :: ig)
    case (METHOD_TAYLOR, METHOD_AUTO)
      allocate (taylor_t :: ig)
    case default
      stat = TUBES_EINPUT
    end select
  end subroutine new_integrator

  !> Does the choice integrate a model's state (the ensembles' lanes) with the Taylor method?
  pure logical function uses_taylor(choice)
    type(integ_choice_t), intent(in) :: choice
    uses_taylor = choice%method == METHOD_TAYLOR .or. choice%method == METHOD_AUTO
  end function uses_taylor

  !> Allocate the integrator of a choice, its fixed step set. extended: it integrates an extended
  !> state (variational equations, action), where METHOD_AUTO means DOP853. A noisy field (damped_t
  !> with noise) is integrated by the stochastic method (tubes_sde) whatever the choice, with step
  !> choice%h if > 0, else the field's h_noise; stream: its trajectory's number (noise_stream).
  subroutine make_integrator(choice, ig, stat, extended, f, rtol, atol)
    type(integ_choice_t), intent(in) :: choice
    class(integrator_t), allocatable, intent(out) :: ig
    integer, intent(out) :: stat
    logical, intent(in), optional :: extended
    class(vector_field_t), intent(in), optional :: f   !! the field, the integration starting at t = 0
    real(wp), intent(in), optional :: rtol, atol       !! the analysis's tolerances
    integer :: m
    logical :: stochastic
    stochastic = .false.
    if (present(f)) stochastic = noisy(f)      ! (not in one .and.: Fortran does not short-circuit)
    if (stochastic) then
      select type (f)
      type is (damped_t)
        allocate (sde_t :: ig)
        ig%h = merge(choice%h, f%h_noise, choice%h > 0)
        stat = TUBES_EINPUT
        if (.not. ig%h > 0) return
        call ig%init(f, 0.0_wp)
        stat = TUBES_OK
      end select
      return
    end if
    m = choice%method
    if (m == METHOD_AUTO .and. present(extended)) then
      if (extended) m = METHOD_DOP853
    end if
    call new_integrator(m, ig, stat, choice%opts)
    if (stat /= TUBES_OK) return
    if (is_fixed_step(choice%method) .and. .not. choice%h > 0) then
      stat = TUBES_EINPUT
      return
    end if
    ig%h = choice%h
    ! under auto, h is the Taylor method's largest step; DOP853 would take it as a fixed step
    ! without error control (its h's meaning): the extended state keeps its tolerances
    if (choice%method == METHOD_AUTO .and. m == METHOD_DOP853) ig%h = 0
    if (present(f)) call ig%init(f, 0.0_wp)
    if (present(rtol)) ig%rtol = rtol
    if (present(atol)) ig%atol = atol
  end subroutine make_integrator

  !> Is f a noisy field (integrated by the stochastic method; not in the Taylor method's lanes)?
  pure logical function noisy(f)
    class(vector_field_t), intent(in) :: f
    noisy = .false.
    select type (f)
    type is (damped_t)
      noisy = f%noisy()
    end select
  end function noisy

  !> Set the stochastic integrator's trajectory number (its noise stream); others: nothing.
  subroutine noise_stream(ig, k)
    class(integrator_t), intent(inout) :: ig
    integer, intent(in) :: k
    select type (ig)
    class is (sde_t)
      ig%stream = k
    end select
  end subroutine noise_stream
end module tubes_methods
