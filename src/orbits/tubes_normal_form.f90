!> The Birkhoff normal form of a Hamiltonian about a saddle x centre^(N-1) equilibrium, by Lie
!> transforms, and the flux through the bottleneck from it (docs/theory.md, "The normal form").
!>
!> Input: the Taylor expansion of H at the equilibrium z_s = (q_s, p_s) to total degree K, exact
!> (from the computer-algebra layer, python/tubes/codegen.py --taylor; no finite differences).
!> 1. The quadratic part H2 = 1/2 z^T M z is brought to lambda x1 y1 + sum_k omega_k/2 (x_k^2 + y_k^2)
!>    by a real symplectic matrix C built from the eigenvectors of J M (checked: |C^T J C - J|).
!> 2. The centre pairs are complexified, x = (xi + i eta)/sqrt 2, y = (i xi + eta)/sqrt 2 (a
!>    symplectic change), so that H2 = sum_k nu_k xi_k eta_k, nu = (lambda, i omega_2, ...).
!> 3. For n = 3 .. K the generator W_n, w = h / <nu, a - b> for every monomial xi^a eta^b of
!>    degree n with a /= b, removes the degree-n non-normal terms; H <- exp(L_W) H with
!>    L_W H = {H, W}, truncated at degree K. A monomial with <nu, a - b> = 0 and a coefficient
!>    that is not zero is a resonance: refused, naming it.
!> 4. What is left is a polynomial in the actions I_1 = xi_1 eta_1 and J_k = i xi_k eta_k; on the
!>    NHIM (I_1 = 0) the flux is (2 pi)^(N-1) times the volume of {J >= 0: H_NF(0, J) - E_s <= dE}
!>    (MacKay 1990; Waalkens, Schubert & Wiggins 2008): 2 pi J(dE) in 2 DOF, (2 pi)^2 times an
!>    area (GSL QAGS over J_2 of the root J_3 by Brent) in 3 DOF.
module tubes_normal_form
  use, intrinsic :: iso_c_binding, only: c_double, c_ptr, c_loc, c_f_pointer, c_funloc
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan, ieee_is_finite
  use tubes_kinds, only: wp, PI
  use tubes_status, only: TUBES_OK, TUBES_EINPUT, TUBES_ENOCONV
  use tubes_lapack, only: eigen
  use tubes_quad, only: quad_qags, quad_root
  use tubes_equilibria, only: sort_indices
  implicit none
  private

  complex(wp), parameter :: IU = (0.0_wp, 1.0_wp)
  integer, parameter, public :: NF_MAX_DOF = 3
  integer, parameter :: MAX_KEYS = 20000000    !! (K+1)^(2N) monomial keys at most

  !> Monomials of degree 0..kmax in nv = 2N variables (x_1..x_N, y_1..y_N), by degree.
  type :: space_t
    integer :: nv = 0, nd = 0, kmax = 0, nmon = 0
    integer, allocatable :: expo(:, :)      !! (nv, nmon)
    integer, allocatable :: deg(:)          !! (nmon)
    integer, allocatable :: first(:)        !! (0:kmax+1): monomials of degree d are first(d):first(d+1)-1
    integer, allocatable :: lookup(:)       !! key (base kmax+1) -> index
    integer, allocatable :: pw(:)           !! (nv) key weights
  end type space_t

  !> The result: the normal form on the actions, and the checks.
  type, public :: nf_result_t
    integer :: ndof = 0, order = 0
    real(wp) :: lambda = 0
    real(wp) :: omegas(NF_MAX_DOF - 1) = 0
    integer :: nterms = 0                      !! H_NF = sum_t coef(t) I_1^e(1,t) J_2^e(2,t) ...
    integer, allocatable :: expo(:, :)         !! (ndof, nterms)
    real(wp), allocatable :: coef(:)           !! (nterms), the constant E_s included
    real(wp) :: symplectic_error = 0           !! max |C^T J C - J|
    real(wp) :: residual = 0                   !! largest non-normal coefficient left (degree <= K)
    real(wp) :: imaginary = 0                  !! largest |Im| of a normal-form coefficient
    real(wp) :: smallest_divisor = 0           !! min |<nu, a - b>| over the removed monomials
    character(len=256) :: message = ''
    !> with nhim_de: points of the NHIM at each of those energies mapped to the model's
    !> coordinates, dz = z - z_s (2N, NF_NPTS, size(nhim_de)), and the largest round-trip error
    !> |new(old(zeta)) - zeta| of the normal form's coordinate change and its inverse there
    real(wp), allocatable :: nhim(:, :, :)
    real(wp), allocatable :: round_trip(:)
  end type nf_result_t
  integer, parameter, public :: NF_NPTS = 8    !! NHIM points per energy

  type :: area_t                               !! data of the 3-DOF area integrand
    type(nf_result_t), pointer :: nf => null()
    real(wp) :: de = 0, j2 = 0
    integer :: stat = TUBES_OK
    integer :: k = 1                           !! the action f_action_gap varies: 1 J_2 (J_3 = 0), 2 J_3
  end type area_t

  !> The normal form's coordinate change (old from new, Lie series of degree K - 1) and its
  !> inverse, with the linear change C: new real normal-form coordinates w = (x_1..x_N, y_1..y_N)
  !> (x_1 unstable, y_1 stable, (x_k, y_k) a centre) map to dz = z - z_s (nf_to_model).
  type, public :: nf_change_t
    type(space_t) :: s
    complex(wp), allocatable :: fwd(:, :), inv(:, :)   !! (nmon, 2N)
    real(wp), allocatable :: c(:, :)                   !! (2N, 2N)
  end type nf_change_t

  public :: normal_form, nf_flux, nf_action_energy, normal_form_flux, nf_to_model, nf_nhim_point, nf_from_model, &
            nf_map_points

