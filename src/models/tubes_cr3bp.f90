!> The planar circular restricted three-body problem in the rotating frame (V. Szebehely,
!> Theory of Orbits, 1967; W. S. Koon, M. W. Lo, J. E. Marsden and S. D. Ross, Dynamical Systems,
!> the Three-Body Problem and Space Mission Design, 2011), in units where the primaries' distance,
!> total mass and angular velocity are 1:
!>   H = (px^2 + py^2)/2 + y px - x py - (1 - mu)/r1 - mu/r2,
!>   r1 = |(x + mu, y)| (the primary 1 - mu), r2 = |(x - 1 + mu, y)| (the secondary mu).
!> Gyroscopic, not natural: at the equilibria L1..L5 the momenta are p = (-y, x). The Jacobi
!> constant is C = -2 H. The reversor (x, y, px, py, t) -> (x, -y, -px, py, -t) maps solutions to
!> solutions; the Lyapunov orbits of L1 and L2 are symmetric under it.
!> Spatial (nd = 3, the system cr3bp_spatial, or cr3bp with spatial = .true.): the state is
!> (x, y, z, px, py, pz), H = |p|^2/2 + y px - x py - (1 - mu)/r1 - mu/r2 with r1 = |(x + mu, y, z)|,
!> r2 = |(x - 1 + mu, y, z)|; the reversor (x, -y, z, -px, py, -pz); L1..L5 lie in z = 0, where
!> the vertical mode decouples: its frequency omega_v = sqrt(c2) (Koon et al. 2011, ch. 6).
module tubes_cr3bp
  use tubes_kinds, only: wp
  use tubes_hamiltonian, only: hamiltonian_t, NAMES_LAGRANGE, BLOWUP_Q
  implicit none
  private

  real(wp), parameter :: MIN_R = 1.0e-100_wp   !! closer to a primary than this: a collision, refused

  !> The CR3BP with mass ratio mu (its default lives in tubes_models).
  type, extends(hamiltonian_t), public :: cr3bp_t
    real(wp) :: mu   !! mass ratio m2/(m1 + m2), 0 < mu <= 1/2 (nd, inherited: 2 planar, 3 spatial)
  contains
    procedure :: energy => cr_energy, gradient => cr_gradient, hessian => cr_hessian
    procedure :: naming => cr_naming, reversor => cr_reversor, length_scale => cr_length_scale
    procedure :: jacobi_factor => cr_jacobi_factor
  end type cr3bp_t

