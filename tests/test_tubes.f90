!> Tube cuts and the energy surface on U1 against independent references: the cut's area
!> (Green's theorem) equals the orbit's action (the Poincare-Cartan integral invariant), the
!> area converges at the rate of its quadrature (cubic splines: 2^4 per doubling), the step-off
!> eps matters only at O(eps^2), A_E is the integral of the boundary computed by a second method,
!> dA_E/dE matches a finite difference, and the Monte Carlo classification matches the cut.
program test_tubes
  use, intrinsic :: iso_c_binding, only: c_long
  use tubes_kinds, only: wp, PI
  use tubes_ball, only: ball_t, make_ball
  use tubes_fourwell, only: fourwell_t
  use tubes_equilibria, only: equilibrium_t, find_equilibria
  use tubes_orbits, only: orbit_t, orbit_opts_t, orbit_family
  use tubes_manifold, only: tube_opts_t, tube_cut_t, tube_cut
  use tubes_ray_surface, only: ray_t, section_region, section_area, boundary_pr
  use tubes_section_kinds, only: poincare_t, make_ray_section
  use tubes_transport, only: gate_spec_t
  use tubes_methods, only: integ_choice_t
  use tubes_transport, only: monte_carlo
  use tubes_check, only: check_close, check_rel, check_true, check_eq, finish
  implicit none
  type(ball_t) :: ball
  type(equilibrium_t), allocatable :: eqs(:)
  type(orbit_opts_t) :: oo
  type(orbit_t) :: orbs(2)
  type(tube_opts_t) :: to
  type(tube_cut_t) :: cut, c1, c2, c3
  type(ray_t), target :: ray
  type(poincare_t) :: psec
  type(gate_spec_t) :: gate
  real(wp) :: end_de, wd(2), a, err, a2, da, e1, e2, e3, s, h
  real(wp), allocatable :: r(:), pr(:)
  integer, allocatable :: out(:)
  logical, allocatable :: ins(:)
  integer :: k, isad, iw, reason, stat, n
  character(64) :: lbl

  call make_ball(ball, fourwell_t(), 981.0_wp)
  call find_equilibria(ball, [-20.0_wp, -20.0_wp], [20.0_wp, 20.0_wp], 41, eqs, stat)
  do k = 1, size(eqs)
    if (eqs(k)%name == 'S12') isad = k
    if (eqs(k)%name == 'W1') iw = k
  end do
  wd = eqs(iw)%q - eqs(isad)%q
  call make_ray_section(psec, ball, PI/4, 1)   ! U1^-
  call orbit_family(ball, eqs, isad, [10.0_wp, 100.0_wp], oo, orbs, end_de, reason, stat)

  ! area = action (the issue's bound: 1e-8 relative; the quadrature reaches ~1e-12)
  do k = 1, 2
    call tube_cut(ball, orbs(k), wd, psec, to, cut, stat)
    write (lbl, '(a,f6.1)') 'tube cut at dE =', orbs(k)%de
    call check_eq(trim(lbl)//': status', stat, 0)
    call check_rel(trim(lbl)//': area = action', cut%area, orbs(k)%action, 1.0e-8_wp)
    ! every cut point on the section's ray (y = x), branch p_theta > 0, inside the energy
    ! surface; flight times negative (stable manifold: backwards)
    call check_true(trim(lbl)//': points on U1^- with negative flight time', &
                    all(abs(cut%x(1, :) - cut%x(2, :)) <= 1.0e-9_wp*cut%x(1, :)) .and. &
                    all(cut%x(1, :)*cut%x(4, :) - cut%x(2, :)*cut%x(3, :) > 0) .and. all(cut%time < 0))
  end do

  ! convergence rate: uniform doubling 32 -> 64 -> 128 seeds at dE = 100; the periodic cubic
  ! spline quadrature of a smooth closed curve has error O(N^-4): ratios ~ 16 (allow 10..22)
  to%adaptive = .false.
  to%area_tol = 1.0_wp      ! one round only
  to%n_init = 32
  call tube_cut(ball, orbs(2), wd, psec, to, c1, stat)
  to%n_init = 64
  call tube_cut(ball, orbs(2), wd, psec, to, c2, stat)
  to%n_init = 128
  call tube_cut(ball, orbs(2), wd, psec, to, c3, stat)
  e1 = abs(c1%hist_area(1) - orbs(2)%action)
  e2 = abs(c2%hist_area(1) - orbs(2)%action)
  e3 = abs(c3%hist_area(1) - orbs(2)%action)
  call check_true('area error ratio 32->64 seeds ~ 16 (spline quadrature, O(N^-4))', e1/e2 > 10 .and. e1/e2 < 22)
  call check_true('area error ratio 64->128 seeds ~ 16', e2/e3 > 10 .and. e2/e3 < 22)
  ! the polygon (shoelace) converges at O(N^-2): ratio ~ 4
  call check_true('polygon area error ratio 64->128 ~ 4 (O(N^-2))', &
                  abs(c2%area_polygon - orbs(2)%action)/abs(c3%area_polygon - orbs(2)%action) > 3 .and. &
                  abs(c2%area_polygon - orbs(2)%action)/abs(c3%area_polygon - orbs(2)%action) < 5)

  ! eps/10 changes the area by O(eps^2) only (first-order term vanishes: dH(v_s) = 0)
  to = tube_opts_t()
  to%eps = 1.0e-5_wp
  call tube_cut(ball, orbs(2), wd, psec, to, c1, stat)
  to%eps = 1.0e-6_wp
  call tube_cut(ball, orbs(2), wd, psec, to, c2, stat)
  call check_rel('eps 1e-5 vs 1e-6: areas agree to 1e-9', c1%area, c2%area, 1.0e-9_wp)

  ! the energy surface: A_E by QAGS vs the trapezoidal integral of the boundary 2 p_r,max(r)
  ! on a fine grid in the cos-substituted variable (a second, simpler quadrature)
  ray%ball = ball
  ray%energy = eqs(isad)%energy + 100
  call section_region(ray, 20.0_wp, stat)
  call check_eq('section region: status', stat, 0)
  call section_area(ray, a, err, stat)
  n = 20000
  a2 = 0
  do k = 1, n - 1
    s = PI*k/n
    h = ray%rmin + (ray%rmax - ray%rmin)*(1 - cos(s))/2
    a2 = a2 + 2*boundary_pr(ray, h)*(ray%rmax - ray%rmin)*sin(s)/2
  end do
  a2 = a2*PI/n
  ! trapezoid on a smooth periodic-like integrand (vanishing at both ends): error << 1e-8
  call check_rel('A_E by QAGS = trapezoid of the boundary', a, a2, 1.0e-8_wp)
  ! dA_E/dE against a central difference (step 0.5: error ~ h^2 A''' ~ 1e-6 relative)
  call section_area(ray, da, err, stat, derivative=.true.)
  ray%energy = eqs(isad)%energy + 100.5_wp
  call section_region(ray, 20.0_wp, stat)
  call section_area(ray, a2, err, stat)
  ray%energy = eqs(isad)%energy + 99.5_wp
  call section_region(ray, 20.0_wp, stat)
  call section_area(ray, e1, err, stat)
  call check_rel('dA_E/dE = central difference', da, (a2 - e1)/1.0_wp, 1.0e-5_wp)

  ! Monte Carlo at dE = 100: the cut predicts every outcome (tube dynamics), fraction near
  ! A_tube / A_E (a statistical check with 1500 points: within 4 standard errors)
  ray%energy = eqs(isad)%energy + 100
  call section_region(ray, 20.0_wp, stat)
  call section_area(ray, a, err, stat)
  to = tube_opts_t()
  to%area_tol = 1.0e-8_wp
  call tube_cut(ball, orbs(2), wd, psec, to, cut, stat)
  n = 1500
  allocate (r(n), pr(n), out(n), ins(n))
  ! the gate: 1.5 cm past S12 along its reaction coordinate, away from W1 (docs/tubes.md)
  gate%origin = eqs(isad)%q
  gate%normal = eqs(isad)%evec(1:2, 1)/norm2(eqs(isad)%evec(1:2, 1))
  if (dot_product(gate%normal, wd) > 0) gate%normal = -gate%normal
  gate%dist = 1.5_wp
  call psec%set_energy(eqs(isad)%energy + 100, 20.0_wp, stat)
  call monte_carlo(ball, psec, n, 7_c_long, gate, 20.0_wp, 1.0e-10_wp, integ_choice_t(), cut%r, cut%pr, &
                   r, pr, out, ins, stat)
  call check_eq('Monte Carlo: status', stat, 0)
  call check_eq('Monte Carlo: no misclassification (inside <=> transit)', &
                count(ins .neqv. (out == 1)), 0)
  s = sqrt(cut%area/a*(1 - cut%area/a)/n)
  call check_close('Monte Carlo fraction within 4 standard errors of p_trans', &
                   real(count(out == 1), wp)/n, cut%area/a, 4*s)
  call finish('test_tubes')
end program test_tubes