contains

  subroutine space_init(s, nd, kmax, stat)
    type(space_t), intent(out) :: s
    integer, intent(in) :: nd, kmax
    integer, intent(out) :: stat
    integer :: d, k, m, e(2*NF_MAX_DOF), nk
    stat = TUBES_EINPUT
    s%nd = nd
    s%nv = 2*nd
    s%kmax = kmax
    if (real(kmax + 1, wp)**s%nv > MAX_KEYS) return
    nk = (kmax + 1)**s%nv
    allocate (s%pw(s%nv), s%lookup(0:nk - 1), s%first(0:kmax + 1))
    s%pw = [((kmax + 1)**(k - 1), k = 1, s%nv)]
    s%lookup = 0
    ! count, then list by degree (odometer over exponent vectors)
    m = 0
    do k = 0, nk - 1
      if (sum(key_digits(k)) <= kmax) m = m + 1
    end do
    s%nmon = m
    allocate (s%expo(s%nv, m), s%deg(m))
    m = 0
    do d = 0, kmax
      s%first(d) = m + 1
      do k = 0, nk - 1
        e(1:s%nv) = key_digits(k)
        if (sum(e(1:s%nv)) == d) then
          m = m + 1
          s%expo(:, m) = e(1:s%nv)
          s%deg(m) = d
          s%lookup(k) = m
        end if
      end do
    end do
    s%first(kmax + 1) = m + 1
    stat = TUBES_OK
  contains
    pure function key_digits(key) result(dg)
      integer, intent(in) :: key
      integer :: dg(2*nd), r, i
      r = key
      do i = 1, 2*nd
        dg(i) = mod(r, kmax + 1)
        r = r/(kmax + 1)
      end do
    end function key_digits
  end subroutine space_init

  pure integer function idx(s, e)
    type(space_t), intent(in) :: s
    integer, intent(in) :: e(:)
    idx = s%lookup(sum(e*s%pw))
  end function idx

  !> h = {f, g} truncated at degree dmax: sum_k f_xk g_yk - f_yk g_xk.
  subroutine bracket(s, f, g, dmax, h)
    type(space_t), intent(in) :: s
    complex(wp), intent(in) :: f(:), g(:)
    integer, intent(in) :: dmax
    complex(wp), intent(out) :: h(:)
    integer, allocatable :: nf(:), ng(:)
    integer :: i, j, k, n, e(2*NF_MAX_DOF), c
    n = s%nd
    h = 0
    nf = pack([(i, i = 1, s%nmon)], f /= 0)
    ng = pack([(i, i = 1, s%nmon)], g /= 0)
    do i = 1, size(nf)
      do j = 1, size(ng)
        if (s%deg(nf(i)) + s%deg(ng(j)) - 2 > dmax) cycle
        do k = 1, n
          c = s%expo(k, nf(i))*s%expo(n + k, ng(j)) - s%expo(n + k, nf(i))*s%expo(k, ng(j))
          if (c == 0) cycle
          e(1:2*n) = s%expo(:, nf(i)) + s%expo(:, ng(j))
          e(k) = e(k) - 1
          e(n + k) = e(n + k) - 1
          h(idx(s, e(1:2*n))) = h(idx(s, e(1:2*n))) + c*f(nf(i))*g(ng(j))
        end do
      end do
    end do
  end subroutine bracket

  !> The normal form of H given by its Taylor coefficients at the equilibrium: coef(t) for the
  !> monomial dz^expo(:, t), dz = (dq_1..dq_N, dp_1..dp_N), degrees 0..order.
  !> stat: TUBES_EINPUT for bad arguments, or an equilibrium that is not a saddle x centres (a
  !> zero or repeated frequency, a centre of negative energy, ...); TUBES_ENOCONV for a resonance
  !> in the terms; the reason in res%message.
  subroutine normal_form(nd, order, expo, coef, res, stat, nhim_de, change)
    integer, intent(in) :: nd, order
    integer, intent(in) :: expo(:, :)
    real(wp), intent(in) :: coef(:)
    type(nf_result_t), intent(out), target :: res
    integer, intent(out) :: stat
    real(wp), intent(in), optional :: nhim_de(:)   !! energies of NHIM points to map (res%nhim)
    type(nf_change_t), intent(out), optional :: change   !! the coordinate change, kept
    type(space_t) :: s
    type(nf_change_t) :: ch
    complex(wp), allocatable :: h(:), w(:), t(:), u(:), gens(:, :)
    real(wp) :: m(2*NF_MAX_DOF, 2*NF_MAX_DOF), jm(2*NF_MAX_DOF, 2*NF_MAX_DOF), c(2*NF_MAX_DOF, 2*NF_MAX_DOF)
    real(wp) :: jj(2*NF_MAX_DOF, 2*NF_MAX_DOF), a(2*NF_MAX_DOF, 2*NF_MAX_DOF), scale
    complex(wp) :: p(2*NF_MAX_DOF, 2*NF_MAX_DOF), nu(NF_MAX_DOF), dv
    integer :: nv, i, j, k, n, ist, e(2*NF_MAX_DOF)
    logical :: normal
    stat = TUBES_EINPUT
    res%ndof = nd
    res%order = order
    nv = 2*nd
    if (nd < 2 .or. nd > NF_MAX_DOF .or. order < 2 .or. size(expo, 1) /= nv .or. &
        size(expo, 2) /= size(coef)) then
      res%message = 'normal form: 2 or 3 degrees of freedom and an order of at least 2'
      return
    end if
    call space_init(s, nd, order, ist)
    if (ist /= TUBES_OK) then
      write (res%message, '(a,i0,a,i0,a)') 'normal form: order ', order, ' in ', nd, &
        ' degrees of freedom needs too many monomials: lower &flux order'
      return
    end if
    ! the quadratic part: M = d2H/dz2
    m = 0
    do k = 1, size(coef)
      if (sum(expo(:, k)) /= 2) cycle
      i = findloc(expo(:, k) > 0, .true., 1)
      j = findloc(expo(:, k) > 0, .true., 1, back=.true.)
      if (i == j) then
        m(i, i) = 2*coef(k)
      else
        m(i, j) = coef(k)
        m(j, i) = coef(k)
      end if
    end do
    jj = 0
    do i = 1, nd
      jj(i, nd + i) = 1
      jj(nd + i, i) = -1
    end do
    jm(1:nv, 1:nv) = matmul(jj(1:nv, 1:nv), m(1:nv, 1:nv))
    call symplectic_basis(nd, jm(1:nv, 1:nv), jj(1:nv, 1:nv), c(1:nv, 1:nv), res, ist)
    if (ist /= TUBES_OK) return
    a(1:nv, 1:nv) = matmul(transpose(c(1:nv, 1:nv)), matmul(jj(1:nv, 1:nv), c(1:nv, 1:nv))) - jj(1:nv, 1:nv)
    res%symplectic_error = maxval(abs(a(1:nv, 1:nv)))
    ! dz = C T zeta: T complexifies the centre pairs
    p = 0
    do i = 1, nv
      p(i, 1) = c(i, 1)
      p(i, nd + 1) = c(i, nd + 1)
      do k = 2, nd
        p(i, k) = (c(i, k) + IU*c(i, nd + k))/sqrt(2.0_wp)
        p(i, nd + k) = (IU*c(i, k) + c(i, nd + k))/sqrt(2.0_wp)
      end do
    end do
    nu(1) = res%lambda
    nu(2:nd) = IU*res%omegas(1:nd - 1)
    ! H(zeta): every term a product of linear forms
    allocate (h(s%nmon), w(s%nmon), t(s%nmon), u(s%nmon))
    h = 0
    do k = 1, size(coef)
      if (sum(expo(:, k)) > order .or. any(expo(:, k) < 0)) cycle
      t = 0
      t(1) = coef(k)
      do i = 1, nv
        do j = 1, expo(i, k)
          call times_linear(s, t, p(i, 1:nv), u)
          t = u
        end do
      end do
      h = h + t
    end do
    ! Lie transforms, degree by degree
    allocate (gens(s%nmon, 3:max(order, 3)))
    gens = 0
    scale = max(abs(res%lambda), maxval(res%omegas(1:nd - 1)))
    res%smallest_divisor = huge(1.0_wp)
    do n = 3, order
      w = 0
      do k = s%first(n), s%first(n + 1) - 1
        e(1:nv) = s%expo(:, k)
        if (all(e(1:nd) == e(nd + 1:nv))) cycle
        dv = sum(nu(1:nd)*(e(1:nd) - e(nd + 1:nv)))
        if (abs(dv) <= 1.0e-9_wp*scale) then
          if (abs(h(k)) > 1.0e-12_wp*max(1.0_wp, maxval(abs(h)))) then
            call resonance_message(nd, e(1:nv), res)
            stat = TUBES_ENOCONV
            return
          end if
          cycle
        end if
        res%smallest_divisor = min(res%smallest_divisor, abs(dv))
        w(k) = h(k)/dv
      end do
      gens(:, n) = w
      call lie_series(s, h, w, order)
    end do
    ! what is left: the normal part and the residual
    res%residual = 0
    res%imaginary = 0
    allocate (res%expo(nd, s%nmon), res%coef(s%nmon))
    res%nterms = 0
    do k = 1, s%nmon
      e(1:nv) = s%expo(:, k)
      normal = all(e(1:nd) == e(nd + 1:nv))
      if (.not. normal) then
        res%residual = max(res%residual, abs(h(k)))
        cycle
      end if
      if (h(k) == 0) cycle
      ! xi_k eta_k = -i J_k (k >= 2), xi_1 eta_1 = I_1
      dv = h(k)*(-IU)**sum(e(2:nd))
      res%imaginary = max(res%imaginary, abs(aimag(dv)))
      res%nterms = res%nterms + 1
      res%expo(:, res%nterms) = e(1:nd)
      res%coef(res%nterms) = real(dv, wp)
    end do
    ! max() above may drop a NaN coefficient: report it (the diagnostics are printed and written)
    if (.not. all(ieee_is_finite(real(h, wp)) .and. ieee_is_finite(aimag(h)))) then
      res%residual = ieee_value(1.0_wp, ieee_quiet_nan)
      res%imaginary = res%residual
    end if
    if (res%smallest_divisor == huge(1.0_wp)) res%smallest_divisor = 0
    stat = TUBES_OK
    if (.not. (present(nhim_de) .or. present(change))) return
    call make_change(s, gens, c(1:nv, 1:nv), ch)
    if (present(nhim_de)) call nhim_points(ch, res, nhim_de)
    if (present(change)) change = ch
  end subroutine normal_form

  !> The coordinate change old = phi_3 o ... o phi_K (new) and its inverse as polynomials of
  !> degree K - 1 in the complex coordinates, with C.
  subroutine make_change(s, gens, c, ch)
    type(space_t), intent(in) :: s
    complex(wp), intent(in) :: gens(:, 3:)
    real(wp), intent(in) :: c(:, :)
    type(nf_change_t), intent(out) :: ch
    integer :: i, n, kmax
    kmax = ubound(gens, 2)
    ch%s = s
    ch%c = c
    allocate (ch%fwd(s%nmon, s%nv), ch%inv(s%nmon, s%nv))
    do i = 1, s%nv
      ch%fwd(:, i) = 0
      ch%fwd(i + 1, i) = 1            ! the degree-1 monomials follow the constant, in variable order
      ch%inv(:, i) = ch%fwd(:, i)
      do n = 3, kmax                  ! old = phi_3 o ... o phi_K (new)
        call lie_series(s, ch%fwd(:, i), gens(:, n), s%kmax - 1)
      end do
      do n = kmax, 3, -1              ! new = phi_K^-1 o ... o phi_3^-1 (old)
        call lie_series(s, ch%inv(:, i), -gens(:, n), s%kmax - 1)
      end do
    end do
  end subroutine make_change

  !> Real normal-form coordinates w -> complex (xi, eta): the hyperbolic pair as it is, each
  !> centre by the inverse of x = (xi + i eta)/sqrt 2, y = (i xi + eta)/sqrt 2.
  pure function to_complex(nd, w) result(z)
    integer, intent(in) :: nd
    real(wp), intent(in) :: w(:)
    complex(wp) :: z(2*nd)
    integer :: i
    z(1) = w(1)
    z(nd + 1) = w(nd + 1)
    do i = 2, nd
      z(i) = (w(i) - IU*w(nd + i))/sqrt(2.0_wp)
      z(nd + i) = (w(nd + i) - IU*w(i))/sqrt(2.0_wp)
    end do
  end function to_complex

  !> The model's dz = C w(old), w(old) the real coordinates of old(zn).
  function complex_to_model(ch, zn) result(dz)
    type(nf_change_t), intent(in) :: ch
    complex(wp), intent(in) :: zn(:)
    real(wp) :: dz(ch%s%nv)
    complex(wp) :: zo(ch%s%nv), w(ch%s%nv)
    real(wp) :: wr(ch%s%nv)
    integer :: i, nd
    nd = ch%s%nd
    do i = 1, ch%s%nv
      zo(i) = poly_at(ch%s, ch%fwd(:, i), zn)
    end do
    w(1) = zo(1)
    w(nd + 1) = zo(nd + 1)
    do i = 2, nd
      w(i) = (zo(i) + IU*zo(nd + i))/sqrt(2.0_wp)
      w(nd + i) = (IU*zo(i) + zo(nd + i))/sqrt(2.0_wp)
    end do
    wr = real(w, wp)            ! a named array: matmul of real(w) drew gfortran 12's -Wuninitialized
    dz = matmul(ch%c, wr)
  end function complex_to_model

  !> dz = z - z_s of the point with real normal-form coordinates w (x_1..x_N, y_1..y_N).
  function nf_to_model(ch, w) result(dz)
    type(nf_change_t), intent(in) :: ch
    real(wp), intent(in) :: w(:)
    real(wp) :: dz(ch%s%nv)
    dz = complex_to_model(ch, to_complex(ch%s%nd, w))
  end function nf_to_model

  !> The real normal-form coordinates w of the model's point dz = z - z_s: w(old) = C^-1 dz
  !> (C^-1 = -J C^T J, C symplectic), complexified, through the inverse change, back to real
  !> (the imaginary parts left are the change's roundoff).
  function nf_from_model(ch, dz) result(w)
    type(nf_change_t), intent(in) :: ch
    real(wp), intent(in) :: dz(:)
    real(wp) :: w(ch%s%nv)
    real(wp) :: jj(ch%s%nv, ch%s%nv), wo(ch%s%nv)
    complex(wp) :: zo(ch%s%nv), zn(ch%s%nv)
    integer :: i, nd, nv
    nd = ch%s%nd
    nv = ch%s%nv
    jj = 0
    do i = 1, nd
      jj(i, nd + i) = 1
      jj(nd + i, i) = -1
    end do
    wo = -matmul(jj, matmul(transpose(ch%c), matmul(jj, dz)))
    zo = to_complex(nd, wo)
    do i = 1, nv
      zn(i) = poly_at(ch%s, ch%inv(:, i), zo)
    end do
    w(1) = real(zn(1), wp)
    w(nd + 1) = real(zn(nd + 1), wp)
    do i = 2, nd
      w(i) = real((zn(i) + IU*zn(nd + i))/sqrt(2.0_wp), wp)
      w(nd + i) = real((IU*zn(i) + zn(nd + i))/sqrt(2.0_wp), wp)
    end do
  end function nf_from_model

  !> Points mapped by the normal form's change (to_model: pts are real normal-form coordinates
  !> (x_1..x_N, y_1..y_N), out = z - z_s; else pts are z - z_s, out normal-form coordinates), each
  !> with its round trip |back(out) - pts| (max norm).
  subroutine nf_map_points(ch, to_model, pts, out, round_trip)
    type(nf_change_t), intent(in) :: ch
    logical, intent(in) :: to_model
    real(wp), intent(in) :: pts(:, :)
    real(wp), intent(out) :: out(:, :), round_trip(:)
    integer :: k
    do k = 1, size(pts, 2)
      if (to_model) then
        out(:, k) = nf_to_model(ch, pts(:, k))
        round_trip(k) = maxval(abs(nf_from_model(ch, out(:, k)) - pts(:, k)))
      else
        out(:, k) = nf_from_model(ch, pts(:, k))
        round_trip(k) = maxval(abs(nf_to_model(ch, out(:, k)) - pts(:, k)))
      end if
    end do
  end subroutine nf_map_points

  !> The point of the NHIM at E_s + de with the actions' split eta (3 DOF: J_2 = sin^2(eta) times
  !> its largest, J_3 from H_NF(0, J) - E_s = de; 2 DOF: eta ignored) and the angles th(1:N-1),
  !> stepped off to y_1 = y1 on the stable manifold x_1 = 0 (H_NF there is H_NF(0, J): the same
  !> energy): dz = z - z_s. stat TUBES_ENOCONV if the actions have no root there.
  subroutine nf_nhim_point(nf, ch, de, eta, th, y1, dz, stat)
    type(nf_result_t), intent(in), target :: nf
    type(nf_change_t), intent(in) :: ch
    real(wp), intent(in) :: de, eta, th(:), y1
    real(wp), intent(out) :: dz(:)
    integer, intent(out) :: stat
    type(area_t), target :: ar
    real(wp) :: j2max, jj(2), w(2*NF_MAX_DOF)
    integer :: nd, i
    nd = nf%ndof
    dz = ieee_value(1.0_wp, ieee_quiet_nan)
    ar%nf => nf
    ar%de = de
    call action_root(ar, 0.0_wp, 1, j2max, stat)
    if (stat /= TUBES_OK) return
    jj = [j2max, 0.0_wp]
    if (nd == 3) then
      jj(1) = j2max*sin(eta)**2
      jj(2) = 0
      ar%j2 = jj(1)
      if (gap(ar, 2, 0.0_wp) > 0) then
        call action_root(ar, jj(1), 2, jj(2), stat)
        if (stat /= TUBES_OK) return
      end if
    end if
    w = 0
    w(nd + 1) = y1
    do i = 2, nd
      w(i) = sqrt(2*jj(i - 1))*cos(th(i - 1))
      w(nd + i) = sqrt(2*jj(i - 1))*sin(th(i - 1))
    end do
    dz = nf_to_model(ch, w(1:2*nd))
  end subroutine nf_nhim_point

  !> f <- exp(L_W) f = f + {f, W} + {{f, W}, W}/2 + ..., truncated at degree dmax.
  subroutine lie_series(s, f, w, dmax)
    type(space_t), intent(in) :: s
    complex(wp), intent(inout) :: f(:)
    complex(wp), intent(in) :: w(:)
    integer, intent(in) :: dmax
    complex(wp) :: t(size(f)), u(size(f))
    integer :: j
    if (all(w == 0)) return
    t = f
    do j = 1, dmax
      call bracket(s, t, w, dmax, u)
      t = u/j
      if (all(t == 0)) exit
      f = f + t
    end do
  end subroutine lie_series

  !> The value of the polynomial f at the complex point zeta.
  pure complex(wp) function poly_at(s, f, zeta) result(v)
    type(space_t), intent(in) :: s
    complex(wp), intent(in) :: f(:), zeta(:)
    integer :: k
    v = 0
    do k = 1, s%nmon
      if (f(k) /= 0) v = v + f(k)*product(zeta**s%expo(:, k))
    end do
  end function poly_at

  !> NF_NPTS points of the NHIM (I_1 = 0) at each energy of de: actions on H_NF(0, J) - E_s = dE
  !> (3 DOF: J_2 from 0 to its largest, J_3 from the boundary), angles spread; mapped to the
  !> model's coordinates by the normal form's change (the Lie series of the coordinates, degree
  !> K - 1), and back by its inverse: res%nhim (dz) and res%round_trip.
  subroutine nhim_points(ch, res, de)
    type(nf_change_t), intent(in) :: ch
    type(nf_result_t), intent(inout), target :: res
    real(wp), intent(in) :: de(:)
    complex(wp) :: zn(ch%s%nv), zo(ch%s%nv), zb(ch%s%nv)
    type(area_t), target :: ar
    real(wp) :: jj(2), th, j2max, rt, w(ch%s%nv)
    integer :: nd, nv, i, k, m, st
    nd = ch%s%nd
    nv = ch%s%nv
    allocate (res%nhim(nv, NF_NPTS, size(de)), res%round_trip(size(de)))
    res%nhim = ieee_value(1.0_wp, ieee_quiet_nan)
    res%round_trip = ieee_value(1.0_wp, ieee_quiet_nan)
    ar%nf => res
    do m = 1, size(de)
      ar%de = de(m)
      call action_root(ar, 0.0_wp, 1, j2max, st)
      if (st /= TUBES_OK) cycle
      rt = 0
      do k = 1, NF_NPTS
        th = 2*PI*(k - 1)/NF_NPTS
        if (nd == 2) then
          jj(1) = j2max
        else
          jj(1) = j2max*(k - 1)/(NF_NPTS - 1)
          call action_root(ar, jj(1), 2, jj(2), st)
          if (st /= TUBES_OK) jj(2) = 0
        end if
        w = 0
        do i = 2, nd
          w(i) = sqrt(2*jj(i - 1))*cos(th*(i - 1) + 0.7_wp*(i - 2))
          w(nd + i) = sqrt(2*jj(i - 1))*sin(th*(i - 1) + 0.7_wp*(i - 2))
        end do
        zn = to_complex(nd, w)
        do i = 1, nv
          zo(i) = poly_at(ch%s, ch%fwd(:, i), zn)
        end do
        do i = 1, nv
          zb(i) = poly_at(ch%s, ch%inv(:, i), zo)
        end do
        rt = max(rt, maxval(abs(zb - zn)))
        res%nhim(:, k, m) = complex_to_model(ch, zn)
      end do
      res%round_trip(m) = rt
    end do
  end subroutine nhim_points

  !> u = t * (sum_j l(j) zeta_j)
  subroutine times_linear(s, t, l, u)
    type(space_t), intent(in) :: s
    complex(wp), intent(in) :: t(:), l(:)
    complex(wp), intent(out) :: u(:)
    integer :: i, j, e(2*NF_MAX_DOF)
    u = 0
    do i = 1, s%nmon
      if (t(i) == 0 .or. s%deg(i) >= s%kmax) cycle
      do j = 1, s%nv
        if (l(j) == 0) cycle
        e(1:s%nv) = s%expo(:, i)
        e(j) = e(j) + 1
        u(idx(s, e(1:s%nv))) = u(idx(s, e(1:s%nv))) + t(i)*l(j)
      end do
    end do
  end subroutine times_linear

  !> Columns of C: x_1 = u+ (eigenvalue lambda), x_k = a (Re of the eigenvector of i omega_k),
  !> y_1 = u- (-lambda), y_k = b, scaled so that C^T J C = J.
  subroutine symplectic_basis(nd, jm, jj, c, res, stat)
    integer, intent(in) :: nd
    real(wp), intent(in) :: jm(:, :), jj(:, :)
    real(wp), intent(out) :: c(:, :)
    type(nf_result_t), intent(inout) :: res
    integer, intent(out) :: stat
    real(wp) :: wr(2*nd), wi(2*nd), vr(2*nd, 2*nd), scale, sy
    integer :: ip, im, k, nc, ic(nd), nv
    character(len=24) :: buf
    nv = 2*nd
    call eigen(jm, wr, wi, stat, vr)
    if (stat /= TUBES_OK) then
      res%message = 'normal form: the eigenvalues of the linearisation failed (LAPACK dgeev)'
      stat = TUBES_EINPUT
      return
    end if
    stat = TUBES_EINPUT
    scale = max(maxval(abs(wr)), maxval(abs(wi)))
    ip = maxloc(wr, 1)
    im = minloc(wr, 1)
    nc = 0
    do k = 1, nv
      if (wi(k) > 1.0e-8_wp*scale .and. abs(wr(k)) <= 1.0e-8_wp*scale) then
        nc = nc + 1
        if (nc <= nd) ic(nc) = k
      end if
    end do
    if (.not. wr(ip) > 1.0e-8_wp*scale .or. abs(wi(ip)) > 1.0e-8_wp*scale .or. nc /= nd - 1 .or. &
        count(abs(wr) > 1.0e-8_wp*scale) /= 2) then
      if (count(abs(wr) <= 1.0e-8_wp*scale .and. abs(wi) <= 1.0e-8_wp*scale) > 0) then
        res%message = 'normal form: the equilibrium is degenerate (an eigenvalue 0: a mode without a ' // &
                      'quadratic term, e.g. a quartic bath); no Birkhoff normal form exists there ' // &
                      '(the sampled flux does not need one)'
      else
        res%message = 'normal form: the equilibrium is not a saddle x centre^(N-1) (one real pair ' // &
                      '+-lambda and N-1 imaginary pairs +-i omega)'
      end if
      return
    end if
    res%lambda = wr(ip)
    call sort_indices(ic(1:nc), wi)     ! ascending frequencies
    do k = 1, nc - 1
      if (wi(ic(k + 1)) - wi(ic(k)) <= 1.0e-9_wp*scale) then
        res%message = 'normal form: two equal frequencies (a 1:1 resonance of the centres): not supported'
        return
      end if
    end do
    c = 0
    c(:, 1) = vr(:, ip)
    c(:, nd + 1) = vr(:, im)
    sy = dot_product(c(:, 1), matmul(jj, c(:, nd + 1)))
    if (abs(sy) <= 1.0e-12_wp*sqrt(sum(c(:, 1)**2)*sum(c(:, nd + 1)**2))) then
      res%message = 'normal form: the hyperbolic eigenvectors are not symplectically paired'
      return
    end if
    c(:, nd + 1) = c(:, nd + 1)/sy
    do k = 1, nc
      res%omegas(k) = wi(ic(k))
      c(:, k + 1) = vr(:, ic(k))
      c(:, nd + k + 1) = vr(:, ic(k) + 1)
      sy = dot_product(c(:, k + 1), matmul(jj, c(:, nd + k + 1)))
      if (.not. sy > 0) then
        write (buf, '(es12.5)') wi(ic(k))
        res%message = 'normal form: the centre of frequency ' // trim(adjustl(buf)) // &
                      ' has negative energy (a gyroscopic saddle): not supported'
        return
      end if
      c(:, k + 1) = c(:, k + 1)/sqrt(sy)
      c(:, nd + k + 1) = c(:, nd + k + 1)/sqrt(sy)
    end do
    stat = TUBES_OK
  end subroutine symplectic_basis

  subroutine resonance_message(nd, e, res)
    integer, intent(in) :: nd, e(:)
    type(nf_result_t), intent(inout) :: res
    character(len=160) :: lhs, vals
    integer :: k
    lhs = ''
    vals = ''
    do k = 2, nd
      write (lhs(len_trim(lhs) + 1:), '(a,sp,i0,ss,a,i0)') ' ', e(k) - e(nd + k), ' omega_', k
      write (vals(len_trim(vals) + 1:), '(a,i0,a,g0.6)') merge(', ', '  ', k > 2), k, ' = ', res%omegas(k - 1)
    end do
    res%message = 'normal form: a resonance of the centre frequencies,' // trim(lhs) // ' = 0 (omega_' // &
                  trim(adjustl(vals)) // '), with a term that does not vanish: no Birkhoff normal form ' // &
                  '(lower &flux order or use the sampled flux)'
  end subroutine resonance_message

  !> The normal form (normal_form) and its flux at de(:) (nf_flux): flux(k) NaN with fstat(k) its
  !> status where the truncated form has no bounded region; all NaN if the normal form is refused
  !> (stat, res%message). The one path of the program (src/capi/tubes_capi.f90) and of Python.
  subroutine normal_form_flux(nd, order, expo, coef, de, res, flux, fstat, stat)
    integer, intent(in) :: nd, order
    integer, intent(in) :: expo(:, :)
    real(wp), intent(in) :: coef(:), de(:)
    type(nf_result_t), intent(out) :: res
    real(wp), intent(out) :: flux(:)
    integer, intent(out) :: fstat(:), stat
    integer :: k
    flux = ieee_value(1.0_wp, ieee_quiet_nan)
    fstat = TUBES_EINPUT
    call normal_form(nd, order, expo, coef, res, stat, de)
    if (stat /= TUBES_OK) return
    do k = 1, size(de)
      call nf_flux(res, de(k), flux(k), fstat(k))
      if (fstat(k) /= TUBES_OK) flux(k) = ieee_value(1.0_wp, ieee_quiet_nan)
    end do
  end subroutine normal_form_flux

  !> H_NF(0, J) - E_s at the actions J(1:N-1) (the NHIM: I_1 = 0).
  pure real(wp) function nf_action_energy(nf, j) result(h)
    type(nf_result_t), intent(in) :: nf
    real(wp), intent(in) :: j(:)
    integer :: t
    h = 0
    do t = 1, nf%nterms
      if (nf%expo(1, t) /= 0 .or. all(nf%expo(:, t) == 0)) cycle
      h = h + nf%coef(t)*product(j(1:nf%ndof - 1)**nf%expo(2:nf%ndof, t))
    end do
  end function nf_action_energy

  !> The flux (2 pi)^(N-1) vol{J >= 0: H_NF(0, J) - E_s <= de}. stat TUBES_ENOCONV where the
  !> truncated normal form has no such bounded region (de beyond the series' reach).
  subroutine nf_flux(nf, de, flux, stat)
    type(nf_result_t), intent(in), target :: nf
    real(wp), intent(in) :: de
    real(wp), intent(out) :: flux
    integer, intent(out) :: stat
    type(area_t), target :: ar
    real(wp) :: j2max, area, aerr
    flux = 0
    stat = TUBES_EINPUT
    if (.not. de > 0) return
    ar%nf => nf
    ar%de = de
    select case (nf%ndof)
    case (2)
      call action_root(ar, 0.0_wp, 1, j2max, stat)
      flux = 2*PI*j2max
    case (3)
      call action_root(ar, 0.0_wp, 1, j2max, stat)
      if (stat /= TUBES_OK) return
      stat = quad_qags(c_funloc(f_j3), c_loc(ar), 0.0_wp, j2max, 0.0_wp, 1.0e-12_wp, area, aerr)
      if (stat /= 0 .or. ar%stat /= TUBES_OK) then
        stat = TUBES_ENOCONV
        return
      end if
      flux = (2*PI)**2*area
      stat = TUBES_OK
    end select
  end subroutine nf_flux

  !> The action J_k >= 0 where H_NF(0, J) - E_s = de with the other action fixed (k = 1: J_2 with
  !> J_3 = 0 in 3 DOF; k = 2: J_3 at J_2 = other): Brent on a bracket found by doubling.
  subroutine action_root(ar, other, k, root, stat)
    type(area_t), intent(inout), target :: ar
    real(wp), intent(in) :: other
    integer, intent(in) :: k
    real(wp), intent(out) :: root
    integer, intent(out) :: stat
    real(wp) :: hi, om
    integer :: it
    stat = TUBES_ENOCONV
    root = 0
    ar%j2 = other
    om = ar%nf%omegas(k)
    hi = 2*ar%de/om
    do it = 1, 60
      if (gap(ar, k, hi) < 0) exit
      hi = 2*hi
    end do
    if (.not. gap(ar, k, hi) < 0 .or. gap(ar, k, 0.0_wp) < 0) return
    ar%k = k
    stat = quad_root(c_funloc(f_action_gap), c_loc(ar), 0.0_wp, hi, 0.0_wp, 1.0e-14_wp, root)
    if (stat /= 0) stat = TUBES_ENOCONV
  end subroutine action_root

  !> de - (H_NF - E_s) at action x of index k (the other fixed as ar%j2).
  real(wp) function gap(ar, k, x)
    type(area_t), intent(in) :: ar
    integer, intent(in) :: k
    real(wp), intent(in) :: x
    real(wp) :: j(2)
    if (k == 1) then
      j = [x, 0.0_wp]
    else
      j = [ar%j2, x]
    end if
    gap = ar%de - nf_action_energy(ar%nf, j(1:ar%nf%ndof - 1))
  end function gap

  real(c_double) function f_action_gap(x, user) bind(C)
    real(c_double), value :: x
    type(c_ptr), value :: user
    type(area_t), pointer :: ar
    call c_f_pointer(user, ar)
    f_action_gap = gap(ar, ar%k, x)
  end function f_action_gap

  !> J_3 at the boundary over J_2 = x (0 past the region).
  real(c_double) function f_j3(x, user) bind(C)
    real(c_double), value :: x
    type(c_ptr), value :: user
    type(area_t), pointer :: ar
    type(area_t), target :: loc
    real(wp) :: r
    integer :: st
    call c_f_pointer(user, ar)
    loc = ar
    loc%j2 = x
    f_j3 = 0
    if (gap(loc, 2, 0.0_wp) <= 0) return
    call action_root(loc, x, 2, r, st)
    if (st /= TUBES_OK) ar%stat = st
    f_j3 = r
  end function f_j3
end module tubes_normal_form
