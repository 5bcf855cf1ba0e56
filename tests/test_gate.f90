!> The Monte Carlo's transit gate bounded to the neck (src/transport/tubes_transport.f90 gate_bound,
!> gate_t): on Henon-Heiles, V(x, y) = (x^2 + y^2)/2 + x^2 y - y^3/3, the gate 0.1 past the saddle
!> (0, 1) is the line y = 1.1, where V = 1.6 x^2 + 0.605 - 1.331/3: the neck's segment at E is
!> |x| <= sqrt((E - 0.605 + 1.331/3)/1.6), a closed form. Free particles (dq/dt = p, dp/dt = 0)
!> crossing the line inside it pass, outside it do not (and are counted there), and a line that
!> whose point lies above E (the neck closed there) passes nothing.
program test_gate
  use tubes_kinds, only: wp
  use tubes_check, only: check_close, check_true, check_eq, finish
  use tubes_status, only: TUBES_OK
  use tubes_henon_heiles, only: henon_heiles_t
  use tubes_transport, only: gate_spec_t, gate_t, gate_bound
  use tubes_dop853, only: dop853_t
  use tubes_integrator, only: propagate
  use tubes_test_models, only: affine_field_t
  implicit none
  type(henon_heiles_t) :: hh
  type(gate_spec_t) :: g
  real(wp) :: e, half
  integer :: stat
  g%origin = [0.0_wp, 1.0_wp]
  g%normal = [0.0_wp, 1.0_wp]
  g%dist = 0.1_wp
  e = 1.0_wp/6 + 0.02_wp                       ! dE = 0.02 above the saddles
  call gate_bound(hh, g, e, stat)
  call check_eq('gate_bound status', stat, TUBES_OK)
  half = sqrt((e - 0.605_wp + 1.331_wp/3)/1.6_wp)
  ! the segment's ends by bisection to the last bit of the marching step's 2^-80
  call check_close('neck segment, one end (closed form)', min(-g%seg_lo, g%seg_hi), half, 1.0e-12_wp)
  call check_close('neck segment, the other end', max(-g%seg_lo, g%seg_hi), half, 1.0e-12_wp)
  call check_close('tangent orthogonal to the normal', dot_product(g%tangent, g%normal), 0.0_wp, 0.0_wp)
  call fly(0.5_wp*half, .true., 0)
  call fly(-0.9_wp*half, .true., 0)
  call fly(1.5_wp*half, .false., 1)             ! across the line beside the neck: no transit
  call fly(-3.0_wp, .false., 1)
  ! a gate where the line's point lies above E (y = -0.8 below the saddle, V(0, -0.8) = 0.49): no
  ! segment, nothing passes
  g%normal = [0.0_wp, -1.0_wp]
  g%dist = 1.8_wp
  call gate_bound(hh, g, e, stat)
  call check_eq('gate point above the energy: status', stat, TUBES_OK)
  call check_true('gate point above the energy: an empty segment', g%seg_lo > g%seg_hi)
  call finish('test_gate')
contains
  !> A free particle from (x0, 0.5) moving up with unit speed crosses y = 1.1 at x0.
  subroutine fly(x0, pass, outside)
    real(wp), intent(in) :: x0
    logical, intent(in) :: pass
    integer, intent(in) :: outside
    type(affine_field_t) :: free
    type(dop853_t) :: ig
    type(gate_t) :: obs
    real(wp) :: x(4)
    integer :: st
    character(48) :: name
    allocate (free%a(4, 4))
    free%a = 0
    free%a(1, 3) = 1
    free%a(2, 4) = 1
    free%b = [0.0_wp, 0.0_wp, 0.0_wp, 0.0_wp]
    call ig%init(free, 0.0_wp)
    x = [x0, 0.5_wp, 0.0_wp, 1.0_wp]
    obs%spec = g
    call propagate(ig, x, 2.0_wp, st, observer=obs)
    write (name, '(a, f7.3)') 'crossing at x = ', x0
    call check_true(trim(name)//': passed', obs%passed .eqv. pass)
    call check_eq(trim(name)//': crossings beside the neck', obs%outside, outside)
    if (pass) call check_true(trim(name)//': stopped past the line', x(2) > 1.1_wp .and. st == TUBES_OK)
  end subroutine fly
end program test_gate
