!> One study's set-up, shared by the C API (src/c/tubes_capi.f90) and the f2py facade
!> (python/tubes_f2py.f90): the model by name, its equilibria in the search box and the chosen
!> rank-1 saddle; the section of the tube-dynamics calls and the saddle's transit gate; the
!> Lyapunov orbit at one energy. (The start of the workflow layer: each call still computes its
!> pieces afresh.)
module tubes_study
  use tubes_kinds, only: wp
  use tubes_status, only: TUBES_OK, TUBES_EINPUT, TUBES_ENOCONV
  use tubes_hamiltonian, only: hamiltonian_t
  use tubes_ball, only: ball_t
  use tubes_models, only: make_model
  use tubes_equilibria, only: equilibrium_t, find_equilibria
  use tubes_orbits, only: orbit_t, orbit_opts_t, orbit_family
  use tubes_section_kinds, only: poincare_t, make_ray_section, make_plane_section
  use tubes_transport, only: gate_spec_t
  implicit none
  private

  real(wp), parameter :: PI = acos(-1.0_wp)
  integer, parameter, public :: SECTION_RAY = 1     !! sec_kind: the ball's polar ray
  integer, parameter, public :: SECTION_PLANE = 2   !! sec_kind: the plane q_index = level

  public :: setup_model, setup_section, orbit_at, saddle_gate

