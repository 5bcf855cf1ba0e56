!> Equilibria of the rolling ball on the paper's four-well surface (critical points of H):
!> count, Morse indices, names, residuals, symmetry, equal saddle energies, and the
!> linearized flow at the rank-1 saddles against closed forms. Then a symmetric variant
!> (xi = 0, beta = 0.8) whose equilibria are known in closed form. Units cm and s.
!>
!> Accuracy model used below. At a Newton-converged point the gradient is at roundoff:
!> its terms 2 alpha |x|, beta |x|/sx, xi |y| are <= ~2, so |grad H| ~ a few eps ~ 1e-15,
!> and the position is off by |grad H|/|kappa|_min ~ 1e-15/0.09 ~ 1e-14 cm. Heights are
!> sums of terms of total size S ~ 30 cm, good to a few eps S.
program test_equilibria
  use tubes_kinds, only: wp
  use tubes_status, only: TUBES_OK, TUBES_EINPUT, TUBES_ENOCONV
  use tubes_fourwell, only: fourwell_t
  use tubes_ball, only: ball_t, make_ball
  use tubes_equilibria, only: equilibrium_t, find_equilibria, rest_jacobian, quadrant, GRAD_TOL, &
                              MAX_EQUILIBRIA
  use tubes_check, only: check_close, check_rel, check_true, check_eq, finish
  use tubes_test_models, only: EPS, quartic_bath_t
  implicit none

  real(wp), parameter :: G = 981.0_wp           ! gravity [cm/s^2]
  real(wp), parameter :: RHO = 5.0_wp/7.0_wp    ! v = (5/7) M^-1 p (solid sphere)
  character(len=3), parameter :: NAMES(9) = ['W1 ', 'W2 ', 'W3 ', 'W4 ', 'S12', 'S14', &
                                             'S23', 'S34', 'R1 ']

  type(ball_t) :: ball
  type(fourwell_t) :: surf
  type(equilibrium_t), allocatable :: eqs(:), none(:)
  real(wp) :: gr(2), hs(2, 2), kap(2), lam, omg, jac(4, 4), v(4), jv(4), e_ref, q(2), qm(2)
  real(wp) :: ystar, fy, f0, fxq, fyq, proj
  integer :: stat, i, k, j, m
  character(80) :: lbl
  character(len=8) :: nm
  type(quartic_bath_t) :: qb
  character(:), allocatable :: emsg
  real(wp) :: gbound
  integer :: ig, ib
  integer, parameter :: GRIDS(5) = [3, 5, 21, 40, 41]
  real(wp), parameter :: BOXES(3) = [1.5_wp, 2.0_wp, 3.0_wp]

  surf = fourwell_t()
  call make_ball(ball, surf, G)

  ! --- input validation --------------------------------------------------------------------
  call find_equilibria(ball, [0.0_wp, 0.0_wp], [0.0_wp, 0.0_wp], 41, none, stat)
  call check_eq('find_equilibria: an empty box is TUBES_EINPUT', stat, TUBES_EINPUT)
  call find_equilibria(ball, [-20.0_wp, -20.0_wp], [20.0_wp, 20.0_wp], 1, none, stat)
  call check_eq('find_equilibria: n_grid = 1 is TUBES_EINPUT', stat, TUBES_EINPUT)

  ! --- the paper surface -------------------------------------------------------------------
  call find_equilibria(ball, [-20.0_wp, -20.0_wp], [20.0_wp, 20.0_wp], 41, eqs, stat)
  call check_eq('paper surface: status', stat, TUBES_OK)
  call check_eq('paper surface: 9 equilibria', size(eqs), 9)
  if (size(eqs) /= 9) call finish('test_equilibria')   ! the rest indexes 9 points
  call check_eq('paper surface: 4 wells (Morse 0)', count(eqs%morse == 0), 4)
  call check_eq('paper surface: 4 rank-1 saddles (Morse 1)', count(eqs%morse == 1), 4)
  call check_eq('paper surface: 1 rank-2 saddle (Morse 2)', count(eqs%morse == 2), 1)
  do k = 1, 9
    write (lbl, '(a,a)') 'paper surface: name present once: ', trim(NAMES(k))
    call check_eq(trim(lbl), count(eqs%name == NAMES(k)), 1)
  end do
  ! documented order: wells, rank-1, rank-2, each by name
  call check_true('paper surface: sorted W1 W2 W3 W4 S12 S14 S23 S34 R1', &
                  all([(eqs(k)%name == NAMES(k), k = 1, 9)]))

  do k = 1, 9
    nm = eqs(k)%name
    q = eqs(k)%q
    call surf%derivs(q(1), q(2), gr, hs)
    ! residual: roundoff level ~1e-15 (see the header); 1e-12 leaves a factor ~1000
    write (lbl, '(a,a)') 'gradient residual <= 1e-12 at ', trim(nm)
    call check_close(trim(lbl), norm2(gr), 0.0_wp, 1.0e-12_wp)
    write (lbl, '(a,a)') 'stored grad_norm = |grad H| at ', trim(nm)
    call check_close(trim(lbl), eqs(k)%grad_norm, norm2(gr), 1.0e-12_wp)
    ! the stored height and energy are those of q (same formula: a few ulps)
    write (lbl, '(a,a)') 'stored height = H(q) at ', trim(nm)
    call check_close(trim(lbl), eqs(k)%height, surf%height(q(1), q(2)), 4*EPS*40)
    write (lbl, '(a,a)') 'stored energy = g H(q) at ', trim(nm)
    call check_rel(trim(lbl), eqs(k)%energy, G*eqs(k)%height, 2*EPS)
    ! curvatures against the closed-form 2x2 eigenvalues; LAPACK's symmetric eigenvalues
    ! are good to ~eps |Hess|, |Hess| <= 0.2/cm
    kap = eig2(hs)
    write (lbl, '(a,a)') 'stored curvatures = closed-form Hessian eigenvalues at ', trim(nm)
    call check_close(trim(lbl), maxval(abs(eqs(k)%curv - kap)), 0.0_wp, 16*EPS*0.2_wp)
    write (lbl, '(a,a)') 'Morse index = number of negative curvatures at ', trim(nm)
    call check_eq(trim(lbl), eqs(k)%morse, count(kap < 0))
    ! wells and saddles sit where their names say
    select case (nm(1:1))
    case ('W')
      write (lbl, '(a,a)') 'well in its quadrant: ', trim(nm)
      call check_eq(trim(lbl), quadrant(q), ichar(nm(2:2)) - ichar('0'))
    case ('S')
      ! S_ij joins wells i and j, so it lies near the axis between their quadrants:
      ! S12 on +y, S14 on +x, S23 on -x, S34 on -y. With x small, H_x = 0 gives
      ! x = -xi y/(beta/sqrt(gamma) - 2 alpha) ~ -0.054 y: |off-axis| < 0.1 |on-axis|.
      select case (trim(nm))
      case ('S12'); m = 2; j = 1   ! on-axis coordinate y > 0
      case ('S14'); m = 1; j = 1   ! x > 0
      case ('S23'); m = 1; j = -1  ! x < 0
      case default; m = 2; j = -1  ! S34: y < 0
      end select
      write (lbl, '(a,a)') 'saddle next to the axis its name says: ', trim(nm)
      call check_true(trim(lbl), j*q(m) > 0 .and. abs(q(3 - m)) < 0.1_wp*abs(q(m)))
    end select
  end do
  ! S12 specifically: x < 0, y > 0 (the tilt -xi x y moves it off the y axis to x < 0)
  do j = 1, 9
    if (eqs(j)%name == 'S12') k = j
  end do
  call check_true('S12 at x < 0, y > 0, |x| < 0.1 y', &
                  eqs(k)%q(1) < 0 .and. eqs(k)%q(2) > 0 .and. abs(eqs(k)%q(1)) < 0.1_wp*eqs(k)%q(2))

  ! the four rank-1 saddles are images of each other under the symmetries of H, so their
  ! energies agree up to roundoff: positions off by ~1e-14 cm change H only to second
  ! order (grad H = 0), evaluation ~4 eps S g with S ~ 30 cm: ~1e-14 relative. 1e-12
  ! leaves a factor ~100.
  e_ref = eqs(5)%energy
  do k = 6, 8
    write (lbl, '(a,a)') 'rank-1 saddle energy equal to S12: ', trim(eqs(k)%name)
    call check_rel(trim(lbl), eqs(k)%energy, e_ref, 1.0e-12_wp)
  end do
  ! the start of test_dop853 lies 1500 (cm/s)^2 above the saddles: g H(4, 12.6148...) has
  ! terms of total size ~981*43 cm; 16 eps of that is 1.5e-10
  call check_close('start (4, 12.614863819914357) is 1500 (cm/s)^2 above the saddles', &
                   ball%energy([4.0_wp, 12.614863819914357_wp, 0.0_wp, 0.0_wp]) - e_ref, &
                   1500.0_wp, 16*EPS*G*43)

  ! symmetry: H(x, y) = H(y, x) = H(-x, -y); each image of an equilibrium must be an
  ! equilibrium of the same Morse index. Positions are good to ~1e-14 cm; 1e-10 is
  ! generous (a factor 1e4).
  do k = 1, 9
    do i = 1, 3
      select case (i)
      case (1); qm = [eqs(k)%q(2), eqs(k)%q(1)]
      case (2); qm = -eqs(k)%q
      case default; qm = -[eqs(k)%q(2), eqs(k)%q(1)]
      end select
      m = 0
      do j = 1, 9
        if (norm2(eqs(j)%q - qm) <= 1.0e-10_wp .and. eqs(j)%morse == eqs(k)%morse) m = j
      end do
      write (lbl, '(a,a,a,i0)') 'symmetric image is an equilibrium: ', trim(eqs(k)%name), &
        ', map ', i
      call check_true(trim(lbl), m > 0)
    end do
  end do

  ! --- linearization at the rank-1 saddles -----------------------------------------------
  ! At rest (p = 0, grad H = 0) the Jacobian is [[0, rho I], [-g K, 0]], K the Hessian, so
  ! mu^2 = -rho g kappa: lambda = sqrt(-rho g kappa_min), omega = sqrt(rho g kappa_max).
  ! dgeev is backward stable: eigenvalue error <= cond * eps * |J| with |J| ~ g |kappa|
  ! ~ 120/s^2 and cond = (mu^2 + rho^2)/(2 rho |mu|) ~ 6.4 for mu ~ 9/s: ~1.6e-13, i.e.
  ! ~2e-14 relative; 1e-12 leaves a factor 50.
  do k = 1, 9
    if (eqs(k)%morse /= 1) cycle
    nm = eqs(k)%name
    call surf%derivs(eqs(k)%q(1), eqs(k)%q(2), gr, hs)
    kap = eig2(hs)
    lam = sqrt(-RHO*G*kap(1))
    omg = sqrt(RHO*G*kap(2))
    write (lbl, '(a,a)') 'lambda = sqrt(-(5/7) g kappa_min) at ', trim(nm)
    call check_rel(trim(lbl), eqs(k)%lambda, lam, 1.0e-12_wp)
    write (lbl, '(a,a)') 'omega = sqrt((5/7) g kappa_max) at ', trim(nm)
    call check_rel(trim(lbl), eqs(k)%omega, omg, 1.0e-12_wp)
    call rest_jacobian(ball, eqs(k)%x, jac, stat)
    ! eigenvector residuals: dgeev's residual is ~eps |J| ~ 3e-14 for unit vectors; 1e-10
    ! is generous; scaled by |lambda| ~ 9/s it stays an absolute 1e-10 check
    v = eqs(k)%evec(:, 1)
    write (lbl, '(a,a)') 'J u = lambda u (unit u) at ', trim(nm)
    call check_close(trim(lbl), norm2(matmul(jac, v) - eqs(k)%lambda*v), 0.0_wp, 1.0e-10_wp)
    write (lbl, '(a,a)') '|u| = 1 at ', trim(nm)
    call check_close(trim(lbl), norm2(v), 1.0_wp, 4*EPS)
    v = eqs(k)%evec(:, 2)
    write (lbl, '(a,a)') 'J s = -lambda s (unit s) at ', trim(nm)
    call check_close(trim(lbl), norm2(matmul(jac, v) + eqs(k)%lambda*v), 0.0_wp, 1.0e-10_wp)
    ! centre pair: columns 3, 4 are Re c and Im c, each normalised to 1 separately, so
    ! J Re c = -omega Im c holds only up to the ratio of their norms; the invariants that
    ! survive: J^2 x = -omega^2 x for both, and J (Re c) parallel to Im c. Same residual
    ! model, relative to the scale omega^2 (~70/s^2) of J^2.
    do i = 3, 4
      v = eqs(k)%evec(:, i)
      jv = matmul(jac, v)
      write (lbl, '(a,i0,a,a)') 'J^2 x = -omega^2 x, centre column ', i, ' at ', trim(nm)
      call check_close(trim(lbl), norm2(matmul(jac, jv) + eqs(k)%omega**2*v), 0.0_wp, &
                       1.0e-10_wp*eqs(k)%omega**2)
      proj = dot_product(jv, eqs(k)%evec(:, 7 - i))   ! component along the other column
      write (lbl, '(a,i0,a,a)') 'J x parallel to the other centre column, column ', i, &
        ' at ', trim(nm)
      call check_close(trim(lbl), norm2(jv - proj*eqs(k)%evec(:, 7 - i)), 0.0_wp, &
                       1.0e-10_wp*eqs(k)%omega)
    end do
  end do

  ! --- a symmetric variant known in closed form: xi = 0, beta = 0.8 ---------------------
  ! H = f(x) + f(y) + h0 with f(s) = alpha s^2 - beta sqrt(s^2 + gamma); f'(s) = 0 at s = 0
  ! and s = +-y*, y*^2 = (beta/(2 alpha))^2 - gamma (needs beta > 2 alpha sqrt(gamma)):
  ! wells (+-y*, +-y*), rank-1 saddles (0, +-y*), (+-y*, 0), rank-2 at 0.
  ! f(y*) = -beta^2/(4 alpha) - alpha gamma, f(0) = -beta sqrt(gamma),
  ! f''(0) = 2 alpha - beta/sqrt(gamma) < 0, f''(y*) = 2 alpha (1 - 4 alpha^2 gamma/beta^2).
  surf = fourwell_t(xi=0.0_wp, beta=0.8_wp)
  call make_ball(ball, surf, G)
  call find_equilibria(ball, [-20.0_wp, -20.0_wp], [20.0_wp, 20.0_wp], 41, eqs, stat)
  call check_eq('xi = 0 variant: status', stat, TUBES_OK)
  call check_eq('xi = 0 variant: 9 equilibria', size(eqs), 9)
  if (size(eqs) /= 9) call finish('test_equilibria')
  call check_true('xi = 0 variant: names and order as for the paper surface', &
                  all([(eqs(k)%name == NAMES(k), k = 1, 9)]))
  ystar = sqrt((surf%beta/(2*surf%alpha))**2 - surf%gamma)
  fy = -surf%beta**2/(4*surf%alpha) - surf%alpha*surf%gamma
  f0 = -surf%beta*sqrt(surf%gamma)
  do k = 1, 9
    nm = eqs(k)%name
    select case (trim(nm))
    case ('W1'); q = [ystar, ystar]
    case ('W2'); q = [-ystar, ystar]
    case ('W3'); q = [-ystar, -ystar]
    case ('W4'); q = [ystar, -ystar]
    case ('S12'); q = [0.0_wp, ystar]
    case ('S14'); q = [ystar, 0.0_wp]
    case ('S23'); q = [-ystar, 0.0_wp]
    case ('S34'); q = [0.0_wp, -ystar]
    case default; q = [0.0_wp, 0.0_wp]
    end select
    ! position good to ~1e-14 cm (header); 1e-12 cm leaves a factor ~100
    write (lbl, '(a,a)') 'xi = 0: position = closed form at ', trim(nm)
    call check_close(trim(lbl), norm2(eqs(k)%q - q), 0.0_wp, 1.0e-12_wp)
    fxq = merge(fy, f0, q(1) /= 0)   ! f at the x coordinate
    fyq = merge(fy, f0, q(2) /= 0)
    ! energies: a few eps of g S with S ~ 30 cm, relative to E ~ 5000: ~1e-14; use 1e-12
    write (lbl, '(a,a)') 'xi = 0: energy = g (f(x) + f(y) + h0) at ', trim(nm)
    call check_rel(trim(lbl), eqs(k)%energy, G*(fxq + fyq + surf%h0), 1.0e-12_wp)
    if (eqs(k)%morse == 1) then
      ! closed-form curvatures at the saddle; eigenvalue accuracy as for the paper surface
      lam = sqrt(-RHO*G*(2*surf%alpha - surf%beta/sqrt(surf%gamma)))
      omg = sqrt(RHO*G*2*surf%alpha*(1 - 4*surf%alpha**2*surf%gamma/surf%beta**2))
      write (lbl, '(a,a)') 'xi = 0: lambda = sqrt(-(5/7) g f''''(0)) at ', trim(nm)
      call check_rel(trim(lbl), eqs(k)%lambda, lam, 1.0e-12_wp)
      write (lbl, '(a,a)') 'xi = 0: omega = sqrt((5/7) g f''''(y*)) at ', trim(nm)
      call check_rel(trim(lbl), eqs(k)%omega, omg, 1.0e-12_wp)
    end if
  end do

  ! --- degenerate equilibria (docs/models.md, "Degenerate equilibria") ----------------------
  ! V = -x^2/2 + x^4/4 + y^4/4: grad V = (x^3 - x, y^3) vanishes at (0, 0) and (+-1, 0), the
  ! Hessian diag(3x^2 - 1, 3y^2) is singular there (y: a root of multiplicity 3). Closed form:
  ! (+-1, 0) at V = -1/4, index 0 with a zero mode (not all centres: R1, R2); (0, 0) at V = 0,
  ! one real pair lambda = 1 and a zero mode: D1. Before the fix none was found, for every box
  ! and grid (the singular Hessian stopped Newton). Every box and grid with a start on the
  ! line x = 0 or near it finds the three, once each.
  qb = quartic_bath_t()
  do ib = 1, size(BOXES)
    do ig = 1, size(GRIDS)
      call find_equilibria(qb, [-BOXES(ib), -BOXES(ib)], [BOXES(ib), BOXES(ib)], GRIDS(ig), eqs, stat)
      write (lbl, '(a,f0.1,a,i0,a)') 'y^4/4: box ', BOXES(ib), ', n_grid ', GRIDS(ig), ': 3 equilibria'
      call check_eq(trim(lbl), merge(size(eqs), -1, stat == TUBES_OK), 3)
    end do
  end do
  call find_equilibria(qb, [-2.0_wp, -2.0_wp], [2.0_wp, 2.0_wp], 41, eqs, stat)
  call check_eq('y^4/4: status', stat, TUBES_OK)
  call check_eq('y^4/4: 3 equilibria', size(eqs), 3)
  if (size(eqs) /= 3) call finish('test_equilibria')
  call check_true('y^4/4: named R1, R2 (index 0, a zero mode), D1 (degenerate saddle)', &
                  eqs(1)%name == 'R1' .and. eqs(2)%name == 'R2' .and. eqs(3)%name == 'D1', &
                  eqs(1)%name//eqs(2)%name//eqs(3)%name)
  ! x: a simple root, to roundoff; y: a triple root, where Newton shrinks y by 2/3 a step until
  ! the step is below 1e-14: |y| < 1e-13. The stated bound is (GRAD_TOL G)^(1/3), G = the
  ! largest |grad V| on the grid (|(6, 8)| = 10 at the corner (2, 2)): 1e-3.
  gbound = (GRAD_TOL*10.0_wp)**(1.0_wp/3)
  do k = 1, 3
    q = [real(2*k - 3, wp), 0.0_wp]
    if (k == 3) q = 0
    write (lbl, '(a,a)') 'y^4/4: x = closed form at ', trim(eqs(k)%name)
    call check_close(trim(lbl), eqs(k)%q(1), q(1), 1.0e-14_wp)
    write (lbl, '(a,a)') 'y^4/4: |y| < 1e-13 (Newton to its step floor) at ', trim(eqs(k)%name)
    call check_close(trim(lbl), eqs(k)%q(2), 0.0_wp, 1.0e-13_wp)
    write (lbl, '(a,a)') 'y^4/4: |y| within the stated (GRAD_TOL G)^(1/3) at ', trim(eqs(k)%name)
    call check_close(trim(lbl), eqs(k)%q(2), 0.0_wp, gbound)
    write (lbl, '(a,a)') 'y^4/4: the location error estimate covers |y| at ', trim(eqs(k)%name)
    call check_true(trim(lbl), abs(eqs(k)%q(2)) <= 2*eqs(k)%location_error + 1.0e-15_wp)
    write (lbl, '(a,a)') 'y^4/4: energy -1/4 or 0 at ', trim(eqs(k)%name)
    call check_close(trim(lbl), eqs(k)%energy, merge(0.0_wp, -0.25_wp, k == 3), 4*EPS)
    write (lbl, '(a,a)') 'y^4/4: one zero mode at ', trim(eqs(k)%name)
    call check_eq(trim(lbl), eqs(k)%nzero, 1)
    write (lbl, '(a,a)') 'y^4/4: index at ', trim(eqs(k)%name)
    call check_eq(trim(lbl), eqs(k)%morse, merge(1, 0, k == 3))
    write (lbl, '(a,a)') 'y^4/4: residual <= GRAD_TOL G at ', trim(eqs(k)%name)
    call check_true(trim(lbl), eqs(k)%grad_norm <= GRAD_TOL*10.0_wp)
  end do
  call check_true('y^4/4: no rank-1 saddle', .not. any(eqs%rank1))
  call check_true('y^4/4: D1 degenerate, R1 and R2 not', eqs(3)%degenerate .and. .not. eqs(1)%degenerate &
                  .and. .not. eqs(2)%degenerate)
  call check_rel('y^4/4: D1 lambda = sqrt(-V_xx) = 1', eqs(3)%lambda, 1.0_wp, 1.0e-14_wp)
  call check_close('y^4/4: D1 omega = 0 (the zero mode)', eqs(3)%omega, 0.0_wp, 0.0_wp)
  call check_close('y^4/4: D1 curvatures -1, 0', maxval(abs(eqs(3)%curv - [-1.0_wp, 0.0_wp])), 0.0_wp, 1.0e-13_wp)

  ! A root of multiplicity 5 off the grid: V = -x^2/2 + x^4/4 + (y - 0.3)^6/6. Newton shrinks
  ! y - 0.3 by 4/5 a step; the three are found, at y = 0.3 within the stated bound
  ! (GRAD_TOL G)^(1/5), G = |grad V(2, -2)| = |(6, 2.3^5)| ~ 64.8: ~2e-2 (found: to 1e-13).
  qb = quartic_bath_t(s=0.3_wp, k=6)
  call find_equilibria(qb, [-2.0_wp, -2.0_wp], [2.0_wp, 2.0_wp], 41, eqs, stat)
  call check_eq('(y - 0.3)^6/6: status', stat, TUBES_OK)
  call check_eq('(y - 0.3)^6/6: 3 equilibria', size(eqs), 3)
  if (size(eqs) /= 3) call finish('test_equilibria')
  call check_true('(y - 0.3)^6/6: named R1, R2, D1', &
                  eqs(1)%name == 'R1' .and. eqs(2)%name == 'R2' .and. eqs(3)%name == 'D1')
  gbound = (GRAD_TOL*hypot(6.0_wp, 2.3_wp**5))**(1.0_wp/5)
  do k = 1, 3
    write (lbl, '(a,a)') '(y - 0.3)^6/6: y = 0.3 within the stated bound at ', trim(eqs(k)%name)
    call check_close(trim(lbl), eqs(k)%q(2), 0.3_wp, gbound)
    write (lbl, '(a,a)') '(y - 0.3)^6/6: y = 0.3 to 1e-12 (found) at ', trim(eqs(k)%name)
    call check_close(trim(lbl), eqs(k)%q(2), 0.3_wp, 1.0e-12_wp)
    write (lbl, '(a,a)') '(y - 0.3)^6/6: energy -1/4 or 0 at ', trim(eqs(k)%name)
    call check_close(trim(lbl), eqs(k)%energy, merge(0.0_wp, -0.25_wp, k == 3), 4*EPS)
  end do

  ! 3 DOF (the quartic bath of tests/test_normal_form.py with a double well in q1): the wells
  ! (+-1, 0, 0) were dropped by the old search on some grids; now R1, R2 and D1 (omegas 0, w).
  qb = quartic_bath_t()
  qb%nd = 3
  call find_equilibria(qb, [-1.0_wp, -1.0_wp, -1.0_wp], [1.0_wp, 1.0_wp, 1.0_wp], 5, eqs, stat)
  call check_eq('3 DOF quartic bath: status', stat, TUBES_OK)
  call check_eq('3 DOF quartic bath: 3 equilibria', size(eqs), 3)
  if (size(eqs) /= 3) call finish('test_equilibria')
  call check_true('3 DOF quartic bath: named R1, R2, D1', &
                  eqs(1)%name == 'R1' .and. eqs(2)%name == 'R2' .and. eqs(3)%name == 'D1')
  call check_close('3 DOF quartic bath: D1 at the origin', norm2(eqs(3)%q), 0.0_wp, 1.0e-13_wp)
  call check_close('3 DOF quartic bath: R1 at (-1, 0, 0)', norm2(eqs(1)%q - [-1.0_wp, 0.0_wp, 0.0_wp]), &
                   0.0_wp, 1.0e-13_wp)
  call check_close('3 DOF quartic bath: energies -1/4', maxval(abs(eqs(1:2)%energy + 0.25_wp)), 0.0_wp, 4*EPS)
  call check_close('3 DOF quartic bath: D1 omegas (0, 1.3)', maxval(abs(eqs(3)%omegas - [0.0_wp, 1.3_wp])), &
                   0.0_wp, 1.0e-13_wp)

  ! Nothing is dropped silently: more than MAX_EQUILIBRIA equilibria (cos x + cos y: one every
  ! pi, 39^2 in [-60, 60]^2) is TUBES_ENOCONV with errmsg saying so, not a truncated list.
  qb = quartic_bath_t(cosines=.true.)
  call find_equilibria(qb, [-60.0_wp, -60.0_wp], [60.0_wp, 60.0_wp], 121, eqs, stat, emsg)
  call check_eq('cos x + cos y in [-60, 60]^2: more than MAX_EQUILIBRIA is TUBES_ENOCONV', stat, TUBES_ENOCONV)
  call check_true('... errmsg says more than MAX_EQUILIBRIA', index(emsg, 'more than 256') > 0, emsg)
  call check_eq('... MAX_EQUILIBRIA is 256 (the C and Python tables)', MAX_EQUILIBRIA, 256)
  call find_equilibria(qb, [-7.0_wp, -7.0_wp], [7.0_wp, 7.0_wp], 41, eqs, stat)
  call check_eq('cos x + cos y in [-7, 7]^2: 25 equilibria (k pi, l pi), |k|, |l| <= 2', &
                merge(size(eqs), -1, stat == TUBES_OK), 25)

  call finish('test_equilibria')

contains

  !> Eigenvalues (ascending) of a symmetric 2x2 matrix in closed form:
  !> (a + d)/2 -+ sqrt(((a - d)/2)^2 + b^2). mean -+ r cancels only for an eigenvalue
  !> near 0; every curvature here is >= 0.06/cm in size against r <= 0.12/cm, so both
  !> come out to a few eps of |Hess|.
  pure function eig2(h) result(ev)
    real(wp), intent(in) :: h(2, 2)
    real(wp) :: ev(2), mean, r
    mean = (h(1, 1) + h(2, 2))/2
    r = hypot((h(1, 1) - h(2, 2))/2, h(1, 2))
    ev = [mean - r, mean + r]
  end function eig2

end program test_equilibria
