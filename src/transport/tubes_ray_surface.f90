!> The energy surface on a Poincare section theta = theta0 (a ray from the origin), in the
!> polar canonical coordinates (r, p_r): the permitted region p_r^2 <= (14/5)(E - gH(r))(1 + H_r^2)
!> (H_r = dH/dr along the ray), its area A_E(E) and dA_E/dE by GSL quadrature, and p_theta from
!> the energy. Derivation: docs/theory.md, "The energy surface on U1".
module tubes_ray_surface
  use, intrinsic :: iso_c_binding, only: c_double, c_int, c_ptr, c_loc, c_f_pointer, c_funptr, c_funloc
  use tubes_kinds, only: wp, PI
  use tubes_ball, only: ball_t, ROLL
  use tubes_status, only: TUBES_OK, TUBES_EINPUT, TUBES_ENOCONV
  use tubes_quad, only: quad_area, quad_root
  implicit none
  private


  !> A ball, an energy and a ray: the context of the quadrature callbacks.
  type, public :: ray_t
    type(ball_t) :: ball
    real(wp) :: theta0 = PI/4   !! the ray's angle [rad]
    real(wp) :: energy = 0      !! E [(cm/s)^2]
    real(wp) :: rmin = 0        !! the permitted interval on the ray [cm]
    real(wp) :: rmax = 0
    integer :: mode = 0         !! integrand: 0 area, 1 dA/dE
    integer :: root = 0         !! root function: 0 E - gH, 1 dH/dr (section_region)
  end type ray_t

  public :: ray_potential, ray_hr, section_region, section_area, boundary_pr, &
            p_theta_from

