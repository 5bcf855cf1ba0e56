!> Every model of the library through the abstract Hamiltonian (tubes_hamiltonian): the analytic
!> gradient against central differences of H, the analytic Hessian against central differences
!> of the gradient and its symmetry, Hamilton's equations (eval) against J grad H and the
!> Jacobian against J Hess H, the reversor (f(R x) = -R f(x)), the natural systems' shape and
!> kinetic matrix against H itself, and the damping wrapper. Models are built by name from the
!> library's table (tubes_models), as the program builds them.
program test_hamiltonians
  use tubes_kinds, only: wp
  use tubes_hamiltonian, only: hamiltonian_t, natural_t, damped_t, make_damped
  use tubes_models, only: make_model, system_info, system_info_t, system_name, NSYSTEMS, MAX_PARAMS
  use tubes_check, only: check_close, check_true, check_eq, finish
  implicit none
  class(hamiltonian_t), allocatable :: m
  type(system_info_t) :: info
  real(wp) :: params(MAX_PARAMS), d, scale, e0, ep, em
  real(wp), allocatable :: x(:), states(:, :), g(:), gfd(:), h(:, :), hfd(:, :), f(:), fj(:), jac(:, :), &
                           xp(:), xm(:), gp(:), gm(:), a(:, :), gr(:), hs(:, :), rf(:)
  integer, allocatable :: rev(:)
  integer :: k, j, st, is, n2, nd
  type(damped_t) :: damped
  character(80) :: lbl
  character(32) :: name

  do is = 1, NSYSTEMS
    name = system_name(is)
    call system_info(trim(name), info, st)
    params = 0
    do k = 1, info%np
      params(k) = info%params(k)%default
    end do
    call make_model(trim(name), params, m, st)
    call check_eq(trim(name)//': built from the table', st, 0)
    if (st /= 0) cycle
    n2 = m%dim()
    nd = n2/2
    call check_eq(trim(name)//': 2N = 2 ndof', n2, 2*info%ndof)
    if (allocated(x)) deallocate (x, states, g, gfd, h, hfd, f, fj, jac, xp, xm, gp, gm, a, gr, hs, rf, rev)
    allocate (x(n2), states(n2, 3), g(n2), gfd(n2), h(n2, n2), hfd(n2, n2), f(n2), fj(n2), jac(n2, n2), &
              xp(n2), xm(n2), gp(n2), gm(n2), a(nd, nd), gr(nd), hs(nd, nd), rf(n2), rev(n2))
    ! three generic states inside each model's domain (scaled to its length scale)
    scale = m%length_scale()
    if (nd == 2) then
      states(:, 1) = [0.31_wp, -0.17_wp, 0.23_wp, -0.41_wp]
      states(:, 2) = [-0.52_wp, 0.44_wp, -0.12_wp, 0.35_wp]
      states(:, 3) = [0.05_wp, 0.61_wp, 0.7_wp, 0.2_wp]
    else
      states(:, 1) = [0.31_wp, -0.17_wp, 0.13_wp, 0.23_wp, -0.41_wp, 0.09_wp]
      states(:, 2) = [-0.52_wp, 0.44_wp, -0.21_wp, -0.12_wp, 0.35_wp, 0.27_wp]
      states(:, 3) = [0.05_wp, 0.61_wp, 0.3_wp, 0.7_wp, 0.2_wp, -0.33_wp]
    end if
    if (trim(name) == 'rolling_ball') states(1:2, :) = 10*states(1:2, :)
    if (trim(name) == 'rolling_ball') states(3:4, :) = 50*states(3:4, :)
    if (trim(name) == 'cr3bp' .or. trim(name) == 'cr3bp_spatial') &
      states(1, :) = states(1, :) + 0.6_wp     ! away from the primaries
    do j = 1, 3
      x = states(:, j)
      call m%gradient(x, g, st)
      call check_eq(trim(name)//': gradient status', st, 0)
      ! central differences, step d ~ eps^(1/3) |x|: truncation ~ d^2 H''' and roundoff ~
      ! eps |H| / d, both ~ 1e-10 relative to the gradient's scale; 1e-7 leaves a margin
      do k = 1, n2
        d = 1.0e-5_wp*max(1.0_wp, abs(x(k)))
        xp = x
        xm = x
        xp(k) = x(k) + d
        xm(k) = x(k) - d
        gfd(k) = (m%energy(xp) - m%energy(xm))/(2*d)
        call m%gradient(xp, gp, st)
        call m%gradient(xm, gm, st)
        hfd(:, k) = (gp - gm)/(2*d)
      end do
      write (lbl, '(a,a,i0)') trim(name), ': gradient = differences of H, state ', j
      call check_close(trim(lbl), maxval(abs(g - gfd))/max(1.0_wp, maxval(abs(g))), 0.0_wp, 1.0e-7_wp)
      call m%hessian(x, h, st)
      write (lbl, '(a,a,i0)') trim(name), ': Hessian = differences of the gradient, state ', j
      call check_close(trim(lbl), maxval(abs(h - hfd))/max(1.0_wp, maxval(abs(h))), 0.0_wp, 1.0e-7_wp)
      write (lbl, '(a,a,i0)') trim(name), ': Hessian symmetric, state ', j
      call check_close(trim(lbl), maxval(abs(h - transpose(h)))/max(1.0_wp, maxval(abs(h))), 0.0_wp, &
                       1.0e-13_wp)   ! the ball's comes from its Jacobian: a few roundoffs
      ! Hamilton's equations and their Jacobian: exact relations, to roundoff
      call m%eval(0.0_wp, x, f, st)
      fj = [g(nd + 1:n2), -g(1:nd)]
      write (lbl, '(a,a,i0)') trim(name), ': eval = J grad H, state ', j
      call check_close(trim(lbl), maxval(abs(f - fj))/max(1.0_wp, maxval(abs(f))), 0.0_wp, 1.0e-13_wp)
      call m%jacobian(0.0_wp, x, jac, st)
      write (lbl, '(a,a,i0)') trim(name), ': Jacobian = J Hess H, state ', j
      call check_close(trim(lbl), maxval(abs(jac(1:nd, :) - h(nd + 1:n2, :)) + abs(jac(nd + 1:n2, :) + h(1:nd, :))) &
                       /max(1.0_wp, maxval(abs(jac))), 0.0_wp, 1.0e-13_wp)
      ! the reversor maps solutions to solutions: f(R x) = -R f(x)
      rev = m%reversor()
      if (any(rev /= 0)) then
        call m%eval(0.0_wp, rev*x, rf, st)
        write (lbl, '(a,a,i0)') trim(name), ': f(R x) = -R f(x), state ', j
        call check_close(trim(lbl), maxval(abs(rf + rev*f)), 0.0_wp, 1.0e-12_wp*max(1.0_wp, maxval(abs(f))))
      end if
      ! natural systems: H = 1/2 p^T A p + V, with V's gradient that of the shape x the scale
      select type (m)
      class is (natural_t)
        call m%kinetic_matrix(x(1:nd), a)
        call m%shape_derivs(x(1:nd), gr, hs)
        write (lbl, '(a,a,i0)') trim(name), ': H = 1/2 p^T A p + V, state ', j
        call check_close(trim(lbl), m%energy(x), 0.5_wp*dot_product(x(nd + 1:n2), matmul(a, x(nd + 1:n2))) &
                         + m%potential(x(1:nd)), 1.0e-12_wp*max(1.0_wp, abs(m%energy(x))))
        write (lbl, '(a,a,i0)') trim(name), ': dH/dq at p = 0 is grad V, state ', j
        xp = 0
        xp(1:nd) = x(1:nd)
        call m%gradient(xp, g, st)
        call check_close(trim(lbl), maxval(abs(g(1:nd) - m%potential_scale()*gr)), 0.0_wp, &
                         1.0e-12_wp*max(1.0_wp, maxval(abs(g(1:nd)))))
      end select
    end do
    ! damping: dE/dt = -c p . dH/dp along the damped field (a finite difference along f)
    call make_damped(damped, m, 0.3_wp)
    x = states(:, 1)
    call damped%eval(0.0_wp, x, f, st)
    call m%gradient(x, g, st)
    d = 1.0e-6_wp
    e0 = m%energy(x)
    ep = m%energy(x + d*f)
    em = m%energy(x - d*f)
    write (lbl, '(a,a)') trim(name), ': damped dE/dt = -c p . dH/dp'
    call check_close(trim(lbl), (ep - em)/(2*d), -0.3_wp*dot_product(x(nd + 1:n2), g(nd + 1:n2)), &
                     1.0e-6_wp*max(1.0_wp, abs(e0)))
  end do
  call finish('test_hamiltonians')
end program test_hamiltonians
