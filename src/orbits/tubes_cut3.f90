!> The cut of a 3-DOF tube with a plane section: a 3-sphere in the 4-D section, and which points of
!> the section lie inside it (the paper's section II; docs/theory.md, "Tube cuts in 3 DOF").
!>
!> Seeds: the NHIM at E_s + dE in the normal form's coordinates, on a grid of its 3-sphere (Hopf
!> coordinates: J_2 = sin^2(eta) J_2max, J_3 from H_NF(0, J) - E_s = dE, angles theta_2, theta_3),
!> stepped off to y_1 = sigma eps on the stable manifold x_1 = 0, mapped to the model's (q, p) by
!> the normal form's change, put on the energy surface (Newton along grad H), and followed
!> backwards in time to their first crossing of q_k = c. Backwards, the stable manifold attracts:
!> the seeds' errors off it (the normal form's truncation) shrink as exp(-lambda |t|).
!>
!> The cut is the image of the grid: n_eta + 1 rings of n_theta x n_theta nodes, each cell split in
!> 6 tetrahedra (Kuhn), the poles' collapsed circles shared. Its enclosed 4-volume (sum of the
!> tetrahedra's cones) is the flux (the symplectic volume dq_a dp_a dq_b dp_b of the section).
!> A point is inside iff a ray from it along +q_a crosses an odd number of tetrahedra: exactly the
!> paper's test (the points of the cut over the point's (q_b, p_b) form a circle in (q_a, p_a);
!> inside that circle is inside), done on the piecewise-linear cut.
module tubes_cut3
  use tubes_kinds, only: wp, PI
  use tubes_status, only: TUBES_OK, TUBES_EINPUT, TUBES_EVENT, TUBES_ENOCROSS, TUBES_ENOCONV
  use tubes_hamiltonian, only: hamiltonian_t
  use tubes_integrator, only: integrator_t, plane_t, propagate
  use tubes_methods, only: integ_choice_t, make_integrator
  use tubes_normal_form, only: nf_result_t, nf_change_t, nf_nhim_point, normal_form
  use tubes_ensemble, only: ensemble_t, ens_out_t, ens_run, ens_agree
  use tubes_equilibria, only: equilibrium_t
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
  implicit none
  private

  integer, parameter, public :: CUT_NOCROSS = 1    !! node status: no crossing within t_max
  integer, parameter, public :: CUT_WRONGWAY = 2   !! node status: first crossing the other way
  integer, parameter :: NBIN = 12                  !! bins per axis of the inside test's grid
  integer, parameter :: PERM(3, 6) = reshape([1, 2, 3, 1, 3, 2, 2, 1, 3, 2, 3, 1, 3, 1, 2, 3, 2, 1], [3, 6])
  integer, parameter :: PSIGN(6) = [1, -1, -1, 1, 1, -1]

  type, public :: cut3_t
    integer :: n_eta = 0, n_theta = 0, nnodes = 0
    integer :: axes(4) = 0                 !! state indices of the section's coordinates (q_a, p_a, q_b, p_b)
    real(wp), allocatable :: x(:, :)       !! (6, nnodes) states at the section
    real(wp), allocatable :: sec(:, :)     !! (4, nnodes) their section coordinates
    real(wp), allocatable :: t(:)          !! (nnodes) time from the seed to the section (< 0)
    integer, allocatable :: st(:)          !! (nnodes) TUBES_OK, CUT_NOCROSS, CUT_WRONGWAY or < 0
    real(wp) :: seed_energy_error = 0      !! max |H(seed) - E| / dE before the correction
    real(wp) :: volume = 0                 !! the enclosed 4-volume [action^2]
    integer :: n_failed = 0
  end type cut3_t

  !> The cut's seeds as an ensemble (tubes_ensemble): item id the node cut3_node numbers id (the
  !> poles' copies are not items), its state at the section, its time and its seed's energy error
  !> (2N + 2 reals). The components are cut3_compute's arguments.
  type, extends(ensemble_t) :: node_ens_t
    class(hamiltonian_t), allocatable :: model
    type(nf_result_t) :: nf
    type(nf_change_t) :: ch
    type(integ_choice_t) :: integ
    real(wp), allocatable :: zs(:)
    real(wp) :: es = 0, de = 0, y1 = 0, c = 0, t_max = 0, tol = 0
    integer :: n_eta = 0, n = 0, k = 0, dir = 0
  contains
    procedure :: item => node_item
  end type node_ens_t

  !> cut3_inside's points as an ensemble: the cut's tetrahedra binned on an NBIN^3 grid of
  !> (p_a, q_b, p_b) (CSR: list(start(b):start(b + 1) - 1) the tetrahedra of bin b).
  type, extends(ensemble_t) :: inside_ens_t
    type(cut3_t) :: cut
    real(wp), allocatable :: pts(:, :), grid(:, :, :)
    integer, allocatable :: tet(:, :), start(:), list(:)
    real(wp) :: lo(3) = 0, hi(3) = 0, w(3) = 0
    logical :: sm = .false.
  contains
    procedure :: item => inside_item
  end type inside_ens_t

  public :: cut3_compute, cut3_inside, cut3_node, cut3_half, bcast_normal_form

  !> cut3_study's summary diag(CUT3_NDIAG): the seeds' largest |H - E| / dE before their correction,
  !> the cut's 4-volume V, failed nodes, V_h on every other node, V_x = V + (V - V_h) / 3, the points
  !> whose smooth crossing did not converge (unresolved), the decided points (transit or return)
  !> misclassified by the cut and by the piecewise-linear cut, decided points, points inside the cut,
  !> the weighted fraction inside the cut (p_trans by the tube), the weighted fraction that transits
  integer, parameter, public :: CUT3_NDIAG = 12