contains

  !> g H at distance r along the ray [(cm/s)^2].
  pure real(wp) function ray_potential(ray, r) result(v)
    type(ray_t), intent(in) :: ray
    real(wp), intent(in) :: r
    v = ray%ball%potential_xy(r*cos(ray%theta0), r*sin(ray%theta0))
  end function ray_potential

  !> dH/dr along the ray [1].
  pure real(wp) function ray_hr(ray, r) result(hr)
    type(ray_t), intent(in) :: ray
    real(wp), intent(in) :: r
    real(wp) :: gr(2), hs(2, 2)
    call ray%ball%surf%derivs(r*cos(ray%theta0), r*sin(ray%theta0), gr, hs)
    hr = cos(ray%theta0)*gr(1) + sin(ray%theta0)*gr(2)
  end function ray_hr

  !> The largest |p_r| at r on the energy surface: sqrt((14/5)(E - gH)(1 + H_r^2)) (0 outside).
  pure real(wp) function boundary_pr(ray, r) result(p)
    type(ray_t), intent(in) :: ray
    real(wp), intent(in) :: r
    p = sqrt(max(0.0_wp, (ray%energy - ray_potential(ray, r))*(1 + ray_hr(ray, r)**2)/ROLL*2))
  end function boundary_pr

  !> p_theta > 0 (branch = +1) or < 0 (-1) of the state at (r, p_r) on the ray with energy E:
  !> the roots of T(p_r, p_theta) = E - gH, a quadratic in s = p_theta / r with the polar
  !> components of M^-1 (docs/theory.md). stat = TUBES_EINPUT outside the region.
  subroutine p_theta_from(ray, r, pr, branch, pth, stat)
    type(ray_t), intent(in) :: ray
    real(wp), intent(in) :: r, pr
    integer, intent(in) :: branch
    real(wp), intent(out) :: pth
    integer, intent(out) :: stat
    real(wp) :: gr(2), hs(2, 2), hr, ht, d, a, b, c, k, disc, s
    call ray%ball%surf%derivs(r*cos(ray%theta0), r*sin(ray%theta0), gr, hs)
    hr = cos(ray%theta0)*gr(1) + sin(ray%theta0)*gr(2)        ! dH/dr
    ht = -sin(ray%theta0)*gr(1) + cos(ray%theta0)*gr(2)       ! (1/r) dH/dtheta
    d = 1 + hr*hr + ht*ht
    a = 1 - hr*hr/d
    b = -hr*ht/d
    c = 1 - ht*ht/d
    k = 2*(ray%energy - ray_potential(ray, r))/ROLL            ! (14/5)(E - V) = a pr^2 + 2 b pr s + c s^2
    disc = (b*pr)**2 - c*(a*pr*pr - k)
    stat = TUBES_OK
    pth = 0
    if (disc < 0) then
      stat = TUBES_EINPUT
      return
    end if
    s = (-b*pr + sign(1.0_wp, real(branch, wp))*sqrt(disc))/c
    pth = s*r
  end subroutine p_theta_from

  !> The function of r whose roots section_region finds (ray%root: 0 E - gH, 1 dH/dr).
  real(c_double) function f_root(r, user) bind(C)
    real(c_double), value :: r
    type(c_ptr), value :: user
    type(ray_t), pointer :: ray
    call c_f_pointer(user, ray)
    if (ray%root == 1) then
      f_root = ray_hr(ray, r)
    else
      f_root = ray%energy - ray_potential(ray, r)
    end if
  end function f_root

  !> The permitted interval [rmin, rmax] of the ray around the well on it: the minimum of gH
  !> along the ray in (0, rfar] (Brent on dH/dr), then the roots of E - gH on either side
  !> (rmin = 0 if E exceeds gH at the origin). stat = TUBES_EINPUT if E is below the well.
  subroutine section_region(ray, rfar, stat)
    type(ray_t), intent(inout), target :: ray
    real(wp), intent(in) :: rfar      !! outer end of the search [cm]
    integer, intent(out) :: stat
    real(wp) :: rw, a, b
    integer :: k, n
    n = 400
    ! the well: the first sign change of dH/dr from - to + on a grid, refined by Brent
    rw = -1
    do k = 1, n - 1
      a = rfar*k/n
      b = rfar*(k + 1)/n
      if (ray_hr(ray, a) < 0 .and. ray_hr(ray, b) >= 0) then
        ray%root = 1
        stat = quad_root(c_funloc(f_root), c_loc(ray), a, b, 0.0_wp, 1.0e-15_wp, rw)
        if (stat /= 0) then
          stat = TUBES_ENOCONV
          return
        end if
        exit
      end if
    end do
    if (rw < 0 .or. ray%energy <= ray_potential(ray, max(rw, 0.0_wp))) then
      stat = TUBES_EINPUT
      return
    end if
    ray%root = 0                      ! from here the roots of E - gH
    if (ray%energy >= ray_potential(ray, 0.0_wp)) then
      ray%rmin = 0
    else
      stat = quad_root(c_funloc(f_root), c_loc(ray), 0.0_wp, rw, 0.0_wp, 1.0e-15_wp, ray%rmin)
      if (stat /= 0) then
        stat = TUBES_ENOCONV
        return
      end if
    end if
    b = rw
    do while (ray%energy >= ray_potential(ray, b))
      b = b + 1
      if (b > 100*rfar) then
        stat = TUBES_EINPUT
        return
      end if
    end do
    stat = quad_root(c_funloc(f_root), c_loc(ray), rw, b, 0.0_wp, 1.0e-15_wp, ray%rmax)
    if (stat /= 0) stat = TUBES_ENOCONV
  end subroutine section_region

  !> Integrand after r = rmin + (rmax - rmin)(1 - cos phi)/2, which removes the square-root
  !> behaviour at the ends: mode 0 gives A_E, mode 1 dA_E/dE.
  real(c_double) function f_area(phi, user) bind(C)
    real(c_double), value :: phi
    type(c_ptr), value :: user
    type(ray_t), pointer :: ray
    real(wp) :: r, drdphi, gap, w
    call c_f_pointer(user, ray)
    r = ray%rmin + (ray%rmax - ray%rmin)*(1 - cos(phi))/2
    drdphi = (ray%rmax - ray%rmin)*sin(phi)/2
    gap = max(ray%energy - ray_potential(ray, r), 0.0_wp)
    w = 2*(1 + ray_hr(ray, r)**2)/ROLL               ! (14/5)(1 + H_r^2)
    if (ray%mode == 0) then
      f_area = 2*sqrt(w*gap)*drdphi                  ! 2 p_r,max dr
    else if (gap > 0) then
      f_area = sqrt(w/gap)*drdphi                    ! d/dE of the above
    else
      f_area = 0
    end if
  end function f_area

  !> A_E = area of the permitted region on the ray's section [cm^2/s], or with derivative its
  !> dA_E/dE [s], at the ray's energy (its interval must be set by section_region). GSL QAGS to
  !> relative 1e-12.
  subroutine section_area(ray, area, abserr, stat, derivative)
    type(ray_t), intent(inout), target :: ray
    real(wp), intent(out) :: area, abserr
    integer, intent(out) :: stat
    logical, intent(in), optional :: derivative
    ray%mode = 0
    if (present(derivative)) ray%mode = merge(1, 0, derivative)
    stat = quad_area(c_funloc(f_area), c_loc(ray), 0.0_wp, PI, area, abserr)
    if (stat /= 0) stat = TUBES_ENOCONV
  end subroutine section_area
end module tubes_ray_surface