contains

  !> The model, its equilibria in the box and the rank-1 saddle named `saddle`.
  subroutine setup_model(system, params, lo, hi, n_grid, saddle, model, eqs, isad, stat)
    character(*), intent(in) :: system            !! the system's name
    character(*), intent(in) :: saddle            !! the rank-1 saddle's name
    real(wp), intent(in) :: params(:)             !! its parameters (table order)
    real(wp), intent(in) :: lo(:), hi(:)          !! the equilibrium search box (>= N entries)
    integer, intent(in) :: n_grid
    class(hamiltonian_t), allocatable, intent(out) :: model
    type(equilibrium_t), allocatable, intent(out) :: eqs(:)
    integer, intent(out) :: isad, stat
    character(8) :: name
    integer :: k, nd
    isad = 0
    name = saddle
    call make_model(system, params, model, stat)
    if (stat /= TUBES_OK) return
    nd = model%ndof()
    call find_equilibria(model, lo(1:nd), hi(1:nd), n_grid, eqs, stat)
    if (stat /= TUBES_OK) return
    do k = 1, size(eqs)
      if (eqs(k)%name == name .and. eqs(k)%rank1) isad = k
    end do
    if (isad == 0) stat = TUBES_EINPUT
  end subroutine setup_model

  !> The model, the saddle and the section of a tube-dynamics call at energy E_e + de:
  !> sec_kind 1 = the ball's ray theta = level [rad] with sign(p_theta) = dir, 2 = the plane
  !> q_index = level crossed with sign(dq_index/dt) = dir. q_ref is a configuration point of the
  !> section's side of the saddle: the well nearest the ray's direction, or the middle of the
  !> plane's region. stat = TUBES_EINPUT for a section that makes no sense for the model or
  !> does not meet the energy surface.
  subroutine setup_section(system, params, lo, hi, n_grid, saddle, sec_kind, sec_index, level, dir, &
                           de, model, eqs, isad, psec, q_ref, stat)
    character(*), intent(in) :: system, saddle
    real(wp), intent(in) :: params(:), lo(:), hi(:), level, de
    integer, intent(in) :: n_grid, sec_kind, sec_index, dir
    class(hamiltonian_t), allocatable, intent(out) :: model
    type(equilibrium_t), allocatable, intent(out) :: eqs(:)
    integer, intent(out) :: isad
    type(poincare_t), intent(out) :: psec
    real(wp), allocatable, intent(out) :: q_ref(:)
    integer, intent(out) :: stat
    integer :: k, iw, j
    real(wp) :: best, d, span
    call setup_model(system, params, lo, hi, n_grid, saddle, model, eqs, isad, stat)
    if (stat /= TUBES_OK) return
    stat = TUBES_EINPUT
    if (model%ndof() /= 2 .or. abs(dir) /= 1) return
    select case (sec_kind)
    case (SECTION_RAY)
      select type (model)
      type is (ball_t)
        call make_ray_section(psec, model, level, dir)
      class default
        return                               ! the ray section is the rolling ball's
      end select
      iw = 0
      best = huge(1.0_wp)
      do k = 1, size(eqs)
        if (eqs(k)%morse == 0) then
          d = abs(modulo(atan2(eqs(k)%q(2), eqs(k)%q(1)) - level + PI, 2*PI) - PI)   ! angular distance
          if (d < best) then
            best = d
            iw = k
          end if
        end if
      end do
      if (iw == 0) return
      q_ref = eqs(iw)%q
      call psec%set_energy(eqs(isad)%energy + de, 2*sqrt(sum(eqs(iw)%q**2)) + 10, stat)
    case (SECTION_PLANE)
      if (sec_index < 1 .or. sec_index > 2) return
      j = 3 - sec_index
      span = hi(j) - lo(j)
      call make_plane_section(psec, model, sec_index, level, dir, eqs(isad)%q(j), lo(j) - span/2, &
                              hi(j) + span/2, stat)
      if (stat /= TUBES_OK) return
      call psec%set_energy(eqs(isad)%energy + de, 0.0_wp, stat)
      if (stat /= TUBES_OK) return
      allocate (q_ref(2))
      q_ref(sec_index) = level
      q_ref(j) = 0.5_wp*(psec%smin + psec%smax)
      if (abs(q_ref(sec_index) - eqs(isad)%q(sec_index)) == 0) stat = TUBES_EINPUT  ! through the saddle
    end select
  end subroutine setup_section

  !> The Lyapunov orbit at excess energy de by continuation (options as &orbits).
  subroutine orbit_at(ball, eqs, isad, de, n_segments, tol, rtol, atol, orb, stat, local)
    class(hamiltonian_t), intent(in) :: ball
    logical, intent(in), optional :: local    !! on this MPI rank alone (default: all ranks)
    type(equilibrium_t), intent(in) :: eqs(:)
    integer, intent(in) :: isad, n_segments
    real(wp), intent(in) :: de, tol, rtol, atol
    type(orbit_t), intent(out) :: orb
    integer, intent(out) :: stat
    type(orbit_opts_t) :: opts
    type(orbit_t) :: orbs(1)
    real(wp) :: end_de
    integer :: reason
    opts%n_segments = n_segments
    opts%tol = tol
    opts%rtol = rtol
    opts%atol = atol
    if (present(local)) opts%local = local
    call orbit_family(ball, eqs, isad, [de], opts, orbs, end_de, reason, stat)
    if (stat /= TUBES_OK) return
    orb = orbs(1)
    if (.not. orb%converged) stat = TUBES_ENOCONV
  end subroutine orbit_at

  !> The transit gate of saddle eqs(isad) seen from q_ref (the section's side): the
  !> configuration hyperplane dist past the saddle along its reaction coordinate, away from q_ref.
  subroutine saddle_gate(sad, q_ref, dist, gspec)
    type(equilibrium_t), intent(in) :: sad
    real(wp), intent(in) :: q_ref(:)
    real(wp), intent(in) :: dist
    type(gate_spec_t), intent(out) :: gspec
    integer :: nd
    nd = size(sad%q)
    gspec%origin = sad%q
    gspec%normal = sad%evec(1:nd, 1)/sqrt(sum(sad%evec(1:nd, 1)**2))
    if (dot_product(gspec%normal, q_ref - sad%q) > 0) gspec%normal = -gspec%normal
    gspec%dist = dist
  end subroutine saddle_gate

end module tubes_study