contains

  !> Node (i, j, k) -> its index 1..(n_eta+1) n^2, the poles' collapsed circles shared: at
  !> eta = 0 (J_2 = 0) theta_2 does not matter, at eta = pi/2 (J_3 = 0) theta_3 does not.
  pure integer function cut3_node(n_eta, n, i, j, k) result(id)
    integer, intent(in) :: n_eta, n, i, j, k
    integer :: jj, kk
    jj = modulo(j, n)
    kk = modulo(k, n)
    if (i == 0) jj = 0
    if (i == n_eta) kk = 0
    id = 1 + (i*n + jj)*n + kk
  end function cut3_node

  !> The cut of the stable tube of the NHIM at E_s + de (zs the saddle's state, es its energy)
  !> with the plane q_k = c crossed with sign(dq_k/dt) = dir: seeds stepped off by eps times the
  !> NHIM's radius sqrt(2 de / omega_2) on the branch towards the plane, followed backwards to
  !> t_max. stat TUBES_ENOCROSS if a node failed (cut%st says which), TUBES_EINPUT for a plane
  !> the tube's branch cannot reach (the unstable eigenvector has no component across it).
  subroutine cut3_compute(model, nf, ch, zs, es, de, n_eta, n_theta, eps, k, c, dir, t_max, tol, integ, &
                          cut, stat)
    class(hamiltonian_t), intent(in) :: model
    type(nf_result_t), intent(in) :: nf
    type(nf_change_t), intent(in) :: ch
    real(wp), intent(in) :: zs(:), es, de, eps, c, t_max, tol
    integer, intent(in) :: n_eta, n_theta, k, dir
    type(integ_choice_t), intent(in) :: integ
    type(cut3_t), intent(out) :: cut
    integer, intent(out) :: stat
    real(wp) :: sigma, y1, emax
    real(wp), allocatable :: eerr(:)
    integer :: nd, n, i, j, l, id, nn, a, b
    logical, allocatable :: copy(:)
    type(node_ens_t) :: ens
    type(ens_out_t) :: out
    stat = TUBES_EINPUT
    nd = model%ndof()
    n = n_theta
    if (nd /= 3 .or. nf%ndof /= 3 .or. n_eta < 2 .or. n < 3 .or. k < 1 .or. k > 3 .or. abs(dir) /= 1 &
        .or. .not. eps > 0 .or. .not. de > 0) return
    ! the branch: y_1 moves the seed along C(:, N+1) (the stable eigenvector); backwards it leaves
    ! the saddle along it, so its q_k component must point to the plane
    if (abs(ch%c(k, nd + 1)) <= 1.0e-8_wp*sqrt(sum(ch%c(1:nd, nd + 1)**2)) .or. c == zs(k)) return
    sigma = sign(1.0_wp, ch%c(k, nd + 1)*(c - zs(k)))
    y1 = sigma*eps*sqrt(2*de/nf%omegas(1))
    a = merge(2, 1, k == 1)
    b = 6 - k - a
    cut%axes = [a, nd + a, b, nd + b]
    cut%n_eta = n_eta
    cut%n_theta = n
    nn = (n_eta + 1)*n*n
    cut%nnodes = nn
    allocate (cut%x(2*nd, nn), cut%sec(4, nn), cut%t(nn), cut%st(nn), eerr(nn))
    ! the seeds are dealt out over MPI ranks and threads (tubes_ensemble)
    ens = node_ens_t(nf=nf, ch=ch, integ=integ, zs=zs, es=es, de=de, y1=y1, c=c, t_max=t_max, tol=tol, &
                     n_eta=n_eta, n=n, k=k, dir=dir)
    allocate (ens%model, source=model)
    allocate (copy(nn))
    do i = 0, n_eta
      do j = 0, n - 1
        do l = 0, n - 1
          copy(1 + (i*n + j)*n + l) = cut3_node(n_eta, n, i, j, l) /= 1 + (i*n + j)*n + l
        end do
      end do
    end do
    call ens_run(ens, nn, out, 2*nd + 2, 0, skip=copy)
    cut%x = out%r(1:2*nd, :)
    cut%t = out%r(2*nd + 1, :)
    eerr = out%r(2*nd + 2, :)
    cut%st = out%st
    do i = 0, n_eta                        ! the poles' copies
      do j = 0, n - 1
        do l = 0, n - 1
          id = cut3_node(n_eta, n, i, j, l)
          if (id == 1 + (i*n + j)*n + l) cycle
          cut%x(:, 1 + (i*n + j)*n + l) = cut%x(:, id)
          cut%t(1 + (i*n + j)*n + l) = cut%t(id)
          cut%st(1 + (i*n + j)*n + l) = cut%st(id)
          eerr(1 + (i*n + j)*n + l) = eerr(id)
        end do
      end do
    end do
    emax = maxval(eerr)
    cut%seed_energy_error = emax
    cut%sec = cut%x(cut%axes, :)
    cut%n_failed = count(cut%st /= TUBES_OK)
    if (cut%n_failed > 0) then
      stat = TUBES_ENOCROSS
      return
    end if
    cut%volume = enclosed_volume(cut)
    stat = TUBES_OK

  end subroutine cut3_compute

  !> Node id: its seed on the NHIM's sphere at (eta, theta), put on the energy surface and followed
  !> backwards to the section.
  subroutine node_item(self, k, out)
    class(node_ens_t), intent(in) :: self
    integer, intent(in) :: k
    type(ens_out_t), intent(inout) :: out
    class(integrator_t), allocatable :: ig
    type(plane_t) :: pl
    real(wp) :: dz(size(self%zs)), x(size(self%zs)), g(size(self%zs)), e, th(2), f(size(self%zs))
    integer :: it, st, i, j, l, id, nv
    id = k
    nv = size(self%zs)
    i = (id - 1)/(self%n*self%n)
    j = mod((id - 1)/self%n, self%n)
    l = mod(id - 1, self%n)
    associate (model => self%model, nf => self%nf, ch => self%ch, integ => self%integ, zs => self%zs, &
               es => self%es, de => self%de, y1 => self%y1, c => self%c, t_max => self%t_max, tol => self%tol, &
               n_eta => self%n_eta, n => self%n, kk => self%k, dir => self%dir)
    th = 2*PI*[real(j, wp), real(l, wp)]/n
    call nf_nhim_point(nf, ch, de, (PI/2)*i/n_eta, th, y1, dz, st)
    if (st /= TUBES_OK) then
      out%st(id) = st
      return
    end if
    x = zs + dz
    out%r(nv + 2, id) = abs(model%energy(x) - es - de)/de
    do it = 1, 4                     ! onto the energy surface: Newton along grad H
      call model%gradient(x, g, st)
      e = model%energy(x) - es - de
      if (st /= 0 .or. .not. sum(g**2) > 0) then
        out%st(id) = TUBES_ENOCONV
        return
      end if
      x = x - e*g/sum(g**2)
    end do
    call make_integrator(integ, ig, st, f=model, rtol=tol, atol=tol)
    if (st /= TUBES_OK) then
      out%st(id) = st
      return
    end if
    pl%k = kk
    pl%c = c
    pl%direction = 0
    pl%terminal = .true.
    call propagate(ig, x, -t_max, st, event=pl)
    if (st == TUBES_EVENT) then
      call model%eval(0.0_wp, x, f, st)
      out%r(1:nv, id) = x
      out%r(nv + 1, id) = ig%t
      out%st(id) = merge(TUBES_OK, CUT_WRONGWAY, dir*f(kk) > 0)
    else if (st >= 0) then
      out%st(id) = CUT_NOCROSS
    else
      out%st(id) = st
    end if
    end associate
  end subroutine node_item

  !> The cut on every other node of cut's grid (n_eta and n_theta even): its discretisation error
  !> is about 4 times cut's (second order), so cut - half estimates 3/4 of half's, a third of cut's.
  subroutine cut3_half(cut, half, stat)
    type(cut3_t), intent(in) :: cut
    type(cut3_t), intent(out) :: half
    integer, intent(out) :: stat
    integer :: i, j, l, n, nh
    stat = TUBES_EINPUT
    if (mod(cut%n_eta, 2) /= 0 .or. mod(cut%n_theta, 2) /= 0 .or. .not. allocated(cut%sec)) return
    n = cut%n_theta
    nh = n/2
    half%n_eta = cut%n_eta/2
    half%n_theta = nh
    half%axes = cut%axes
    half%nnodes = (half%n_eta + 1)*nh*nh
    allocate (half%sec(4, half%nnodes))
    do i = 0, half%n_eta
      do j = 0, nh - 1
        do l = 0, nh - 1
          half%sec(:, 1 + (i*nh + j)*nh + l) = cut%sec(:, 1 + ((2*i)*n + 2*j)*n + 2*l)
        end do
      end do
    end do
    half%volume = enclosed_volume(half)
    stat = TUBES_OK
  end subroutine cut3_half

  !> The normal form and its change as rank 0 has them: the seeds' inputs come from work every rank
  !> repeats (docs/cluster.md).
  subroutine bcast_normal_form(nf, ch)
    type(nf_result_t), intent(inout) :: nf
    type(nf_change_t), intent(inout) :: ch
    real(wp), allocatable :: re(:, :), im(:, :)
    call ens_agree(nf%coef)
    call ens_agree(nf%omegas)
    call ens_agree(ch%c)
    re = real(ch%fwd, wp)
    im = aimag(ch%fwd)
    call ens_agree(re)
    call ens_agree(im)
    ch%fwd = cmplx(re, im, wp)
  end subroutine bcast_normal_form

  !> The node of the cut at grid coordinates (m, j, l) of the cut's map continued to all m: the
  !> NHIM's Hopf coordinates cover S^3 twice over eta in [0, 2 pi) with (-eta, theta_2 + pi,
  !> theta_3) = (eta, theta_2, theta_3) = (pi - eta, theta_2, theta_3 + pi), so the map is smooth
  !> and periodic in all three (n_theta even).
  pure function ext_node(cut, m, j, l) result(x)
    type(cut3_t), intent(in) :: cut
    integer, intent(in) :: m, j, l
    real(wp) :: x(4)
    integer :: ne, n, mm, h
    ne = cut%n_eta
    n = cut%n_theta
    h = n/2
    mm = modulo(m, 4*ne)
    if (mm <= ne) then
      x = cut%sec(:, cut3_node(ne, n, mm, j, l))
    else if (mm < 2*ne) then
      x = cut%sec(:, cut3_node(ne, n, 2*ne - mm, j, l + h))
    else if (mm <= 3*ne) then
      x = cut%sec(:, cut3_node(ne, n, mm - 2*ne, j + h, l + h))
    else
      x = cut%sec(:, cut3_node(ne, n, 4*ne - mm, j + h, l))
    end if
  end function ext_node

  !> Tricubic Lagrange interpolation of the cut's map at grid coordinates u (f) and its Jacobian
  !> (df(:, k) = df/du_k).
  pure subroutine smooth_map(cut, u, f, df)
    type(cut3_t), intent(in) :: cut
    real(wp), intent(in) :: u(3)
    real(wp), intent(out) :: f(4), df(4, 3)
    integer :: i0(3), a, b, c
    real(wp) :: wv(4, 3), wd(4, 3), t, x(4)
    do a = 1, 3
      i0(a) = floor(u(a))
      t = u(a) - i0(a)
      ! nodes -1, 0, 1, 2
      wv(:, a) = [-t*(t - 1)*(t - 2)/6, (t + 1)*(t - 1)*(t - 2)/2, -(t + 1)*t*(t - 2)/2, (t + 1)*t*(t - 1)/6]
      wd(:, a) = [-(3*t*t - 6*t + 2)/6, (3*t*t - 4*t - 1)/2, -(3*t*t - 2*t - 2)/2, (3*t*t - 1)/6]
    end do
    f = 0
    df = 0
    do c = 1, 4
      do b = 1, 4
        do a = 1, 4
          x = ext_node(cut, i0(1) + a - 2, i0(2) + b - 2, i0(3) + c - 2)
          f = f + wv(a, 1)*wv(b, 2)*wv(c, 3)*x
          df(:, 1) = df(:, 1) + wd(a, 1)*wv(b, 2)*wv(c, 3)*x
          df(:, 2) = df(:, 2) + wv(a, 1)*wd(b, 2)*wv(c, 3)*x
          df(:, 3) = df(:, 3) + wv(a, 1)*wv(b, 2)*wd(c, 3)*x
        end do
      end do
    end do
  end subroutine smooth_map

  !> The crossing of the line p + s e_1 with the smooth cut near grid coordinates x0: Newton on
  !> f_(2:4)(u) = p(2:4); s = f_1(u) - p(1). ok false if it does not converge within a cell.
  pure subroutine smooth_crossing(cut, p, x0, s, ok)
    type(cut3_t), intent(in) :: cut
    real(wp), intent(in) :: p(4), x0(3)
    real(wp), intent(out) :: s
    logical, intent(out) :: ok
    real(wp) :: u(3), f(4), df(4, 3), g(3), du(3), d, scale
    integer :: it, j
    u = x0
    ok = .false.
    s = 0
    scale = maxval(abs(p)) + 1
    do it = 1, 30
      call smooth_map(cut, u, f, df)
      g = f(2:4) - p(2:4)
      if (all(abs(g) <= 1.0e-13_wp*scale)) then   ! all(): a NaN fails it (maxval may skip one)
        ok = maxval(abs(u - x0)) <= 1.5_wp
        s = f(1) - p(1)
        return
      end if
      d = det3(df(2:4, :))
      if (d == 0) return
      do j = 1, 3
        du(j) = det3(merge(spread(g, 2, 3), df(2:4, :), spread([1, 2, 3] == j, 1, 3)))/d
      end do
      u = u - du
      if (.not. all(abs(u - x0) <= 3)) return
    end do
  end subroutine smooth_crossing

  !> The tetrahedra of the cut: their node ids (4, m) and orientation signs, degenerate ones
  !> (two nodes the same: at the poles) left out.
  subroutine tetrahedra(cut, tet, sgn, m, grid)
    type(cut3_t), intent(in) :: cut
    integer, allocatable, intent(out) :: tet(:, :), sgn(:)
    integer, intent(out) :: m
    integer, allocatable, intent(out), optional :: grid(:, :, :)   !! (3, 4, m) the vertices' (i, j, l)
    integer :: i, j, l, p, v(4), off(3), corner(3), s, n, g(3, 4)
    n = cut%n_theta
    allocate (tet(4, 6*cut%n_eta*n*n), sgn(6*cut%n_eta*n*n))
    if (present(grid)) allocate (grid(3, 4, 6*cut%n_eta*n*n))
    m = 0
    do i = 0, cut%n_eta - 1
      do j = 0, n - 1
        do l = 0, n - 1
          do p = 1, 6
            off = 0
            corner = [i, j, l]
            v(1) = cut3_node(cut%n_eta, n, corner(1), corner(2), corner(3))
            g(:, 1) = corner
            do s = 1, 3
              off(PERM(s, p)) = 1
              v(s + 1) = cut3_node(cut%n_eta, n, i + off(1), j + off(2), l + off(3))
              g(:, s + 1) = corner + off
            end do
            if (v(1) == v(2) .or. v(1) == v(3) .or. v(1) == v(4) .or. v(2) == v(3) .or. v(2) == v(4) &
                .or. v(3) == v(4)) cycle
            m = m + 1
            tet(:, m) = v
            sgn(m) = PSIGN(p)
            if (present(grid)) grid(:, :, m) = g
          end do
        end do
      end do
    end do
  end subroutine tetrahedra

  !> |sum of the oriented cones det(v_0 - o, .., v_3 - o) / 4!| (o: the nodes' mean).
  real(wp) function enclosed_volume(cut) result(vol)
    type(cut3_t), intent(in) :: cut
    integer, allocatable :: tet(:, :), sgn(:)
    real(wp) :: o(4), mm(4, 4)
    integer :: m, t
    call tetrahedra(cut, tet, sgn, m)
    o = sum(cut%sec, dim=2)/cut%nnodes
    vol = 0
    do t = 1, m
      mm = cut%sec(:, tet(:, t)) - spread(o, 2, 4)
      vol = vol + sgn(t)*det4(mm)
    end do
    vol = abs(vol)/24
  end function enclosed_volume

  pure real(wp) function det3(a) result(d)
    real(wp), intent(in) :: a(3, 3)
    d = a(1, 1)*(a(2, 2)*a(3, 3) - a(2, 3)*a(3, 2)) - a(1, 2)*(a(2, 1)*a(3, 3) - a(2, 3)*a(3, 1)) &
        + a(1, 3)*(a(2, 1)*a(3, 2) - a(2, 2)*a(3, 1))
  end function det3

  pure real(wp) function det4(a) result(d)
    real(wp), intent(in) :: a(4, 4)
    integer :: j
    d = 0
    do j = 1, 4
      d = d + (-1)**(1 + j)*a(1, j)*det3(a(2:4, pack([1, 2, 3, 4], [1, 2, 3, 4] /= j)))
    end do
  end function det4

  !> inside(i) for the section points pts(4, i) (q_a, p_a, q_b, p_b): the parity of the
  !> tetrahedra a ray from the point along +q_a crosses. Tetrahedra are binned by their extent in
  !> (p_a, q_b, p_b) on an NBIN^3 grid, so a point tests only those of its bin.
  subroutine cut3_inside(cut, pts, inside, smooth, unresolved)
    type(cut3_t), intent(in) :: cut
    real(wp), intent(in) :: pts(:, :)
    logical, intent(out) :: inside(:)
    !> with smooth: the crossings near the point moved onto the smooth cut (tricubic interpolation
    !> of the nodes, Newton); unresolved: the points where that failed (their piecewise-linear test kept)
    logical, intent(in), optional :: smooth
    logical, intent(out), optional :: unresolved(:)
    integer, allocatable :: tet(:, :), sgn(:), cnt(:), start(:), list(:), fill(:), grid(:, :, :)
    real(wp) :: lo(3), hi(3), w(3)
    integer :: m, t, i, b(3, 2), i1, i2, i3, nb
    logical :: sm
    type(inside_ens_t) :: ens
    type(ens_out_t) :: out
    sm = .false.
    if (present(smooth)) sm = smooth
    if (present(unresolved)) unresolved = .false.
    call tetrahedra(cut, tet, sgn, m, grid)
    lo = minval(cut%sec(2:4, :), dim=2)
    hi = maxval(cut%sec(2:4, :), dim=2)
    w = max(hi - lo, tiny(1.0_wp))/NBIN
    nb = NBIN**3
    allocate (cnt(nb), start(nb + 1), fill(nb))
    cnt = 0
    do t = 1, m                         ! count, then fill (CSR)
      call bins(t, b)
      do i3 = b(3, 1), b(3, 2)
        do i2 = b(2, 1), b(2, 2)
          do i1 = b(1, 1), b(1, 2)
            cnt(bin_of(i1, i2, i3)) = cnt(bin_of(i1, i2, i3)) + 1
          end do
        end do
      end do
    end do
    start(1) = 1
    do i = 1, nb
      start(i + 1) = start(i) + cnt(i)
    end do
    allocate (list(start(nb + 1) - 1))
    fill = start(1:nb)
    do t = 1, m
      call bins(t, b)
      do i3 = b(3, 1), b(3, 2)
        do i2 = b(2, 1), b(2, 2)
          do i1 = b(1, 1), b(1, 2)
            list(fill(bin_of(i1, i2, i3))) = t
            fill(bin_of(i1, i2, i3)) = fill(bin_of(i1, i2, i3)) + 1
          end do
        end do
      end do
    end do
    ens%cut = cut
    ens%pts = pts
    ens%lo = lo
    ens%hi = hi
    ens%w = w
    ens%sm = sm
    ens%tet = tet
    ens%grid = grid
    call move_alloc(start, ens%start)
    call move_alloc(list, ens%list)
    call ens_run(ens, size(pts, 2), out, 0, 2, local=.true., chunk=64)   ! each rank tests every point
    inside = out%i(1, :) == 1
    if (present(unresolved)) unresolved = out%i(2, :) == 1

  contains

    subroutine bins(t, b)
      integer, intent(in) :: t
      integer, intent(out) :: b(3, 2)
      real(wp) :: v(3, 4)
      v = cut%sec(2:4, tet(:, t))
      b(:, 1) = min(NBIN, max(1, 1 + int((minval(v, dim=2) - lo)/w)))
      b(:, 2) = min(NBIN, max(1, 1 + int((maxval(v, dim=2) - lo)/w)))
    end subroutine bins

  end subroutine cut3_inside

  pure integer function bin_of(i1, i2, i3)
    integer, intent(in) :: i1, i2, i3
    bin_of = 1 + (i1 - 1) + NBIN*((i2 - 1) + NBIN*(i3 - 1))
  end function bin_of

  !> Point k: the parity of the tetrahedra its ray crosses (out%i(1, k) = 1: odd, inside), and
  !> out%i(2, k) = 1 where the smooth crossing was not found.
  subroutine inside_item(self, k, out)
    class(inside_ens_t), intent(in) :: self
    integer, intent(in) :: k
    type(ens_out_t), intent(inout) :: out
    real(wp) :: p(4)
    logical :: odd
    real(wp) :: v(4, 4), a(3, 3), r(3), d, bc(3), q1, x0(3), s1
    integer :: ib(3), bb, s, t, j
    logical :: ok
    p = self%pts(:, k)
    odd = .false.
    associate (lo => self%lo, hi => self%hi, w => self%w, start => self%start, list => self%list, &
               cut => self%cut, tet => self%tet, sm => self%sm, grid => self%grid)
    if (any(p(2:4) < lo) .or. any(p(2:4) > hi)) return
    ib = min(NBIN, max(1, 1 + int((p(2:4) - lo)/w)))
    bb = bin_of(ib(1), ib(2), ib(3))
    do s = start(bb), start(bb + 1) - 1
      t = list(s)
      v = cut%sec(:, tet(:, t))
      if (maxval(v(1, :)) < p(1) - merge(2*(maxval(v(1, :)) - minval(v(1, :))), 0.0_wp, sm)) cycle
      if (any(p(2:4) < minval(v(2:4, :), dim=2)) .or. any(p(2:4) > maxval(v(2:4, :), dim=2))) cycle
      do j = 1, 3
        a(:, j) = v(2:4, j + 1) - v(2:4, 1)
      end do
      r = p(2:4) - v(2:4, 1)
      d = det3(a)
      if (d == 0) cycle
      do j = 1, 3                    ! Cramer
        bc(j) = det3(merge(spread(r, 2, 3), a, spread([1, 2, 3] == j, 1, 3)))/d
      end do
      if (any(bc < 0) .or. sum(bc) > 1) cycle
      q1 = v(1, 1) + sum(bc*(v(1, 2:4) - v(1, 1)))
      if (q1 > p(1)) odd = .not. odd
      ! near the point: the crossing of the smooth cut decides its side
      if (sm .and. abs(q1 - p(1)) <= 2*(maxval(v(1, :)) - minval(v(1, :)))) then
        x0 = (1 - sum(bc))*grid(:, 1, t) + bc(1)*grid(:, 2, t) + bc(2)*grid(:, 3, t) + bc(3)*grid(:, 4, t)
        call smooth_crossing(cut, p, x0, s1, ok)
        if (.not. ok) then
          out%i(2, k) = 1
        else if ((s1 > 0) .neqv. (q1 > p(1))) then
          odd = .not. odd
        end if
      end if
    end do
    end associate
    out%i(1, k) = merge(1, 0, odd)
  end subroutine inside_item
end module tubes_cut3
