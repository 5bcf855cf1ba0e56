!> The Fortran interface of src/base/tubes_quad_shim.c: GSL's adaptive quadrature (QAGS), Brent's
!> root finder, the periodic cubic spline's enclosed area and the MT19937 uniform stream. The
!> integrands are bind(C) functions f(x, user) of a user pointer; every call is thread-safe. Also
!> the closed polygon's shoelace sum (polygon_area, in Fortran).
module tubes_quad
  use, intrinsic :: iso_c_binding, only: c_int, c_long, c_double, c_ptr, c_funptr
  use tubes_kinds, only: wp
  implicit none
  private
  public :: quad_qags, quad_root, spline_area, rng_uniform, quad_area, polygon_area

  interface
    !> The integral of f over [a, b] to max(epsabs, epsrel |result|): the GSL status.
    integer(c_int) function quad_qags(f, user, a, b, epsabs, epsrel, result, abserr) &
        bind(C, name='tubes_quad_qags')
      import :: c_int, c_double, c_ptr, c_funptr
      type(c_funptr), value :: f
      type(c_ptr), value :: user
      real(c_double), value :: a, b, epsabs, epsrel
      real(c_double), intent(out) :: result, abserr
    end function quad_qags
    !> A root of f in [a, b] (f(a), f(b) of opposite signs) by Brent's method: the GSL status.
    integer(c_int) function quad_root(f, user, a, b, epsabs, epsrel, root) &
        bind(C, name='tubes_quad_root')
      import :: c_int, c_double, c_ptr, c_funptr
      type(c_funptr), value :: f
      type(c_ptr), value :: user
      real(c_double), value :: a, b, epsabs, epsrel
      real(c_double), intent(out) :: root
    end function quad_root
    !> The integral of p dr around the closed curve (r(tau), p(tau)), tau in [tau(1), tau(1) +
    !> period), through periodic cubic splines of its n samples: 0, or the GSL status.
    integer(c_int) function spline_area(n, tau, r, p, period, area) bind(C, name='tubes_spline_area')
      import :: c_int, c_double
      integer(c_int), value :: n
      real(c_double), intent(in) :: tau(*), r(*), p(*)
      real(c_double), value :: period
      real(c_double), intent(out) :: area
    end function spline_area
    !> n uniform numbers in [0, 1) from a new MT19937 stream of seed: 0, or non-zero on failure.
    integer(c_int) function rng_uniform(seed, n, u) bind(C, name='tubes_rng_uniform')
      import :: c_int, c_double, c_long
      integer(c_long), value :: seed
      integer(c_int), value :: n
      real(c_double), intent(out) :: u(*)
    end function rng_uniform
  end interface
contains

  !> The integral of f over [a, b] by QAGS to relative 1e-12 (an area of the energy surface on a
  !> section, or its dE derivative): 0, or GSL's status. Where QAGS cannot certify 1e-12 (its
  !> roundoff or subdivision limit: an integrand that falls to 0 in the last rounding-wide sliver
  !> of a very narrow region) but its own error estimate is within 1e-9 of the result, the result
  !> is taken (0): A_E and tau are then good to 1e-9 of themselves, as the tube areas they divide
  !> (area_tol 1e-8 by default, 1e-10 in the tightest runs) need.
  integer function quad_area(f, user, a, b, result, abserr) result(stat)
    use, intrinsic :: iso_c_binding, only: c_double
    type(c_funptr), value :: f
    type(c_ptr), value :: user
    real(c_double), value :: a, b
    real(c_double), intent(out) :: result, abserr
    stat = int(quad_qags(f, user, a, b, 0.0_c_double, 1.0e-12_c_double, result, abserr))
    if (stat /= 0 .and. abs(result) <= huge(1.0_c_double) .and. abserr <= 1.0e-9_c_double*abs(result)) stat = 0
  end function quad_area

  !> The shoelace sum of the closed polygon through (s(i), p(i)), i = 1 .. n (its last vertex
  !> joined to its first): the enclosed area, positive when the polygon turns counter-clockwise in
  !> the (s, p) plane (then minus the integral of p ds around it, by Green).
  pure real(wp) function polygon_area(s, p) result(a)
    real(wp), intent(in) :: s(:), p(:)
    integer :: i, j
    a = 0
    do i = 1, size(s)
      j = mod(i, size(s)) + 1
      a = a + 0.5_wp*(s(i)*p(j) - s(j)*p(i))
    end do
  end function polygon_area
end module tubes_quad