contains

  pure real(wp) function cr_energy(self, x)
    class(cr3bp_t), intent(in) :: self
    real(wp), intent(in) :: x(:)
    real(wp) :: r1, r2
    if (self%nd == 3) then
      r1 = norm2([x(1) + self%mu, x(2), x(3)])
      r2 = norm2([x(1) - 1 + self%mu, x(2), x(3)])
      cr_energy = 0.5_wp*(x(4)**2 + x(5)**2 + x(6)**2) + x(2)*x(4) - x(1)*x(5) - (1 - self%mu)/r1 - self%mu/r2
      return
    end if
    r1 = hypot(x(1) + self%mu, x(2))
    r2 = hypot(x(1) - 1 + self%mu, x(2))
    cr_energy = 0.5_wp*(x(3)**2 + x(4)**2) + x(2)*x(3) - x(1)*x(4) - (1 - self%mu)/r1 - self%mu/r2
  end function cr_energy

  !> dH/dx = (-py + U_x, px + U_y, px + y, py - x), U = -(1 - mu)/r1 - mu/r2; spatial:
  !> (-py + U_x, px + U_y, U_z, px + y, py - x, pz).
  pure subroutine cr_gradient(self, x, g, stat)
    class(cr3bp_t), intent(in) :: self
    real(wp), intent(in) :: x(:)
    real(wp), intent(out) :: g(:)
    integer, intent(out) :: stat
    real(wp) :: r1, r2, a1, a2
    logical :: ok
    integer :: nd
    nd = self%nd
    call cr_distances(self, x, r1, r2, ok)
    stat = 0
    g(1:2*nd) = 0
    if (.not. ok) then
      stat = -1
      return
    end if
    a1 = (1 - self%mu)/r1**3
    a2 = self%mu/r2**3
    g(1) = -x(nd + 2) + a1*(x(1) + self%mu) + a2*(x(1) - 1 + self%mu)
    g(2) = x(nd + 1) + (a1 + a2)*x(2)
    if (nd == 3) g(3) = (a1 + a2)*x(3)
    g(nd + 1) = x(nd + 1) + x(2)
    g(nd + 2) = x(nd + 2) - x(1)
    if (nd == 3) g(6) = x(6)
    if (.not. all(abs(g(1:2*nd)) <= huge(1.0_wp))) stat = -1
  end subroutine cr_gradient

  !> The distances r1, r2 from the primaries (hypot planar, norm2 spatial); ok: neither is a
  !> collision (MIN_R) and |q|_1 <= BLOWUP_Q.
  pure subroutine cr_distances(self, x, r1, r2, ok)
    class(cr3bp_t), intent(in) :: self
    real(wp), intent(in) :: x(:)
    real(wp), intent(out) :: r1, r2
    logical, intent(out) :: ok
    if (self%nd == 3) then
      r1 = norm2([x(1) + self%mu, x(2), x(3)])
      r2 = norm2([x(1) - 1 + self%mu, x(2), x(3)])
      ok = min(r1, r2) > MIN_R .and. abs(x(1)) + abs(x(2)) + abs(x(3)) <= BLOWUP_Q
    else
      r1 = hypot(x(1) + self%mu, x(2))
      r2 = hypot(x(1) - 1 + self%mu, x(2))
      ok = min(r1, r2) > MIN_R .and. abs(x(1)) + abs(x(2)) <= BLOWUP_Q
    end if
  end subroutine cr_distances

  !> U_xx = sum_i m_i (1/r_i^3 - 3 dx_i^2/r_i^5), U_xy = -sum_i 3 m_i dx_i y/r_i^5,
  !> U_yy = sum_i m_i (1/r_i^3 - 3 y^2/r_i^5); H_{x,py} = -1, H_{y,px} = 1, H_{p,p} = I.
  pure subroutine cr_hessian(self, x, h, stat)
    class(cr3bp_t), intent(in) :: self
    real(wp), intent(in) :: x(:)
    real(wp), intent(out) :: h(:, :)
    integer, intent(out) :: stat
    real(wp) :: r1, r2, d1, d2, m1, m2, y
    logical :: ok
    if (self%nd == 3) then
      call hessian3(self, x, h, stat)
      return
    end if
    h(1:4, 1:4) = 0
    d1 = x(1) + self%mu
    d2 = x(1) - 1 + self%mu
    y = x(2)
    call cr_distances(self, x, r1, r2, ok)
    stat = 0
    if (.not. ok) then
      stat = -1
      return
    end if
    m1 = 1 - self%mu
    m2 = self%mu
    h(1, 1) = m1*(1/r1**3 - 3*d1**2/r1**5) + m2*(1/r2**3 - 3*d2**2/r2**5)
    h(1, 2) = -3*m1*d1*y/r1**5 - 3*m2*d2*y/r2**5
    h(2, 1) = h(1, 2)
    h(2, 2) = m1*(1/r1**3 - 3*y**2/r1**5) + m2*(1/r2**3 - 3*y**2/r2**5)
    call frame_hessian(2, h, stat)
  end subroutine cr_hessian

  pure integer function cr_naming(self)
    class(cr3bp_t), intent(in) :: self
    cr_naming = NAMES_LAGRANGE
  end function cr_naming

  !> (x, y, px, py) -> (x, -y, -px, py) with t -> -t; spatial: (x, -y, z, -px, py, -pz).
  pure function cr_reversor(self) result(r)
    class(cr3bp_t), intent(in) :: self
    integer :: r(2*self%ndof())
    if (self%nd == 3) then
      r = [1, -1, 1, -1, 1, -1]
    else
      r = [1, -1, -1, 1]
    end if
  end function cr_reversor

  !> Spatial: U_ij = sum_k m_k (delta_ij / r_k^3 - 3 d_i d_j / r_k^5) with d = (x - x_k, y, z);
  !> H_{x,py} = -1, H_{y,px} = 1, H_{p,p} = I.
  pure subroutine hessian3(self, x, h, stat)
    class(cr3bp_t), intent(in) :: self
    real(wp), intent(in) :: x(:)
    real(wp), intent(out) :: h(:, :)
    integer, intent(out) :: stat
    real(wp) :: d(3, 2), r(2), m(2)
    integer :: i, j, k
    logical :: ok
    h(1:6, 1:6) = 0
    d(:, 1) = [x(1) + self%mu, x(2), x(3)]
    d(:, 2) = [x(1) - 1 + self%mu, x(2), x(3)]
    call cr_distances(self, x, r(1), r(2), ok)
    m = [1 - self%mu, self%mu]
    stat = 0
    if (.not. ok) then
      stat = -1
      return
    end if
    do j = 1, 3
      do i = 1, 3
        do k = 1, 2
          h(i, j) = h(i, j) - 3*m(k)*d(i, k)*d(j, k)/r(k)**5
          if (i == j) h(i, j) = h(i, j) + m(k)/r(k)**3
        end do
      end do
    end do
    call frame_hessian(3, h, stat)
  end subroutine hessian3

  !> The entries of the Hessian that are the same at every point (nd = 2 or 3): H_{x,py} = -1,
  !> H_{y,px} = 1, H_{p,p} = I; then stat = -1 if any entry of the (2 nd)^2 block is not finite.
  pure subroutine frame_hessian(nd, h, stat)
    integer, intent(in) :: nd
    real(wp), intent(inout) :: h(:, :)
    integer, intent(inout) :: stat
    integer :: k
    h(1, nd + 2) = -1
    h(nd + 2, 1) = -1
    h(2, nd + 1) = 1
    h(nd + 1, 2) = 1
    do k = nd + 1, 2*nd
      h(k, k) = 1
    end do
    if (.not. all(abs(h(1:2*nd, 1:2*nd)) <= huge(1.0_wp))) stat = -1
  end subroutine frame_hessian

  !> The Jacobi constant C = -2 H (Szebehely 1967; Koon et al. 2011, without their constant
  !> mu (1 - mu)/2 in the effective potential): Earth-Moon C(L1) = 3.18834.
  pure real(wp) function cr_jacobi_factor(self)
    class(cr3bp_t), intent(in) :: self
    cr_jacobi_factor = -2
  end function cr_jacobi_factor

  !> The Hill radius (mu/3)^(1/3): the distance of L1 and L2 from the secondary.
  pure real(wp) function cr_length_scale(self)
    class(cr3bp_t), intent(in) :: self
    cr_length_scale = (self%mu/3)**(1.0_wp/3)
  end function cr_length_scale

end module tubes_cr3bp
