!> One study's set-up, shared by the C API (src/capi/tubes_capi.f90) and the f2py facade
!> (python/tubes_f2py.f90): the model by name, its equilibria in the search box and the chosen
!> rank-1 saddle; the section of the tube-dynamics calls and the saddle's transit gate; the
!> Lyapunov orbits. Given a run's stores (seed_stores_t), its calls take what earlier calls
!> computed: the model's equilibria, each orbit family's continuation and orbits, and each cut
!> set-up's tube seeds. (Each call still makes its model object and its section: cheap.)
module tubes_study
  use, intrinsic :: iso_c_binding, only: c_intptr_t, c_loc, c_f_pointer, c_null_ptr
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
  use tubes_kinds, only: wp, i8, PI
  use tubes_status, only: TUBES_OK, TUBES_EINPUT, TUBES_ENOCONV, TUBES_EPASTEND, TUBES_EUNRESOLVED
  use tubes_hamiltonian, only: hamiltonian_t, damped_t
  use tubes_ball, only: ball_t
  use tubes_models, only: make_model, make_field, dissipative, noisy_params, param_of, MAX_PARAMS, MAX_DOF
  use tubes_field, only: vector_field_t
  use tubes_region, only: region_opts_t, region_t, transition_region, region_curve
  use tubes_equilibria, only: equilibrium_t, find_equilibria, neck_normal, nhim_reach, gate_holds_nhim
  use tubes_orbits, only: orbit_t, orbit_opts_t, orbit_family, family_path_t, floquet_indices, floquet_tangent, &
                          fold_t, branch_arc, END_NOBRANCH, END_NOMODE, named_mode, tilt_of, FAMILY_VERTICAL, &
                          FAMILY_PLANAR, FAMILY_AXIAL, branch_ladder, END_NONE
  use tubes_ensemble, only: ens_reuse_ok
  use tubes_section_kinds, only: poincare_t, make_ray_section, make_plane_section, plane_search_range, &
                                 make_plane_crossing, SEC_PLANE, SEC_RAY
  use tubes_manifold, only: tube_opts_t, tube_cut_t, tube_cut, seed_store_t
  use tubes_transport, only: gate_spec_t, monte_carlo, poincare_map, gate_bound
  use tubes_status, only: TUBES_EOUTSIDE, TUBES_ENARROW, TUBES_ESHAPE, TUBES_EDISSIPATIVE, TUBES_ENOISE
  use tubes_methods, only: integ_choice_t
  implicit none
  private

  integer, parameter, public :: SECTION_RAY = 1     !! sec_kind: the ball's polar ray
  integer, parameter, public :: SECTION_PLANE = 2   !! sec_kind: the plane q_index = level

  public :: setup_model, setup_section, equilibria_of, orbit_at, family_at, saddle_gate, gate_reach, section_info, cut_at, &
            check_at, maps_at, cut_outputs, equilibria_table, study_family, family_table, open_stores, &
            family_bifurcations, bifurcation_table, orbit_crossings, &
            stores_at, close_stores, stores_counts, de_floor, region_at, region_outputs, region_numbers, dissipation_of, &
            damped_spectrum, box_note, box_note_of, centres_of, p_trans_leading, leading_order_at, model_equilibria

  !> The section of a tube-dynamics call (as &section).
  type, public :: section_choice_t
    integer :: kind = SECTION_RAY    !! SECTION_RAY or SECTION_PLANE
    integer :: index = 0             !! plane: q_index = level
    real(wp) :: level = 0            !! ray: angle [rad]; plane: the level
    integer :: dir = 1               !! ray: sign of p_theta; plane: sign of dq_index/dt
  end type section_choice_t

  !> The model, its search box and the saddle of a tube-dynamics call (as &model, &equilibria,
  !> &orbits).
  type, public :: study_t
    character(32) :: system = 'rolling_ball'
    real(wp) :: params(MAX_PARAMS) = 0
    real(wp) :: lo(MAX_DOF) = 0, hi(MAX_DOF) = 0
    integer :: n_grid = 41
    character(8) :: saddle = ''
    integer :: n_segments = 1        !! orbit corrector: 1 single shooting, >= 2 multiple
    !> the orbit family of the tube cuts (as &orbits family: 1 .. N-1 a centre mode's Lyapunov
    !> family, FAMILY_BRANCH_PLUS/_MINUS the halo branch, FAMILY_VERTICAL, _PLANAR, _AXIAL the
    !> families by name; tubes_orbits orbit_opts_t%family)
    integer :: family = 1
    real(wp) :: orb_tol = 1.0e-11_wp, orb_rtol = 1.0e-13_wp, orb_atol = 1.0e-13_wp
    type(integ_choice_t) :: integ    !! the integrator of every analysis (&integrator)
  end type study_t

  integer, parameter :: NKEY = MAX_PARAMS + 4*MAX_DOF + 24   ! seed_key's and family_key's numbers (the longer)
  !> What a kept result belongs to: the system, the saddle and the numbers it depends on.
  type :: kept_for_t
    character(32) :: system = ''
    character(8) :: saddle = ''
    integer(i8) :: key(NKEY) = 0
  end type kept_for_t

  !> The seeds of one set-up (seed_key).
  type, extends(kept_for_t) :: kept_seeds_t
    type(seed_store_t) :: store
  end type kept_seeds_t

  !> A model's equilibria kept for later calls (equilibria_of).
  type, extends(kept_for_t) :: kept_eqs_t
    type(equilibrium_t), allocatable :: eqs(:)
  end type kept_eqs_t

  !> A family's path kept for later calls (family_key).
  type, extends(kept_for_t) :: kept_path_t
    type(family_path_t) :: path
  end type kept_path_t

  !> A run's kept results. The tube seeds of its cuts, one store per set-up (model, saddle, orbit
  !> options, energy, section, step-off, integration): cut_at with it looks up the seeds an
  !> earlier cut of the set-up integrated (docs/tubes.md, "Seeds computed once"). The path of
  !> each orbit family (model, saddle, orbit options): the family is continued once in a run and
  !> each of its orbits found once, for the orbits scene and every cut (docs/orbits.md, "One
  !> family, each orbit once"). The equilibria of each model and search box (equilibria_of).
  !> Owned by the caller (the program's run: include/tubes.h tubes_seed_stores_new; a Python
  !> tubes.Model: open_stores), for one caller at a time.
  !> A transition region's threshold kept for later calls (region_at): below de_lo no point of
  !> the section transits.
  type, extends(kept_for_t) :: kept_threshold_t
    real(wp) :: de_lo = 0, de_hi = 0, area_hi = 0
    real(wp), allocatable :: hints(:, :)   !! points inside the region at de_hi
  end type kept_threshold_t

  type, public :: seed_stores_t
    type(kept_seeds_t), allocatable :: kept(:)
    type(kept_path_t), allocatable :: paths(:)
    type(kept_eqs_t), allocatable :: eqs(:)
    type(kept_threshold_t), allocatable :: thresholds(:)
  end type seed_stores_t

  !> What a transition region's call adds to the region: the dissipation used and, where the
  !> region is empty, the threshold below which it is (region_at).
  type, public :: region_info_t
    real(wp) :: damping_rate = 0   !! c of the viscous damping -c p [1/time] (0: none)
    real(wp) :: area_e = 0         !! A_E, the area of the energy surface on the section
    !> the excess energy at which the region appears: above de_lo (no transit at or below it),
    !> at or below de_hi (a region of area area_hi there); NaN when not searched (the region at
    !> de is not empty), de_hi NaN when no region was found up to de_lo
    real(wp) :: de_lo = 0, de_hi = 0, area_hi = 0
  end type region_info_t

  !> A bifurcation of a family (family_bifurcations): where a count of orbit_crossings changes.
  type, public :: bifurcation_t
    integer :: kind = 0            !! BIF_BRANCH, BIF_PERIOD_DOUBLING or BIF_KREIN
    integer :: after = 0           !! between the requested orbits after and after + 1
    real(wp) :: de = 0             !! the located excess energy (the bracket's midpoint)
    real(wp) :: width = 0          !! the final bracket's width in dE
    real(wp) :: energy = 0, period = 0
    logical :: converged = .false. !! the orbit at de converged (else the bisection stopped where
                                   !! the corrector did: width says how far it got)
    real(wp), allocatable :: nre(:), nim(:)   !! the Floquet indices of the orbit at de
    real(wp), allocatable :: x0(:)            !! that orbit's start (state0)
    !> kinds 1, 2: the eigenvector of its monodromy for the multiplier +1 (orthogonal to the flow)
    !> or -1, the new family's tangent at x0 (floquet_tangent); kind 3: 0
    real(wp), allocatable :: tangent(:)
  end type bifurcation_t

  integer, parameter, public :: BIF_BRANCH = 1           !! a nontrivial index crosses +1
  integer, parameter, public :: BIF_PERIOD_DOUBLING = 2  !! an index crosses -1
  integer, parameter, public :: BIF_KREIN = 3            !! two elliptic pairs collide and leave the
                                                         !! unit circle (or return to it)
  integer, parameter, public :: BIF_FOLD = 4             !! the energy along a guess's family turns back
  real(wp), parameter, public :: BIF_TOL = 1.0e-11_wp    !! the bisection's bracket: width <= BIF_TOL dE
  !> an index is complex (a quartet off the unit circle) when |Im nu| > BIF_COMPLEX (1 + |Re nu|):
  !> above the traces' rounding (1e-16 |m|^2 in (nu1 - nu2)^2), below any collision one can see
  real(wp), parameter :: BIF_COMPLEX = 1.0e-6_wp

contains

  !> A new, empty set of stores; handle: its address (the C API's tubes_seed_stores_new, Python's
  !> tubes.Model). Free it with close_stores.
  subroutine open_stores(handle)
    integer(c_intptr_t), intent(out) :: handle
    type(seed_stores_t), pointer :: s
    allocate (s)
    handle = transfer(c_loc(s), handle)
  end subroutine open_stores

  !> The stores at handle, or a disassociated pointer for 0: passed to an optional `stores`
  !> dummy, a disassociated pointer is an absent argument (Fortran 2008).
  function stores_at(handle) result(s)
    integer(c_intptr_t), intent(in) :: handle
    type(seed_stores_t), pointer :: s
    s => null()
    if (handle /= 0) call c_f_pointer(transfer(handle, c_null_ptr), s)
  end function stores_at

  !> Free the stores at handle (0: nothing).
  subroutine close_stores(handle)
    integer(c_intptr_t), intent(in) :: handle
    type(seed_stores_t), pointer :: s
    s => stores_at(handle)
    if (associated(s)) deallocate (s)
  end subroutine close_stores

  !> What the stores at handle keep: equilibria searches, orbit families, tube-seed set-ups.
  subroutine stores_counts(handle, n_eqs, n_families, n_seeds)
    integer(c_intptr_t), intent(in) :: handle
    integer, intent(out) :: n_eqs, n_families, n_seeds
    type(seed_stores_t), pointer :: s
    n_eqs = 0
    n_families = 0
    n_seeds = 0
    s => stores_at(handle)
    if (.not. associated(s)) return
    if (allocated(s%eqs)) n_eqs = size(s%eqs)
    if (allocated(s%paths)) n_families = size(s%paths)
    if (allocated(s%kept)) n_seeds = size(s%kept)
  end subroutine stores_counts

  !> What a tube seed's crossing depends on besides its phase, bit for bit (the strings apart).
  function seed_key(st, sec, de, o) result(key)
    type(study_t), intent(in) :: st
    type(section_choice_t), intent(in) :: sec
    real(wp), intent(in) :: de
    type(tube_opts_t), intent(in) :: o
    integer(i8) :: key(NKEY)
    real(wp) :: v(size(st%params) + size(st%lo) + size(st%hi) + 21)
    v = [st%params, st%lo, st%hi, real([st%n_grid, st%n_segments], wp), st%orb_tol, st%orb_rtol, &
         st%orb_atol, real([sec%kind, sec%index, sec%dir], wp), sec%level, de, &
         real([o%kind, o%integ%method, o%integ%opts%solver, o%integ%opts%max_iter], wp), o%integ%h, &
         o%integ%opts%omega_bind, o%eps, o%t_max, o%rtol, o%atol, real(st%family, wp)]
    key = 0      ! (NKEY is the longer of the two keys: family_key's)
    key(1:size(v)) = transfer(v, key, size(v))
  end function seed_key

  !> The index of the kept result of st's system and saddle with this key (the last), or 0.
  pure integer function kept_at(kept, st, key) result(ik)
    class(kept_for_t), intent(in) :: kept(:)
    type(study_t), intent(in) :: st
    integer(i8), intent(in) :: key(NKEY)
    integer :: i
    ik = 0
    do i = 1, size(kept)
      if (kept(i)%system == st%system .and. kept(i)%saddle == st%saddle .and. all(kept(i)%key == key)) ik = i
    end do
  end function kept_at

  !> What a family's orbits depend on besides their energies, bit for bit (the strings apart):
  !> the model's numbers, the search box and the orbit options (all but local: the ensemble
  !> layer gives the same bits on any ranks).
  function family_key(st, o) result(key)
    type(study_t), intent(in) :: st
    type(orbit_opts_t), intent(in) :: o
    integer(i8) :: key(NKEY)
    real(wp) :: v(size(st%params) + size(st%lo) + size(st%hi) + 14)
    real(wp) :: g(2*MAX_DOF + 3)
    v = [st%params, st%lo, st%hi, real([st%n_grid, o%n_segments, o%max_iter, o%n_samples, o%family], wp), o%tol, &
         o%rtol, o%atol, o%period_max, real([o%integ%method, o%integ%opts%solver, o%integ%opts%max_iter], wp), &
         o%integ%h, o%integ%opts%omega_bind]
    key = 0
    key(1:size(v)) = transfer(v, key, size(v))
    g = 0      ! a guess's family and a branch: their own paths
    g(1) = o%branch
    if (allocated(o%guess)) then
      g(2) = size(o%guess)
      g(3) = o%guess_period
      g(4:3 + min(size(o%guess), 2*MAX_DOF)) = o%guess(1:min(size(o%guess), 2*MAX_DOF))
    end if
    key(size(v) + 1:size(v) + size(g)) = transfer(g, key, size(g))
  end function family_key

  !> The model, its equilibria in the box and the rank-1 saddle named `saddle` (with
  !> degenerate_ok, also a degenerate saddle: the sampled flux takes one).
  subroutine setup_model(system, params, lo, hi, n_grid, saddle, model, eqs, isad, stat, degenerate_ok, stores, des, &
                         conservative)
    character(*), intent(in) :: system            !! the system's name
    character(*), intent(in) :: saddle            !! the rank-1 saddle's name
    real(wp), intent(in) :: params(:)             !! its parameters (table order)
    real(wp), intent(in) :: lo(:), hi(:)          !! the equilibrium search box (>= N entries)
    integer, intent(in) :: n_grid
    class(hamiltonian_t), allocatable, intent(out) :: model
    type(equilibrium_t), allocatable, intent(out) :: eqs(:)
    integer, intent(out) :: isad, stat
    logical, intent(in), optional :: degenerate_ok
    type(seed_stores_t), intent(inout), optional :: stores   !! the run's kept results
    real(wp), intent(in), optional :: des(:)      !! the excess energies the call will take
    !> a conservative-only computation: TUBES_EDISSIPATIVE for a model with dissipation
    logical, intent(in), optional :: conservative
    character(8) :: name
    integer :: k
    isad = 0
    name = saddle
    if (present(conservative)) then
      stat = TUBES_EDISSIPATIVE
      if (conservative .and. dissipative(system, params)) return
    end if
    call make_model(system, params, model, stat)
    if (stat /= TUBES_OK) return
    call equilibria_of(system, params, lo, hi, n_grid, model, eqs, stat, stores)
    if (stat /= TUBES_OK) return
    do k = 1, size(eqs)
      if (eqs(k)%name == name .and. eqs(k)%rank1) isad = k
      if (present(degenerate_ok) .and. eqs(k)%name == name .and. eqs(k)%degenerate) then
        if (degenerate_ok) isad = k
      end if
    end do
    if (isad == 0) stat = TUBES_EINPUT
    if (stat == TUBES_OK .and. present(des)) call check_resolved(eqs(isad), des, stat)
  end subroutine setup_model

  !> stat = TUBES_EUNRESOLVED if a dE of des is below de_floor at the saddle sad, else unchanged:
  !> the rule of the calls whose results scale with dE (orbits, tubes, Monte Carlo, maps, flux;
  !> not the energy surface on a section, which is E's alone).
  pure subroutine check_resolved(sad, des, stat)
    type(equilibrium_t), intent(in) :: sad
    real(wp), intent(in) :: des(:)
    integer, intent(inout) :: stat
    if (any(abs(des) < de_floor(sad%energy))) stat = TUBES_EUNRESOLVED
  end subroutine check_resolved

  !> The smallest excess energy dE the energy resolves at a saddle of energy e_saddle: E_e + dE
  !> is known to about 16 ulps of |E_e| (H's rounding), and a dE below 1e6 times that would be
  !> known to worse than 1e-6 of itself (an additive constant in H, the ball's h0 = 1e10, made
  !> dE = 1 one of 0.003 and the orbit's action 0.3 % off). TUBES_EUNRESOLVED below it.
  pure real(wp) function de_floor(e_saddle)
    real(wp), intent(in) :: e_saddle
    de_floor = 1.0e6_wp*16*epsilon(1.0_wp)*abs(e_saddle)
  end function de_floor

  !> The equilibria of the model in the box [lo, hi] (n_grid starts per axis): from the run's
  !> stores where an earlier call found them for the same system, model numbers, box and grid
  !> (bit for bit), else found and kept there.
  subroutine equilibria_of(system, params, lo, hi, n_grid, model, eqs, stat, stores)
    character(*), intent(in) :: system
    real(wp), intent(in) :: params(:), lo(:), hi(:)
    integer, intent(in) :: n_grid
    class(hamiltonian_t), intent(in) :: model
    type(equilibrium_t), allocatable, intent(out) :: eqs(:)
    integer, intent(out) :: stat
    type(seed_stores_t), intent(inout), optional :: stores   !! the run's kept results
    type(study_t) :: st
    type(kept_eqs_t) :: entry
    integer(i8) :: key(NKEY)
    integer :: nd, i
    nd = model%ndof()
    if (.not. present(stores)) then
      call find_equilibria(model, lo(1:nd), hi(1:nd), n_grid, eqs, stat)
      return
    end if
    st%system = system
    st%saddle = ''
    key = 0
    key(1:size(params) + 2*nd + 1) = transfer([params, lo(1:nd), hi(1:nd), real(n_grid, wp)], key, &
                                              size(params) + 2*nd + 1)
    if (.not. allocated(stores%eqs)) allocate (stores%eqs(0))
    i = kept_at(stores%eqs, st, key)
    if (i > 0) then
      eqs = stores%eqs(i)%eqs
      stat = TUBES_OK
      return
    end if
    call find_equilibria(model, lo(1:nd), hi(1:nd), n_grid, eqs, stat)
    if (stat /= TUBES_OK) return
    entry%system = system
    entry%key = key
    entry%eqs = eqs
    stores%eqs = [stores%eqs, entry]
  end subroutine equilibria_of

  !> What the equilibrium search box [lo, hi] may hide (docs/models.md, "The search box"): '' when
  !> nothing, else one line. (a) An equilibrium on a face of the box: the search ends there, and
  !> what lies beyond is not searched. (b) A natural model without a minimum (a well) in the box
  !> whose potential on the box's faces (a grid of 33 points per side) is lower than at every
  !> equilibrium found: it falls on across the face, where wells (or an open exit) may lie.
  subroutine box_note(model, lo, hi, eqs, note)
    class(hamiltonian_t), intent(in) :: model
    real(wp), intent(in) :: lo(:), hi(:)
    type(equilibrium_t), intent(in) :: eqs(:)
    character(*), intent(out) :: note
    integer, parameter :: NS = 33
    real(wp) :: q(size(lo)), x(2*size(lo)), qmin(size(lo)), v, vmin, emin, tol
    character(160) :: at
    integer :: nd, k, i, face, m, j, idx(max(size(lo) - 1, 1))
    nd = size(lo)
    note = ''
    do k = 1, size(eqs)
      do i = 1, nd
        tol = 1.0e-6_wp*(hi(i) - lo(i))
        if (abs(eqs(k)%q(i) - lo(i)) <= tol .or. abs(eqs(k)%q(i) - hi(i)) <= tol) then
          write (note, '(3a,i0,a,g0.6,a,g0.6,a,g0.6,a)') 'the equilibrium ', trim(eqs(k)%name), &
            ' lies on a face of the search box (q', i, ' = ', eqs(k)%q(i), ', the box [', lo(i), ', ', hi(i), &
            ']): the search ends there and what lies beyond is not searched; widen &equilibria box to see it'
          return
        end if
      end do
    end do
    if (.not. model%is_natural()) return
    if (any([(eqs(k)%morse == 0, k = 1, size(eqs))])) return
    emin = huge(1.0_wp)
    do k = 1, size(eqs)
      emin = min(emin, eqs(k)%energy)
    end do
    vmin = huge(1.0_wp)
    x = 0
    do face = 1, 2*nd                  ! q(i) = lo(i) or hi(i), the other coordinates on a grid
      i = (face + 1)/2
      idx = 0
      do m = 1, NS**(nd - 1)
        j = m - 1
        do k = 1, nd - 1
          idx(k) = mod(j, NS)
          j = j/NS
        end do
        j = 0
        do k = 1, nd
          if (k == i) then
            q(k) = merge(lo(k), hi(k), mod(face, 2) == 1)
          else
            j = j + 1
            q(k) = lo(k) + (hi(k) - lo(k))*idx(j)/real(NS - 1, wp)
          end if
        end do
        x(1:nd) = q
        v = model%energy(x)
        if (v < vmin) then
          vmin = v
          qmin = q
        end if
      end do
    end do
    if (.not. (vmin < emin - 1.0e-9_wp*max(1.0_wp, abs(emin)))) return
    write (at, '(*(g0.6,:,", "))') qmin
    if (size(eqs) == 0) then
      write (note, '(a,g0.6,a)') 'no equilibrium in the search box, and the potential falls across its faces (V = ', &
        vmin, ' at ('//trim(at)//')): widen &equilibria box to find the wells'
    else
      write (note, '(a,g0.6,a,g0.6,a)') 'no well (minimum) in the search box, and the potential on its faces is ' // &
        'lower (V = ', vmin, ' at ('//trim(at)//')) than at every equilibrium found (lowest E = ', emin, &
        '): wells, or an open exit, lie beyond the box; widen &equilibria box to see them'
    end if
  end subroutine box_note

  !> The model of system and its equilibria in [lo, hi], the search kept in stores when they are
  !> associated (box_note_of, centres_of: the front ends' calls after the equilibria scene's).
  subroutine model_equilibria(system, params, lo, hi, n_grid, stores, model, eqs, stat)
    character(*), intent(in) :: system
    real(wp), intent(in) :: params(:), lo(:), hi(:)
    integer, intent(in) :: n_grid
    type(seed_stores_t), pointer, intent(in) :: stores
    class(hamiltonian_t), allocatable, intent(out) :: model
    type(equilibrium_t), allocatable, intent(out) :: eqs(:)
    integer, intent(out) :: stat
    call make_model(system, params, model, stat)
    if (stat /= TUBES_OK) return
    if (associated(stores)) then
      call equilibria_of(system, params, lo, hi, n_grid, model, eqs, stat, stores)
    else
      call equilibria_of(system, params, lo, hi, n_grid, model, eqs, stat)
    end if
  end subroutine model_equilibria

  !> box_note for the system's equilibria in [lo, hi] (the front ends' one call: the C API's
  !> tubes_box_note and the f2py box_note); stores: the run's kept results, or a null pointer.
  subroutine box_note_of(system, params, lo, hi, n_grid, stores, note, stat)
    character(*), intent(in) :: system
    real(wp), intent(in) :: params(:), lo(:), hi(:)
    integer, intent(in) :: n_grid
    type(seed_stores_t), pointer, intent(in) :: stores
    character(*), intent(out) :: note
    integer, intent(out) :: stat
    class(hamiltonian_t), allocatable :: model
    type(equilibrium_t), allocatable :: eqs(:)
    integer :: nd
    note = ''
    call model_equilibria(system, params, lo, hi, n_grid, stores, model, eqs, stat)
    if (stat /= TUBES_OK) return
    nd = model%ndof()
    call box_note(model, lo(1:nd), hi(1:nd), eqs, note)
  end subroutine box_note_of

  !> The centre frequencies and linear stability of the system's equilibria in [lo, hi] (the front
  !> ends' one call: the C API's tubes_equilibria_centres and the f2py equilibria_centres), in the
  !> order of equilibria_table: freqs(1:nd, k) the k-th's centre frequencies, ascending, NaN where
  !> fewer than nd pairs are centres; stable(k) 1 when all nd are (linearly stable), else 0.
  subroutine centres_of(system, params, lo, hi, n_grid, stores, n, freqs, stable, stat)
    character(*), intent(in) :: system
    real(wp), intent(in) :: params(:), lo(:), hi(:)
    integer, intent(in) :: n_grid
    type(seed_stores_t), pointer, intent(in) :: stores
    integer, intent(out) :: n, stable(:), stat
    real(wp), intent(out) :: freqs(:, :)
    class(hamiltonian_t), allocatable :: model
    type(equilibrium_t), allocatable :: eqs(:)
    integer :: nd, k
    n = 0
    freqs = ieee_value(1.0_wp, ieee_quiet_nan)
    stable = 0
    call model_equilibria(system, params, lo, hi, n_grid, stores, model, eqs, stat)
    if (stat /= TUBES_OK) return
    nd = model%ndof()
    if (size(eqs) > size(stable) .or. nd > size(freqs, 1)) then
      stat = TUBES_EINPUT
      return
    end if
    n = size(eqs)
    do k = 1, n
      if (allocated(eqs(k)%freqs)) freqs(1:nd, k) = eqs(k)%freqs
      stable(k) = merge(1, 0, eqs(k)%stable)
    end do
  end subroutine centres_of

  !> The equilibria as the tables of the C API and the f2py facade: column k of each is eqs(k)
  !> (nd degrees of freedom; rank1 1 for a rank-1 saddle, 2 for a degenerate one, else 0; evec
  !> the 2nd x 2nd eigenvector matrix by columns). The arrays' other entries are left alone.
  subroutine equilibria_table(eqs, nd, q, p, height, energy, grad_norm, morse, rank1, lambda, omega, evec)
    type(equilibrium_t), intent(in) :: eqs(:)
    integer, intent(in) :: nd
    real(wp), intent(inout) :: q(:, :), p(:, :), height(:), energy(:), grad_norm(:), lambda(:), &
                               omega(:, :), evec(:, :)
    integer, intent(inout) :: morse(:), rank1(:)
    integer :: k
    do k = 1, size(eqs)
      q(1:nd, k) = eqs(k)%q
      p(1:nd, k) = eqs(k)%x(nd + 1:2*nd)
      height(k) = eqs(k)%height
      energy(k) = eqs(k)%energy
      grad_norm(k) = eqs(k)%grad_norm
      morse(k) = eqs(k)%morse
      rank1(k) = merge(1, merge(2, 0, eqs(k)%degenerate), eqs(k)%rank1)
      lambda(k) = eqs(k)%lambda
      omega(1:nd - 1, k) = eqs(k)%omegas(1:nd - 1)
      evec(1:4*nd*nd, k) = reshape(eqs(k)%evec, [4*nd*nd])
    end do
  end subroutine equilibria_table

  !> The model, the saddle and the section of a tube-dynamics call at energy E_e + de:
  !> sec_kind 1 = the ball's ray theta = level [rad] with sign(p_theta) = dir, 2 = the plane
  !> q_index = level crossed with sign(dq_index/dt) = dir. q_ref is a configuration point of the
  !> section's side of the saddle: the well nearest the ray's direction, or the middle of the
  !> plane's region. stat = TUBES_EINPUT for a section that makes no sense for the model or
  !> does not meet the energy surface. crossing_only (the tube cuts): a model with N > 2 degrees
  !> of freedom takes a plane for its crossings alone (make_plane_crossing: no region), q_ref
  !> the saddle's q moved onto the plane (the plane through the saddle is TUBES_EINPUT).
  subroutine setup_section(system, params, lo, hi, n_grid, saddle, sec_kind, sec_index, level, dir, &
                           de, model, eqs, isad, psec, q_ref, stat, stores, crossing_only)
    character(*), intent(in) :: system, saddle
    real(wp), intent(in) :: params(:), lo(:), hi(:), level, de
    integer, intent(in) :: n_grid, sec_kind, sec_index, dir
    class(hamiltonian_t), allocatable, intent(out) :: model
    type(equilibrium_t), allocatable, intent(out) :: eqs(:)
    integer, intent(out) :: isad
    type(poincare_t), intent(out) :: psec
    real(wp), allocatable, intent(out) :: q_ref(:)
    integer, intent(out) :: stat
    type(seed_stores_t), intent(inout), optional :: stores   !! the run's kept results
    logical, intent(in), optional :: crossing_only
    integer :: k, iw, j
    real(wp) :: best, d, s_lo, s_hi
    call setup_model(system, params, lo, hi, n_grid, saddle, model, eqs, isad, stat, stores=stores)
    if (stat /= TUBES_OK) return
    stat = TUBES_EINPUT
    if (present(crossing_only)) then
      if (crossing_only .and. model%ndof() > 2) then
        if (sec_kind /= SECTION_PLANE) return
        call make_plane_crossing(psec, model%ndof(), sec_index, level, dir, stat)
        if (stat /= TUBES_OK) return
        q_ref = eqs(isad)%q
        q_ref(sec_index) = level
        if (level == eqs(isad)%q(sec_index)) stat = TUBES_EINPUT   ! through the saddle: no side
        return
      end if
    end if
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
      call plane_search_range(lo, hi, sec_index, s_lo, s_hi)
      call make_plane_section(psec, model, sec_index, level, dir, eqs(isad)%q(j), s_lo, s_hi, stat)
      if (stat /= TUBES_OK) return
      call psec%set_energy(eqs(isad)%energy + de, 0.0_wp, stat)
      if (stat /= TUBES_OK) return
      allocate (q_ref(2))
      q_ref(sec_index) = level
      q_ref(j) = 0.5_wp*(psec%smin + psec%smax)
      if (abs(q_ref(sec_index) - eqs(isad)%q(sec_index)) == 0) stat = TUBES_EINPUT  ! through the saddle
    end select
  end subroutine setup_section

  !> The orbits of the saddle's family at des (orbit_family), on the run's path of this family
  !> (model, saddle and opts) when stores are given: a family is continued once in a run, and
  !> each orbit found once (docs/orbits.md, "One family, each orbit once").
  recursive subroutine family_at(st, model, eqs, isad, des, opts, orbs, end_de, end_reason, stat, stores, folds)
    type(study_t), intent(in) :: st
    class(hamiltonian_t), intent(in) :: model
    type(equilibrium_t), intent(in) :: eqs(:)
    integer, intent(in) :: isad
    real(wp), intent(in) :: des(:)
    type(orbit_opts_t), intent(in) :: opts
    type(orbit_t), intent(out) :: orbs(size(des))
    real(wp), intent(out) :: end_de
    integer, intent(out) :: end_reason, stat
    type(seed_stores_t), intent(inout), optional :: stores   !! the run's kept results
    type(fold_t), allocatable, intent(out), optional :: folds(:)  !! a guess's family: its folds
    type(kept_path_t) :: entry
    integer(i8) :: key(NKEY)
    integer :: i
    end_de = -1
    end_reason = 0
    stat = TUBES_OK
    if (present(folds)) allocate (folds(0))
    call check_resolved(eqs(isad), des, stat)
    if (stat /= TUBES_OK) return
    if (opts%branch > 0) then
      call branch_at(st, model, eqs, isad, des, opts, orbs, end_de, end_reason, stat, stores, folds)
      return
    end if
    ! a family by name (docs/orbits.md, "Branch switching"): 'vertical' and 'lyapunov' are a centre
    ! mode's family, the same (and kept as the same) as that mode's number
    if (opts%family == FAMILY_VERTICAL .or. opts%family == FAMILY_PLANAR) then
      i = 0
      if (isad >= 1 .and. isad <= size(eqs)) i = named_mode(eqs(isad), model%ndof(), opts%family)
      if (i == 0) then
        end_reason = END_NOMODE
        orbs(:)%de = des
        return
      end if
      block
        type(orbit_opts_t) :: o
        o = opts
        o%family = i
        call family_at(st, model, eqs, isad, des, o, orbs, end_de, end_reason, stat, stores, folds)
      end block
      return
    end if
    if (opts%family == FAMILY_AXIAL) then
      call axial_at(st, model, eqs, isad, des, opts, orbs, end_de, end_reason, stat, stores, folds)
      return
    end if
    if (.not. present(stores)) then
      call orbit_family(model, eqs, isad, des, opts, orbs, end_de, end_reason, stat, folds=folds)
      return
    end if
    key = family_key(st, opts)
    if (.not. allocated(stores%paths)) allocate (stores%paths(0))
    i = kept_at(stores%paths, st, key)
    if (i > 0) then
      call orbit_family(model, eqs, isad, des, opts, orbs, end_de, end_reason, stat, stores%paths(i)%path, folds)
      return
    end if
    call orbit_family(model, eqs, isad, des, opts, orbs, end_de, end_reason, stat, entry%path, folds)
    if (stat == TUBES_EINPUT) return      ! a call that made no sense leaves nothing to keep
    entry%system = st%system
    entry%saddle = st%saddle
    entry%key = key
    stores%paths = [stores%paths, entry]
  end subroutine family_at

  !> The family branching off at the opts%branch-th bifurcation (family_bifurcations) of the parent
  !> family (opts with branch = 0: the guess's family, or the saddle's family opts%family) at des:
  !> a branch point or a period doubling, continued by branch_arc from the orbit there along the
  !> monodromy's eigenvector (docs/orbits.md, "Period doubling and the doubled family").
  !> END_NOBRANCH (no orbit) when the parent has fewer bifurcations or that one is not a branch.
  recursive subroutine branch_at(st, model, eqs, isad, des, opts, orbs, end_de, end_reason, stat, stores, folds)
    type(study_t), intent(in) :: st
    class(hamiltonian_t), intent(in) :: model
    type(equilibrium_t), intent(in) :: eqs(:)
    integer, intent(in) :: isad
    real(wp), intent(in) :: des(:)
    type(orbit_opts_t), intent(in) :: opts
    type(orbit_t), intent(out) :: orbs(size(des))
    real(wp), intent(out) :: end_de
    integer, intent(out) :: end_reason, stat
    type(seed_stores_t), intent(inout), optional :: stores
    type(fold_t), allocatable, intent(inout), optional :: folds(:)   !! the branch's folds
    type(orbit_opts_t) :: po
    type(orbit_t) :: parent(size(des))
    type(bifurcation_t), allocatable :: bifs(:)
    type(fold_t), allocatable :: fl(:)
    real(wp) :: nu(2*model%ndof() - 2, size(des))
    integer :: k
    po = opts
    po%branch = 0
    do k = 1, size(des)
      orbs(k)%de = des(k)
    end do
    call family_at(st, model, eqs, isad, des, po, parent, end_de, end_reason, stat, stores, fl)
    if (stat < 0) return
    call family_bifurcations(st, model, eqs, isad, des, parent, po, nu, bifs, stat, stores, fl)
    if (stat < 0) return
    end_de = -1
    end_reason = END_NOBRANCH
    stat = TUBES_OK
    k = opts%branch
    if (k > size(bifs)) return
    if (.not. bifs(k)%converged .or. (bifs(k)%kind /= BIF_BRANCH .and. bifs(k)%kind /= BIF_PERIOD_DOUBLING)) return
    deallocate (fl)
    allocate (fl(0))   ! the branch's own folds
    call branch_arc(model, eqs, isad, bifs(k)%x0, bifs(k)%period, bifs(k)%tangent, &
                    merge(1, -1, bifs(k)%kind == BIF_BRANCH), des, opts, orbs, end_de, end_reason, fl, stat)
    if (present(folds)) call move_alloc(fl, folds)
  end subroutine branch_at

  !> The axial family ('axial'; docs/orbits.md, "Branch switching"): the planar family ('lyapunov',
  !> named_mode) on the ladder of branch_ladder (dE_1 2^j up to the first energy at or above the
  !> largest of des: the branch point found does not depend on des, and is kept in stores for the
  !> next call), upwards until its bifurcations (family_bifurcations) hold the first branch point whose tangent (the monodromy's
  !> eigenvector for +1) lies mostly on the reversor's odd components (the branch keeps the symmetry
  !> q_2, q_N -> -q_2, -q_N, t -> -t; the halo branch point's tangent is even), branch_arc along the
  !> tangent's side of positive tilt (tilt_of: the mean of q_2 q_N grows), stopped at the branch's
  !> first fold (at the vertical family's branch point in the spatial CR3BP), by multiple shooting
  !> (n_segments, at least 4). END_NOMODE without a
  !> planar/vertical split (or a reversor), END_NOBRANCH without such a branch point below max(des).
  recursive subroutine axial_at(st, model, eqs, isad, des, opts, orbs, end_de, end_reason, stat, stores, folds)
    type(study_t), intent(in) :: st
    class(hamiltonian_t), intent(in) :: model
    type(equilibrium_t), intent(in) :: eqs(:)
    integer, intent(in) :: isad
    real(wp), intent(in) :: des(:)
    type(orbit_opts_t), intent(in) :: opts
    type(orbit_t), intent(out) :: orbs(size(des))
    real(wp), intent(out) :: end_de
    integer, intent(out) :: end_reason, stat
    type(seed_stores_t), intent(inout), optional :: stores
    type(fold_t), allocatable, intent(inout), optional :: folds(:)   !! the branch's folds
    integer, parameter :: AXIAL_SEGMENTS = 4
    type(orbit_opts_t) :: po, ao
    type(orbit_t), allocatable :: grid(:)
    type(bifurcation_t), allocatable :: bifs(:)
    type(fold_t), allocatable :: fl(:)
    real(wp), allocatable :: dg(:), nu(:, :)
    real(wp) :: tl, v(model%dim()), x0(model%dim()), period
    integer :: rev(model%dim())
    integer :: k, j, jp, i, ik
    integer(i8) :: key(NKEY)
    type(kept_path_t) :: entry
    logical :: kept
    end_de = -1
    end_reason = END_NOMODE
    stat = TUBES_OK
    do k = 1, size(des)
      orbs(k)%de = des(k)
    end do
    jp = named_mode(eqs(isad), model%ndof(), FAMILY_PLANAR)
    rev = model%reversor()
    if (jp == 0 .or. model%ndof() /= 3 .or. count(rev > 0) /= 3 .or. count(rev < 0) /= 3) return
    end_reason = END_NOBRANCH
    if (.not. maxval(des) > 0) return
    po = opts
    po%family = jp
    po%branch = 0
    ! the branch point kept by an earlier call (a period search's probes), with its ladder's top
    ik = 0
    kept = .false.
    if (present(stores)) then
      key = family_key(st, opts)
      if (.not. allocated(stores%paths)) allocate (stores%paths(0))
      ik = kept_at(stores%paths, st, key)
      if (ik > 0) then
        if (allocated(stores%paths(ik)%path%branch_w)) then
          ! found in the ladder's interval (dE_top / 2, dE_top]: this call's ladder, up to the first
          ! energy at or above max(des), walks the same lower intervals and reaches that one exactly
          ! when max(des) > dE_top / 2 (else it finds none)
          associate (bw => stores%paths(ik)%path%branch_w)
            if (.not. maxval(des) > bw(size(bw))/2) return
            x0 = bw(1:model%dim())
            period = bw(model%dim() + 1)
          end associate
          v = stores%paths(ik)%path%branch_t
          kept = .true.
          end_reason = END_NONE
        end if
      end if
    end if
    if (.not. kept) call search()
    if (stat < 0 .or. end_reason == END_NOBRANCH) return
    ! the arc by multiple shooting: n_segments (method = 'multiple'), at least AXIAL_SEGMENTS (with
    ! one segment, I - M of the branch point's orbit (multipliers ~400 at L1) left the first step's
    ! Newton iteration without convergence for h down to 1/4 of the first step; with 4 it takes 3)
    ao = opts
    ao%n_segments = max(opts%n_segments, AXIAL_SEGMENTS)
    allocate (fl(0))
    end_de = -1
    end_reason = END_NOBRANCH
    stat = TUBES_OK
    call branch_arc(model, eqs, isad, x0, period, v, 1, des, ao, orbs, end_de, end_reason, fl, &
                    stat, end_at_fold=.true.)
    if (present(folds)) call move_alloc(fl, folds)
  contains
    ! the planar family's first odd branch point on the ladder: x0, period, v (kept in stores), and
    ! end_reason END_NONE; or end_reason END_NOBRANCH (none), or stat < 0
    subroutine search()
    dg = branch_ladder(model, eqs, isad, maxval(des))
    allocate (grid(size(dg)), nu(2*model%ndof() - 2, size(dg)))
    ! the ladder upwards, one energy at a time (on the run's path of the planar family), each interval's
    ! bifurcations located as soon as it is known, until the first odd branch point: the family is not
    ! continued further than needed (a grid up to 0.2 at L2 continued the planar family to its end near
    ! dE = 0.165, 3 minutes)
    j = 0
    do k = 1, size(dg)
      call family_at(st, model, eqs, isad, dg(k:k), po, grid(k:k), end_de, end_reason, stat, stores)
      if (stat < 0) return
      if (.not. grid(k)%converged) exit
      if (k == 1) cycle
      call family_bifurcations(st, model, eqs, isad, dg(k - 1:k), grid(k - 1:k), po, nu(:, k - 1:k), bifs, &
                               stat, stores)
      if (stat < 0) return
      do i = 1, size(bifs)
        if (bifs(i)%kind /= BIF_BRANCH .or. .not. bifs(i)%converged) cycle
        if (sum(bifs(i)%tangent**2, mask=rev < 0) > sum(bifs(i)%tangent**2, mask=rev > 0)) then
          j = i
          exit
        end if
      end do
      if (j > 0) exit
    end do
    end_de = -1
    end_reason = END_NOBRANCH
    stat = TUBES_OK
    if (j == 0) return
    v = bifs(j)%tangent
    tl = tilt_of(model, bifs(j)%x0, bifs(j)%period, v, opts, stat)
    if (stat < 0) return
    if (tl < 0) v = -v
    x0 = bifs(j)%x0
    period = bifs(j)%period
    if (present(stores) .and. ens_reuse_ok('segment', opts%local)) then   ! kept: the point, its energy, the ladder's top
      if (ik == 0) then
        entry%system = st%system
        entry%saddle = st%saddle
        entry%key = key
        stores%paths = [stores%paths, entry]
        ik = size(stores%paths)
      end if
      stores%paths(ik)%path%branch_w = [x0, period, dg(k)]   ! dg(k): the top of its interval
      stores%paths(ik)%path%branch_t = v
    end if
    end_reason = END_NONE
    end subroutine search
  end subroutine axial_at

  !> The orbits scene's call: the study's model, equilibria and saddle (setup_model), then the
  !> saddle's family at des (family_at); TUBES_EINPUT for options that make no sense.
  subroutine study_family(st, des, opts, model, eqs, isad, orbs, end_de, end_reason, stat, stores, folds)
    type(study_t), intent(in) :: st
    real(wp), intent(in) :: des(:)
    type(orbit_opts_t), intent(in) :: opts
    class(hamiltonian_t), allocatable, intent(out) :: model
    type(equilibrium_t), allocatable, intent(out) :: eqs(:)
    integer, intent(out) :: isad
    type(orbit_t), intent(out) :: orbs(size(des))
    real(wp), intent(out) :: end_de
    integer, intent(out) :: end_reason, stat
    type(seed_stores_t), intent(inout), optional :: stores   !! the run's kept results
    type(fold_t), allocatable, intent(out), optional :: folds(:)  !! a guess's family: its folds
    end_de = -1
    end_reason = 0
    isad = 0
    if (present(folds)) allocate (folds(0))
    stat = TUBES_EINPUT
    if (size(des) < 1 .or. opts%n_samples < 2 .or. opts%max_iter < 1 .or. opts%n_segments < 1 .or. &
        .not. opts%tol > 0) return
    call setup_model(trim(st%system), st%params, st%lo, st%hi, st%n_grid, trim(st%saddle), model, eqs, &
                     isad, stat, stores=stores)
    if (stat /= TUBES_OK) return
    call family_at(st, model, eqs, isad, des, opts, orbs, end_de, end_reason, stat, stores, folds)
  end subroutine study_family

  !> The orbits as the tables of the C API and the f2py facade (docs/output.md, /orbits): column k
  !> of each is orbs(k) at energy e_saddle + des(k) (n2 = 2N state components; history: the first
  !> size(history, 1) Newton residuals). A column of an orbit that did not converge keeps its
  !> energy, iterations and history; the arrays' other entries are left alone.
  subroutine family_table(orbs, e_saddle, des, n2, energy, period, action, state0, mu_u, mu_s, mu_triv, &
                          stab, residual, closure, iterations, converged, mindist, monodromy, ts, xs, history)
    type(orbit_t), intent(in) :: orbs(:)
    real(wp), intent(in) :: e_saddle, des(:)
    integer, intent(in) :: n2
    real(wp), intent(inout) :: energy(:), period(:), action(:), state0(:, :), mu_u(:), mu_s(:), &
                               mu_triv(:, :), stab(:), residual(:), closure(:), mindist(:), &
                               monodromy(:, :), ts(:, :), xs(:, :, :), history(:, :)
    integer, intent(inout) :: iterations(:), converged(:)
    integer :: k, nh
    do k = 1, size(orbs)
      energy(k) = e_saddle + des(k)
      if (allocated(orbs(k)%history)) then
        nh = min(size(orbs(k)%history), size(history, 1))
        history(1:nh, k) = orbs(k)%history(1:nh)
      end if
      iterations(k) = orbs(k)%iterations
      converged(k) = merge(1, 0, orbs(k)%converged)
      if (.not. orbs(k)%converged) cycle
      period(k) = orbs(k)%period
      action(k) = orbs(k)%action
      state0(1:n2, k) = orbs(k)%x0
      mu_u(k) = orbs(k)%mu_unstable
      mu_s(k) = orbs(k)%mu_stable
      mu_triv(:, k) = [orbs(k)%mu_trivial(1), orbs(k)%mu_trivial_imag(1), &
                       orbs(k)%mu_trivial(2), orbs(k)%mu_trivial_imag(2)]
      stab(k) = orbs(k)%stability_index
      residual(k) = orbs(k)%residual
      closure(k) = orbs(k)%closure
      mindist(k) = orbs(k)%min_eq_distance
      monodromy(1:n2*n2, k) = reshape(orbs(k)%monodromy, [n2*n2])
      ts(:, k) = orbs(k)%t
      xs(1:n2, :, k) = orbs(k)%x
    end do
  end subroutine family_table

  !> The counts of an orbit's Floquet indices (floquet_indices) that bifurcations change:
  !> c(BIF_BRANCH) real indices above +1, c(BIF_PERIOD_DOUBLING) real ones below -1,
  !> c(BIF_KREIN) complex ones.
  pure function orbit_crossings(nre, nim) result(c)
    real(wp), intent(in) :: nre(:), nim(:)
    integer :: c(3)
    logical :: cplx(size(nre))
    cplx = abs(nim) > BIF_COMPLEX*(1 + abs(nre))
    c(BIF_BRANCH) = count(.not. cplx .and. nre > 1)
    c(BIF_PERIOD_DOUBLING) = count(.not. cplx .and. nre < -1)
    c(BIF_KREIN) = count(cplx)
  end function orbit_crossings

  !> Bifurcation monitoring of a family (docs/orbits.md, "Bifurcations"): between consecutive
  !> converged orbits orbs(k), orbs(k + 1) at des(k) < des(k + 1), each count of orbit_crossings
  !> that differs is located by bisection in dE, every midpoint a corrected orbit of the family
  !> (family_at: the continuation to that energy alone), to a bracket of width <= BIF_TOL dE;
  !> the orbit at the final midpoint gives the energy, period and indices. A change and its
  !> reversal between two requested energies are not seen (the requested energies set the
  !> resolution). nu(:, k): the indices of orbs(k) (Re in 1:N-1, Im in N:2N-2; 0 if not converged).
  recursive subroutine family_bifurcations(st, model, eqs, isad, des, orbs, opts, nu, bifs, stat, stores, folds)
    type(study_t), intent(in) :: st
    class(hamiltonian_t), intent(in) :: model
    type(equilibrium_t), intent(in) :: eqs(:)
    integer, intent(in) :: isad
    real(wp), intent(in) :: des(:)
    type(orbit_t), intent(in) :: orbs(:)
    type(orbit_opts_t), intent(in) :: opts
    real(wp), intent(out) :: nu(:, :)                      !! (2N - 2, size(des))
    type(bifurcation_t), allocatable, intent(out) :: bifs(:)
    integer, intent(out) :: stat
    type(seed_stores_t), intent(inout), optional :: stores
    type(fold_t), intent(in), optional :: folds(:)   !! the family's folds (a guess's family): kind BIF_FOLD
    integer :: k, kind, np, cnt(3, size(des))
    type(bifurcation_t) :: b
    np = model%ndof() - 1
    allocate (bifs(0))
    nu = 0
    cnt = -1
    do k = 1, size(des)
      if (.not. orbs(k)%converged) cycle
      call floquet_indices(orbs(k)%monodromy, nu(1:np, k), nu(np + 1:2*np, k), stat)
      if (stat /= TUBES_OK) return
      cnt(:, k) = orbit_crossings(nu(1:np, k), nu(np + 1:2*np, k))
    end do
    stat = TUBES_OK
    do k = 1, size(des) - 1
      if ((opts%family < 0 .and. opts%family /= FAMILY_VERTICAL .and. opts%family /= FAMILY_PLANAR) .or. &
          opts%branch > 0) exit   ! a branch family: its orbits' indices only
      if (cnt(1, k) < 0 .or. cnt(1, k + 1) < 0) cycle
      do kind = 1, 3
        if (cnt(kind, k) == cnt(kind, k + 1)) cycle
        call locate(k, kind, b)
        if (stat < 0) return
        bifs = [bifs, b]
      end do
    end do
    if (present(folds)) then
      do k = 1, size(folds)
        b = bifurcation_t(kind=BIF_FOLD, after=count(des < folds(k)%de), de=folds(k)%de, width=folds(k)%width, &
                          energy=eqs(isad)%energy + folds(k)%de, period=folds(k)%period, converged=.true.)
        allocate (b%nre(np), b%nim(np))
        call floquet_indices(folds(k)%monodromy, b%nre, b%nim, stat)
        if (stat /= TUBES_OK) return
        b%x0 = folds(k)%x0
        b%tangent = folds(k)%tangent
        bifs = [bifs, b]
      end do
    end if
    stat = TUBES_OK
  contains
    subroutine locate(k, kind, b)
      integer, intent(in) :: k, kind
      type(bifurcation_t), intent(out) :: b
      type(orbit_t) :: o(1)
      real(wp) :: lo, hi, mid, end_de, r(np), im(np)
      integer :: reason, c_lo, c(3)
      lo = des(k)
      hi = des(k + 1)
      c_lo = cnt(kind, k)
      b%kind = kind
      b%after = k
      b%converged = .true.
      do while (hi - lo > BIF_TOL*max(abs(lo), abs(hi)))
        mid = lo + (hi - lo)/2
        call family_at(st, model, eqs, isad, [mid], opts, o, end_de, reason, stat, stores)
        if (stat < 0) return
        if (.not. o(1)%converged) then
          b%converged = .false.
          exit
        end if
        call floquet_indices(o(1)%monodromy, r, im, stat)
        if (stat /= TUBES_OK) return
        c = orbit_crossings(r, im)
        if (c(kind) == c_lo) then
          lo = mid
        else
          hi = mid
        end if
      end do
      b%de = lo + (hi - lo)/2
      b%width = hi - lo
      b%energy = eqs(isad)%energy + b%de
      allocate (b%nre(np), b%nim(np))
      b%nre = 0
      b%nim = 0
      stat = TUBES_OK
      if (.not. b%converged) return
      call family_at(st, model, eqs, isad, [b%de], opts, o, end_de, reason, stat, stores)
      if (stat < 0) return
      b%converged = o(1)%converged
      stat = TUBES_OK
      if (.not. b%converged) return
      b%period = o(1)%period
      call floquet_indices(o(1)%monodromy, b%nre, b%nim, stat)
      if (stat /= TUBES_OK) return
      b%x0 = o(1)%x0
      allocate (b%tangent(size(b%x0)))
      b%tangent = 0
      if (kind == BIF_KREIN) return
      block
        real(wp) :: fx(size(b%x0))
        call model%eval(0.0_wp, b%x0, fx, stat)
        if (stat /= TUBES_OK) then
          stat = TUBES_ENOCONV
          return
        end if
        call floquet_tangent(o(1)%monodromy, fx, merge(1, -1, kind == BIF_BRANCH), b%tangent, stat)
      end block
    end subroutine locate
  end subroutine family_bifurcations

  !> The family at des and its bifurcations as tables (the orbits scene's /orbits/floquet_index and
  !> /orbits/bifurcations, for the C API and f2py alike): nu(1:N-1, k), nu(MD:MD+N-2, k) the Re and
  !> Im of orbit k's indices (MD = size(nu, 1)/2 + 1 rows of each); bifurcation j (j <= nbif,
  !> at most size(kind)): kind, after (0-based: between orbits after and after + 1), bconv, bde,
  !> bwidth, benergy, bperiod, bnu (as nu), bx0 and btan (2N rows).
  subroutine bifurcation_table(st, des, opts, nu, nbif, kind, after, bconv, bde, bwidth, benergy, bperiod, bnu, &
                               bx0, btan, stat, stores)
    type(study_t), intent(in) :: st
    real(wp), intent(in) :: des(:)
    type(orbit_opts_t), intent(in) :: opts
    real(wp), intent(out) :: nu(:, :), bde(:), bwidth(:), benergy(:), bperiod(:), bnu(:, :), bx0(:, :), btan(:, :)
    integer, intent(out) :: nbif, kind(:), after(:), bconv(:)
    integer, intent(out) :: stat
    type(seed_stores_t), intent(inout), optional :: stores
    class(hamiltonian_t), allocatable :: model
    type(equilibrium_t), allocatable :: eqs(:)
    type(orbit_t), allocatable :: orbs(:)
    type(bifurcation_t), allocatable :: bifs(:)
    type(fold_t), allocatable :: fl(:)
    real(wp), allocatable :: nu1(:, :)
    integer :: isad, reason, k, np, md
    real(wp) :: ede
    nu = 0; nbif = 0; kind = 0; after = 0; bconv = 0; bde = 0; bwidth = 0; benergy = 0; bperiod = 0; bnu = 0
    bx0 = 0; btan = 0
    md = size(nu, 1)/2 + 1
    allocate (orbs(size(des)))
    call study_family(st, des, opts, model, eqs, isad, orbs, ede, reason, stat, stores, fl)
    if (stat < 0) return
    np = model%ndof() - 1
    allocate (nu1(2*np, size(des)))
    call family_bifurcations(st, model, eqs, isad, des, orbs, opts, nu1, bifs, stat, stores, fl)
    if (stat < 0) return
    nu(1:np, :) = nu1(1:np, :)
    nu(md:md + np - 1, :) = nu1(np + 1:2*np, :)
    nbif = size(bifs)
    do k = 1, min(nbif, size(kind))
      kind(k) = bifs(k)%kind
      after(k) = bifs(k)%after - 1
      bconv(k) = merge(1, 0, bifs(k)%converged)
      bde(k) = bifs(k)%de
      bwidth(k) = bifs(k)%width
      benergy(k) = bifs(k)%energy
      bperiod(k) = bifs(k)%period
      bnu(1:np, k) = bifs(k)%nre
      bnu(md:md + np - 1, k) = bifs(k)%nim
      if (allocated(bifs(k)%x0)) bx0(1:2*np + 2, k) = bifs(k)%x0
      if (allocated(bifs(k)%tangent)) btan(1:2*np + 2, k) = bifs(k)%tangent
    end do
    stat = TUBES_OK
  end subroutine bifurcation_table

  !> The Lyapunov orbit at excess energy de (the options of st; local: on this MPI rank alone).
  subroutine orbit_at(st, model, eqs, isad, de, local, orb, stat, stores)
    type(study_t), intent(in) :: st
    class(hamiltonian_t), intent(in) :: model
    type(equilibrium_t), intent(in) :: eqs(:)
    integer, intent(in) :: isad
    real(wp), intent(in) :: de
    logical, intent(in) :: local
    type(orbit_t), intent(out) :: orb
    integer, intent(out) :: stat
    type(seed_stores_t), intent(inout), optional :: stores   !! the run's kept results
    type(orbit_t), allocatable :: orbs(:)   ! (a local array: gfortran 12 -O1 -fcheck=all warned on its initialiser)
    real(wp) :: end_de
    integer :: reason
    allocate (orbs(1))
    call family_at(st, model, eqs, isad, [de], study_orbit_opts(st, local), orbs, end_de, reason, stat, stores)
    if (stat /= TUBES_OK) return
    orb = orbs(1)
    if (.not. orb%converged) then
      stat = TUBES_ENOCONV
      if (end_de > 0 .and. de >= end_de*(1 - 1.0e-6_wp)) stat = TUBES_EPASTEND
    end if
  end subroutine orbit_at

  !> The orbit options of a study's cuts (local: on this MPI rank alone).
  pure function study_orbit_opts(st, local) result(opts)
    type(study_t), intent(in) :: st
    logical, intent(in) :: local
    type(orbit_opts_t) :: opts
    opts%n_segments = st%n_segments
    opts%tol = st%orb_tol
    opts%rtol = st%orb_rtol
    opts%atol = st%orb_atol
    opts%local = local
    opts%integ = st%integ
    opts%family = st%family
  end function study_orbit_opts

  !> The transit gate of saddle eqs(isad) seen from q_ref (the section's side): the
  !> configuration hyperplane dist past the saddle across its neck (neck_normal), away from q_ref,
  !> bounded at energy e to the neck's segment of it in 2 DOF (gate_bound: a crossing of the line
  !> through another opening of the energy surface is no transit).
  subroutine saddle_gate(model, sad, q_ref, dist, e, gspec, stat)
    class(hamiltonian_t), intent(in) :: model
    type(equilibrium_t), intent(in) :: sad
    real(wp), intent(in) :: q_ref(:)
    real(wp), intent(in) :: dist
    real(wp), intent(in) :: e                !! the energy the segment is bounded at
    type(gate_spec_t), intent(out) :: gspec
    integer, intent(out) :: stat
    gspec%origin = sad%q
    gspec%normal = neck_normal(model, sad)
    if (dot_product(gspec%normal, q_ref - sad%q) > 0) gspec%normal = -gspec%normal
    gspec%dist = dist
    stat = TUBES_OK
    if (model%ndof() == 2) call gate_bound(model, gspec, e, stat)
  end subroutine saddle_gate

  !> A dissipative field without noise loses energy for good: below the saddle's energy a
  !> trajectory cannot pass the neck, and the gate stops it there (MC_TRAPPED: no transition).
  subroutine gate_floor_of(field, sad, gspec)
    class(vector_field_t), intent(in) :: field
    type(equilibrium_t), intent(in) :: sad
    type(gate_spec_t), intent(inout) :: gspec
    select type (field)
    type is (damped_t)
      if (.not. field%noisy()) gspec%e_floor = sad%energy
    end select
  end subroutine gate_floor_of

  !> The reach at de of the saddle's NHIM across its neck (nhim_reach along neck_normal): a
  !> Monte Carlo gate must exceed twice it (gate_holds_nhim; check_at refuses it otherwise).
  subroutine gate_reach(st, de, reach, stat, stores)
    type(study_t), intent(in) :: st
    real(wp), intent(in) :: de
    real(wp), intent(out) :: reach
    integer, intent(out) :: stat
    type(seed_stores_t), intent(inout), optional :: stores   !! the run's kept results
    class(hamiltonian_t), allocatable :: model
    type(equilibrium_t), allocatable :: eqs(:)
    integer :: isad
    reach = 0
    call setup_model(trim(st%system), st%params, st%lo, st%hi, st%n_grid, trim(st%saddle), model, eqs, isad, &
                     stat, stores=stores)
    if (stat /= TUBES_OK) return
    reach = nhim_reach(eqs(isad), de, neck_normal(model, eqs(isad)))
  end subroutine gate_reach

  !> The energy surface on the section at E_e + de: its interval [smin, smax], area, dA/dE.
  subroutine section_info(st, sec, de, smin, smax, area, darea, stat, stores)
    type(study_t), intent(in) :: st
    type(section_choice_t), intent(in) :: sec
    real(wp), intent(in) :: de
    real(wp), intent(out) :: smin, smax, area, darea
    integer, intent(out) :: stat
    type(seed_stores_t), intent(inout), optional :: stores   !! the run's kept results
    class(hamiltonian_t), allocatable :: model
    type(equilibrium_t), allocatable :: eqs(:)
    type(poincare_t), target :: psec
    real(wp), allocatable :: q_ref(:)
    integer :: isad, st_d
    real(wp) :: err
    smin = 0; smax = 0; area = 0; darea = 0
    call setup_section(trim(st%system), st%params, st%lo, st%hi, st%n_grid, trim(st%saddle), sec%kind, &
                       sec%index, sec%level, sec%dir, de, model, eqs, isad, psec, q_ref, stat, stores)
    if (stat /= TUBES_OK) return
    smin = psec%smin
    smax = psec%smax
    call psec%area(area, err, stat)
    if (stat /= TUBES_OK) return
    ! dA_E/dE diverges (logarithmically) as E nears a maximum of V the region touches (the ball's
    ! R1, 777.06 above S12): its quadrature may fail where the area's does not; NaN then, and the
    ! area stands (the transition needs only A_E; the /section scene refuses a NaN tau)
    call psec%area(darea, err, st_d, derivative=.true.)
    if (st_d /= TUBES_OK) darea = ieee_value(1.0_wp, ieee_quiet_nan)
  end subroutine section_info

  !> The leading order of p_trans at small dE (docs/theory.md): p = (T_po/A0) dE (1 - tau dE/A0),
  !> T_po = 2 pi/omega the saddle's Lyapunov period at dE -> 0, A0 the energy surface's area on the
  !> section at the saddle's energy and tau = dA_E/dE there. The transition scene (C) and Python
  !> call it.
  pure function p_trans_leading(tpo, a0, tau, de) result(p) bind(C, name='tubes_p_trans_leading')
    use, intrinsic :: iso_c_binding, only: c_double
    real(c_double), value, intent(in) :: tpo, a0, tau, de
    real(c_double) :: p
    p = tpo/a0*de*(1 - tau/a0*de)
  end function p_trans_leading

  !> T_po, A0 and tau (p_trans_leading) of the study's saddle and section.
  subroutine leading_order_at(st, sec, tpo, a0, tau, stat, stores)
    type(study_t), intent(in) :: st
    type(section_choice_t), intent(in) :: sec
    real(wp), intent(out) :: tpo, a0, tau
    integer, intent(out) :: stat
    type(seed_stores_t), intent(inout), optional :: stores   !! the run's kept results
    class(hamiltonian_t), allocatable :: model
    type(equilibrium_t), allocatable :: eqs(:)
    type(poincare_t) :: psec
    real(wp), allocatable :: q_ref(:)
    real(wp) :: smin, smax
    integer :: isad
    tpo = ieee_value(1.0_wp, ieee_quiet_nan); a0 = tpo; tau = tpo
    call setup_section(trim(st%system), st%params, st%lo, st%hi, st%n_grid, trim(st%saddle), sec%kind, &
                       sec%index, sec%level, sec%dir, 0.0_wp, model, eqs, isad, psec, q_ref, stat, stores)
    if (stat /= TUBES_OK) return
    tpo = 2*PI/eqs(isad)%omega
    call section_info(st, sec, 0.0_wp, smin, smax, a0, tau, stat, stores)
  end subroutine leading_order_at

  !> The cut of the tube of the saddle's periodic orbit at excess energy de with the section
  !> (opts: kind, eps, area_tol, t_max, n_init, n_max, local): the orbit of family st%family (the
  !> Lyapunov family by default; any the orbits scene computes, the halo branch included). orb is
  !> the orbit. A cut that crosses a plane outside the chosen region is TUBES_EOUTSIDE. N > 2: the
  !> section is a plane q_k = c for its crossings alone (setup_section crossing_only), the branch
  !> of the manifold the one towards it from the saddle.
  subroutine cut_at(st, sec, de, opts, cut, orb, stat, stores)
    type(study_t), intent(in) :: st
    type(section_choice_t), intent(in) :: sec
    real(wp), intent(in) :: de
    type(tube_opts_t), intent(in) :: opts
    type(tube_cut_t), intent(out) :: cut
    type(orbit_t), intent(out) :: orb
    integer, intent(out) :: stat
    type(seed_stores_t), intent(inout), optional :: stores   !! the run's kept results
    type(tube_opts_t) :: o
    class(hamiltonian_t), allocatable :: model
    type(equilibrium_t), allocatable :: eqs(:)
    type(poincare_t) :: psec
    real(wp), allocatable :: q_ref(:)
    integer :: isad
    real(wp) :: tol_s
    call setup_section(trim(st%system), st%params, st%lo, st%hi, st%n_grid, trim(st%saddle), sec%kind, &
                       sec%index, sec%level, sec%dir, de, model, eqs, isad, psec, q_ref, stat, stores, &
                       crossing_only=.true.)
    if (stat /= TUBES_OK) return
    call orbit_at(st, model, eqs, isad, de, opts%local, orb, stat, stores)
    if (stat /= TUBES_OK) return
    o = opts
    o%integ = st%integ
    if (present(stores)) then
      call cut_kept(stores%kept)
    else
      call tube_cut(model, orb, q_ref - eqs(isad)%q, psec, o, cut, stat)
    end if
    ! a plane crossed outside the section's region (another part of the line) is not a cut of
    ! the section the caller asked for
    if (stat == TUBES_OK .and. psec%kind == SEC_PLANE .and. cut%n > 0 .and. model%ndof() == 2) then
      tol_s = 1.0e-9_wp*max(1.0_wp, psec%smax - psec%smin)
      if (any(cut%r(1:cut%n) < psec%smin - tol_s .or. cut%r(1:cut%n) > psec%smax + tol_s)) stat = TUBES_EOUTSIDE
    end if
  contains
    subroutine cut_kept(kept)     ! the cut with the store of its set-up
      type(kept_seeds_t), allocatable, intent(inout) :: kept(:)
      integer(i8) :: key(NKEY)
      type(kept_seeds_t) :: entry
      integer :: ik
      key = seed_key(st, sec, de, o)
      if (.not. allocated(kept)) allocate (kept(0))
      ik = kept_at(kept, st, key)
      if (ik == 0) then
        entry%system = st%system
        entry%saddle = st%saddle
        entry%key = key
        kept = [kept, entry]
        ik = size(kept)
      end if
      call tube_cut(model, orb, q_ref - eqs(isad)%q, psec, o, cut, stat, kept(ik)%store)
    end subroutine cut_kept
  end subroutine cut_at

  !> The Monte Carlo check at de: n points on the section, classified by the saddle's gate at
  !> distance gate, predicted by the cut (cr, cp).
  subroutine check_at(st, sec, de, n, seed, t_max, gate, cr, cp, r, pr, outcome, inside, stat, stores)
    use, intrinsic :: iso_c_binding, only: c_long
    type(study_t), intent(in) :: st
    type(section_choice_t), intent(in) :: sec
    real(wp), intent(in) :: de, t_max, gate, cr(:), cp(:)
    integer, intent(in) :: n
    integer(c_long), intent(in) :: seed
    real(wp), intent(out) :: r(n), pr(n)
    integer, intent(out) :: outcome(n)
    logical, intent(out) :: inside(n)
    integer, intent(out) :: stat
    type(seed_stores_t), intent(inout), optional :: stores   !! the run's kept results
    class(hamiltonian_t), allocatable :: model
    type(equilibrium_t), allocatable :: eqs(:)
    type(poincare_t) :: psec
    real(wp), allocatable :: q_ref(:)
    type(gate_spec_t) :: gspec
    class(vector_field_t), allocatable :: field
    real(wp) :: c
    integer :: isad
    r = 0; pr = 0; outcome = -1; inside = .false.
    call setup_section(trim(st%system), st%params, st%lo, st%hi, st%n_grid, trim(st%saddle), sec%kind, &
                       sec%index, sec%level, sec%dir, de, model, eqs, isad, psec, q_ref, stat, stores)
    if (stat /= TUBES_OK) return
    call check_resolved(eqs(isad), [de], stat)
    if (stat /= TUBES_OK) return
    if (.not. gate_holds_nhim(nhim_reach(eqs(isad), de, neck_normal(model, eqs(isad))), gate)) then
      stat = TUBES_ENARROW       ! orbits near the NHIM would swing past the gate: "transits"
      return
    end if
    call saddle_gate(model, eqs(isad), q_ref, gate, eqs(isad)%energy + de, gspec, stat)
    if (stat /= TUBES_OK) return
    call make_field(trim(st%system), st%params, field, c, stat)
    if (stat /= TUBES_OK) return
    select type (field)
    type is (damped_t)                 ! a noisy model's noise: the run's seed, each point its stream
      field%seed = seed
    end select
    call gate_floor_of(field, eqs(isad), gspec)
    if (dissipative(trim(st%system), st%params)) then   ! the dissipative model's trajectories
      call monte_carlo(model, psec, n, seed, gspec, t_max, 1.0e-10_wp, st%integ, cr, cp, r, pr, outcome, &
                       inside, stat, field)
    else
      call monte_carlo(model, psec, n, seed, gspec, t_max, 1.0e-10_wp, st%integ, cr, cp, r, pr, outcome, &
                       inside, stat)
    end if
  end subroutine check_at
  !> Poincare maps of the section at de: n_seeds starts on the section (half at the middle of
  !> the p_s range across the region, half across p_s at the region's middle s), n_iter returns
  !> each: pts(1:2, k, j) = (s, p_s) of the k-th return of seed j (NaN after it stops returning).
  subroutine maps_at(st, sec, de, n_seeds, n_iter, t_max, pts, stat, stores)
    type(study_t), intent(in) :: st
    type(section_choice_t), intent(in) :: sec
    real(wp), intent(in) :: de, t_max
    integer, intent(in) :: n_seeds, n_iter
    real(wp), intent(out) :: pts(2, n_iter, n_seeds)
    integer, intent(out) :: stat
    type(seed_stores_t), intent(inout), optional :: stores   !! the run's kept results
    class(hamiltonian_t), allocatable :: model
    type(equilibrium_t), allocatable :: eqs(:)
    type(poincare_t) :: psec
    real(wp), allocatable :: q_ref(:), x0(:, :)
    class(vector_field_t), allocatable :: field
    real(wp) :: rr, pp, rmid, pm, plo, phi_, pmid, level, c
    integer :: isad, j, h, s
    pts = 0
    level = sec%level
    call setup_section(trim(st%system), st%params, st%lo, st%hi, st%n_grid, trim(st%saddle), sec%kind, &
                       sec%index, sec%level, sec%dir, de, model, eqs, isad, psec, q_ref, stat, stores)
    if (stat /= TUBES_OK) return
    call check_resolved(eqs(isad), [de], stat)
    if (stat /= TUBES_OK) return
    allocate (x0(model%dim(), n_seeds))
    h = (n_seeds + 1)/2
    rmid = 0.5_wp*(psec%smin + psec%smax)
    call psec%bounds(rmid, plo, phi_)
    pm = 0.5_wp*(phi_ - plo)
    pmid = 0.5_wp*(phi_ + plo)
    if (psec%kind == SEC_RAY) then       ! the ray's p_r range at rmid from the potential (as before)
      pm = sqrt(max(0.0_wp, 2*(psec%energy - psec%ray%ball%potential_xy(rmid*cos(level), &
                                                                          rmid*sin(level)))/(5.0_wp/7)))
      pmid = 0
    end if
    do j = 1, n_seeds
      if (j <= h) then
        rr = psec%smin + (psec%smax - psec%smin)*(j - 0.5_wp)/h
        pp = 0
        if (psec%kind /= SEC_RAY) then
          call psec%bounds(rr, plo, phi_)
          pp = 0.5_wp*(plo + phi_)
        end if
      else
        rr = rmid
        pp = pmid + pm*(2*(j - h - 0.5_wp)/max(1, n_seeds - h) - 1)*0.98_wp
      end if
      call psec%state(rr, pp, x0(:, j), s)
      if (s /= TUBES_OK) then       ! a seed at the region's edge
        if (psec%kind == SEC_RAY) then
          x0(:, j) = [rmid*cos(level), rmid*sin(level), 0.0_wp, 0.0_wp]
        else
          call psec%state(rmid, pmid, x0(:, j), s)
        end if
      end if
    end do
    if (noisy_params(trim(st%system), st%params)) then
      stat = TUBES_ENOISE                ! the map of a noisy model: not built (no returns)
      pts = ieee_value(1.0_wp, ieee_quiet_nan)
      return
    end if
    call make_field(trim(st%system), st%params, field, c, stat)
    if (stat /= TUBES_OK) return
    if (dissipative(trim(st%system), st%params)) then   ! the dissipative model's returns (their energy falls)
      call poincare_map(model, psec, x0, n_iter, t_max, 1.0e-10_wp, st%integ, pts, stat, field)
    else
      call poincare_map(model, psec, x0, n_iter, t_max, 1.0e-10_wp, st%integ, pts, stat)
    end if
  end subroutine maps_at

  !> The dissipation of the study's model: its damping rate c (0 for a conservative model), the
  !> field a dissipative scene integrates (make_field).
  subroutine dissipation_of(st, field, c, stat)
    type(study_t), intent(in) :: st
    class(vector_field_t), allocatable, intent(out) :: field
    real(wp), intent(out) :: c
    integer, intent(out) :: stat
    call make_field(trim(st%system), st%params, field, c, stat)
  end subroutine dissipation_of

  !> The eigenvalues (wr + i wi, ascending real part) of the study's saddle linearised with the
  !> model's dissipation (make_field; c its damping rate, 0 for a conservative model: then the
  !> conservative spectrum).
  subroutine damped_spectrum(st, wr, wi, c, stat, stores)
    use tubes_lapack, only: eigen, dlasrt
    type(study_t), intent(in) :: st
    real(wp), intent(out) :: wr(:), wi(:)
    real(wp), intent(out) :: c
    integer, intent(out) :: stat
    type(seed_stores_t), intent(inout), optional :: stores   !! the run's kept results
    class(hamiltonian_t), allocatable :: model
    class(vector_field_t), allocatable :: field
    type(equilibrium_t), allocatable :: eqs(:)
    real(wp), allocatable :: jac(:, :)
    integer :: isad, n, i, j
    wr = 0
    wi = 0
    c = 0
    call setup_model(trim(st%system), st%params, st%lo, st%hi, st%n_grid, trim(st%saddle), model, eqs, isad, &
                     stat, stores=stores)
    if (stat /= TUBES_OK) return
    call make_field(trim(st%system), st%params, field, c, stat)
    if (stat /= TUBES_OK) return
    n = field%dim()
    stat = TUBES_EINPUT
    if (size(wr) < n .or. size(wi) < n) return
    allocate (jac(n, n))
    call field%jacobian(0.0_wp, eqs(isad)%x, jac, stat)
    if (stat /= TUBES_OK) return
    call eigen(jac, wr(1:n), wi(1:n), stat)
    if (stat /= TUBES_OK) return
    do i = 2, n                      ! ascending real part, then imaginary part (insertion sort)
      j = i
      do while (j > 1)
        if (wr(j - 1) < wr(j) .or. (wr(j - 1) == wr(j) .and. wi(j - 1) <= wi(j))) exit
        wr(j - 1:j) = wr(j:j - 1:-1)
        wi(j - 1:j) = wi(j:j - 1:-1)
        j = j - 1
      end do
    end do
  end subroutine damped_spectrum

  !> The transition region at excess energy de (tubes_region): the section points whose
  !> trajectory under the model with its dissipation (make_field) passes the saddle's gate at
  !> distance gate before it returns to the section. Where no point transits (reg%empty), the
  !> threshold is searched: a region at a higher energy, then bisection in energy down to where
  !> it vanishes (info%de_lo, de_hi; kept in the stores for later calls). opts: the region's
  !> options (its integ is the study's).
  subroutine region_at(st, sec, de, gate, opts, reg, info, stat, stores, noiseless)
    use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
    type(study_t), intent(in) :: st
    type(section_choice_t), intent(in) :: sec
    real(wp), intent(in) :: de, gate
    type(region_opts_t), intent(in) :: opts
    type(region_t), intent(out) :: reg
    type(region_info_t), intent(out) :: info
    integer, intent(out) :: stat
    type(seed_stores_t), intent(inout), optional :: stores   !! the run's kept results
    !> the noise-free model's region (the Monte Carlo's D -> 0 limit); without it a noisy model
    !> is TUBES_ENOISE (its region is not defined)
    logical, intent(in), optional :: noiseless
    !> the threshold's bisection in energy ends at this relative width
    real(wp), parameter :: DE_REL = 1.0e-6_wp
    !> the area's accuracy with rolling resistance (its boundary's resolution)
    real(wp), parameter :: ROLL_AREA_TOL = 1.0e-4_wp
    type(region_opts_t) :: o, coarse
    type(region_t) :: r1, rhi
    type(region_info_t) :: i1
    real(wp) :: lo, hi, mid, p2, nan, a_e
    integer :: k, s1, ik
    integer(i8) :: key(NKEY)
    nan = ieee_value(1.0_wp, ieee_quiet_nan)
    info%de_lo = nan
    info%de_hi = nan
    info%area_hi = nan
    o = opts
    o%integ = st%integ
    ! rolling resistance: a ball that stalls before the gate does not transit (gate_floor); where
    ! it stalls depends on the drag's regularisation and the stall time, and the boundary is known
    ! to ~1e-4 of its radius: the area to ROLL_AREA_TOL (docs/dissipation.md)
    if (param_of(trim(st%system), st%params, 'rolling_resistance') > 0) o%area_tol = max(o%area_tol, ROLL_AREA_TOL)
    if (noisy_params(trim(st%system), st%params)) then
      stat = TUBES_ENOISE
      if (.not. present(noiseless)) return
      if (.not. noiseless) return
    end if
    call region_core(de, o, reg, info, stat)
    if (stat /= TUBES_OK .or. .not. reg%empty) return
    ! empty as far as the scan sees: where does the region appear?
    key = threshold_key()
    ik = 0
    if (present(stores)) then
      if (.not. allocated(stores%thresholds)) allocate (stores%thresholds(0))
      ik = kept_at(stores%thresholds, st, key)
      if (ik > 0) then
        if (de <= stores%thresholds(ik)%de_lo) then
          info%de_lo = stores%thresholds(ik)%de_lo
          info%de_hi = stores%thresholds(ik)%de_hi
          info%area_hi = stores%thresholds(ik)%area_hi
          return
        end if
      end if
    end if
    a_e = info%area_e
    coarse = o
    coarse%n_init = 16
    coarse%one_round = .true.
    coarse%xtol = 1.0e-6_wp
    ! upward: double dE until the scan finds a transit
    hi = de
    rhi%empty = .true.
    do k = 1, 20
      hi = 2*hi
      call region_core(hi, coarse, r1, i1, s1)
      if (.not. r1%empty) then
        rhi = r1
        exit
      end if
      if (s1 /= TUBES_OK) exit            ! no energy surface on the section there, or a failure
    end do
    if (rhi%empty) then                  ! no transit found up to hi
      info%de_lo = hi/2
      if (s1 /= TUBES_OK) info%de_lo = hi/2
      call keep(info%de_lo, nan, nan)
      return
    end if
    ! a bracket that does not depend on de (the same threshold from any empty energy, on any MPI
    ! rank): the smallest power of two (in the energy's units) with a region, found by halving
    coarse%n_scan = 0
    p2 = 2.0_wp**ceiling(log(hi)/log(2.0_wp))
    coarse%hints = hints_of(rhi)
    call region_core(p2, coarse, r1, i1, s1)
    if (.not. r1%empty) then             ! (above a non-empty energy: empty only if the hints miss it;
      hi = p2                            ! then the bracket starts at the scan's hi)
      rhi = r1
    end if
    do k = 1, 64                         ! halving ends: below the saddle's resolution the region is empty
      coarse%hints = hints_of(rhi)
      call region_core(hi/2, coarse, r1, i1, s1)
      if (r1%empty) exit
      if (s1 /= TUBES_OK) call point_only(r1)
      hi = hi/2
      rhi = r1
    end do
    ! down: bisection between the empty hi/2 and the non-empty hi, the region's inside as hints
    lo = hi/2
    do while (hi - lo > DE_REL*hi)
      mid = 0.5_wp*(lo + hi)
      coarse%hints = hints_of(rhi)
      call region_core(mid, coarse, r1, i1, s1)
      if (s1 /= TUBES_OK .and. .not. r1%empty) call point_only(r1)
      if (r1%empty) then
        lo = mid
      else
        hi = mid
        rhi = r1
      end if
    end do
    if (de > lo) then                    ! the region at de is there, smaller than the scan
      o%hints = hints_of(rhi)
      call region_core(de, o, reg, info, stat)
      if (.not. reg%empty) return
      stat = TUBES_ESHAPE                ! a region at de the hints do not find: cannot happen
      return
    end if
    info%area_e = a_e
    info%de_lo = lo
    info%de_hi = hi
    info%area_hi = rhi%area
    call keep(lo, hi, rhi%area, hints_of(rhi))
  contains
    subroutine point_only(r)        ! a point transits but the coarse trace failed (a region too small or
      type(region_t), intent(inout) :: r   ! ragged for 16 rays, the rolling drag's stalls): not empty;
      r%n = 0                              ! the next step starts from the point alone; its
      r%area = 0                           ! area is not known (0: a point, docs/output.md)
      if (allocated(r%rho)) deallocate (r%rho)
      if (allocated(r%phi)) deallocate (r%phi)
      allocate (r%rho(0), r%phi(0))
    end subroutine point_only
    subroutine region_core(d, oo, rr, ii, ss)    ! the region at excess energy d
      real(wp), intent(in) :: d
      type(region_opts_t), intent(in) :: oo
      type(region_t), intent(out) :: rr
      type(region_info_t), intent(inout) :: ii
      integer, intent(out) :: ss
      class(hamiltonian_t), allocatable :: model
      class(vector_field_t), allocatable :: field
      type(equilibrium_t), allocatable :: eqs(:)
      type(poincare_t) :: psec
      real(wp), allocatable :: q_ref(:)
      type(gate_spec_t) :: gspec
      type(region_opts_t) :: o2
      real(wp) :: err, lam
      integer :: isad
      call setup_section(trim(st%system), st%params, st%lo, st%hi, st%n_grid, trim(st%saddle), sec%kind, &
                         sec%index, sec%level, sec%dir, d, model, eqs, isad, psec, q_ref, ss, stores)
      if (ss /= TUBES_OK) return
      call check_resolved(eqs(isad), [d], ss)
      if (ss /= TUBES_OK) return
      call psec%area(ii%area_e, err, ss)
      if (ss /= TUBES_OK) return
      call make_field(trim(st%system), st%params, field, ii%damping_rate, ss, noiseless=.true.)
      if (ss /= TUBES_OK) return
      if (.not. gate_holds_nhim(nhim_reach(eqs(isad), d, neck_normal(model, eqs(isad))), gate)) then
        ss = TUBES_ENARROW
        return
      end if
      call saddle_gate(model, eqs(isad), q_ref, gate, eqs(isad)%energy + d, gspec, ss)
      if (ss /= TUBES_OK) return
      call gate_floor_of(field, eqs(isad), gspec)
      ! a boundary point xtol from the manifold lingers ln(1/xtol)/lambda_d at the saddle (lambda_d
      ! = sqrt(lambda^2 + c^2/4) - c/2, the damped saddle's unstable rate): each integration lasts
      ! at least twice that (the ball's 6.6 s is within the default 20 s; Henon-Heiles' 60)
      o2 = oo
      lam = sqrt(eqs(isad)%lambda**2 + ii%damping_rate**2/4) - ii%damping_rate/2
      if (lam > 0) o2%t_max = max(oo%t_max, 2*log(1/oo%xtol)/lam)
      call transition_region(model, field, psec, gspec, o2, rr, ss)
    end subroutine region_core
    function threshold_key() result(kk)
      integer(i8) :: kk(NKEY)
      real(wp) :: v(size(st%params) + size(st%lo) + size(st%hi) + 13)
      v = [st%params, st%lo, st%hi, real([st%n_grid, sec%kind, sec%index, sec%dir, st%integ%method, &
           o%n_scan], wp), sec%level, gate, o%t_max, o%tol, st%integ%h, st%integ%opts%omega_bind, &
           real(st%integ%opts%solver, wp)]
      kk = 0
      kk(1:size(v)) = transfer(v, kk, size(v))
    end function threshold_key
    subroutine keep(dlo, dhi, ahi, h)
      real(wp), intent(in) :: dlo, dhi, ahi
      real(wp), intent(in), optional :: h(:, :)
      type(kept_threshold_t) :: entry
      if (.not. present(stores)) return
      entry%system = st%system
      entry%saddle = st%saddle
      entry%key = key
      entry%de_lo = dlo
      entry%de_hi = dhi
      entry%area_hi = ahi
      if (present(h)) entry%hints = h
      stores%thresholds = [stores%thresholds, entry]
    end subroutine keep
  end subroutine region_at

  !> Points inside a traced region to start the next one from: its centre, and each ray's
  !> point at 1/3 and 2/3 of the boundary.
  pure function hints_of(r) result(h)
    type(region_t), intent(in) :: r
    real(wp), allocatable :: h(:, :)
    integer :: k
    allocate (h(2, 1 + 2*r%n))
    h(:, 1) = r%centre
    do k = 1, r%n
      h(:, 2*k) = r%centre + r%rho(k)/3*[r%scale(1)*cos(r%phi(k)), r%scale(2)*sin(r%phi(k))]
      h(:, 2*k + 1) = r%centre + 2*r%rho(k)/3*[r%scale(1)*cos(r%phi(k)), r%scale(2)*sin(r%phi(k))]
    end do
  end function hints_of

  !> A transition region's boundary as the C API and f2py return it: the first n = min(reg%n,
  !> size(phi)) rays (angle, radius, point, flight time of the last transit), and the boundary
  !> interpolated at m = size(cs) equally spaced angles (a polygon for the Monte Carlo check's
  !> inside test and the plots; m = 0 when empty).
  subroutine region_outputs(reg, n, phi, rho, s, p, t_in, m, cs, cp)
    type(region_t), intent(in) :: reg
    integer, intent(out) :: n, m
    real(wp), intent(inout) :: phi(:), rho(:), s(:), p(:), t_in(:), cs(:), cp(:)
    real(wp), allocatable :: a(:), b(:)
    n = 0
    m = 0
    if (reg%empty .or. reg%n == 0) return
    n = min(reg%n, size(phi))
    phi(1:n) = reg%phi(1:n)
    rho(1:n) = reg%rho(1:n)
    s(1:n) = reg%s(1:n)
    p(1:n) = reg%p(1:n)
    t_in(1:n) = reg%t_in(1:n)
    m = size(cs)
    if (m < 3) then
      m = 0
      return
    end if
    call region_curve(reg, m, a, b)
    cs = a
    cp = b
  end subroutine region_outputs

  !> A transition region's numbers as the C API and f2py return them (include/tubes.h,
  !> tubes_transition_region): res = area, area_polygon, centre (s, p_s), scale (s, p_s), damping
  !> rate, A_E, de_lo, de_hi, area_hi, area_change; counts = scan points, scan transits, scan
  !> undecided, inconsistent, points integrated, rounds, empty (1/0), the failed ray's status.
  pure subroutine region_numbers(reg, info, res, counts)
    type(region_t), intent(in) :: reg
    type(region_info_t), intent(in) :: info
    real(wp), intent(out) :: res(12)
    integer, intent(out) :: counts(8)
    res = [reg%area, reg%area_polygon, reg%centre, reg%scale, info%damping_rate, info%area_e, info%de_lo, &
           info%de_hi, info%area_hi, reg%area_change]
    counts = [reg%n_scan, reg%n_scan_transit, reg%n_scan_undecided, reg%n_inconsistent, reg%n_classified, &
              reg%rounds, merge(1, 0, reg%empty), reg%fail_stat]
  end subroutine region_numbers

  !> A tube cut's arrays and numbers as the C API and f2py return them: the first n = min(cut%n,
  !> size(tau)) points.
  subroutine cut_outputs(cut, orb, n, tau, r, pr, time, xs, area, area_polygon, action, period, n_failed, &
                         nhist, hist_n, hist_area)
    type(tube_cut_t), intent(in) :: cut
    type(orbit_t), intent(in) :: orb
    integer, intent(out) :: n, n_failed
    real(wp), intent(inout) :: tau(:), r(:), pr(:), time(:), xs(:, :)
    real(wp), intent(out) :: area, area_polygon, action, period
    integer, intent(out) :: nhist             !! refinement rounds in hist_n, hist_area (at most their size)
    integer, intent(inout) :: hist_n(:)       !! the cut's points after each round
    real(wp), intent(inout) :: hist_area(:)   !! its area after each round
    nhist = 0
    if (allocated(cut%hist_n)) then
      nhist = min(size(cut%hist_n), size(hist_n))
      hist_n(1:nhist) = cut%hist_n(1:nhist)
      hist_area(1:nhist) = cut%hist_area(1:nhist)
    end if
    action = orb%action
    period = orb%period
    if (.not. orb%converged) then      ! no orbit (the call failed before it): no action, no period
      action = ieee_value(1.0_wp, ieee_quiet_nan)
      period = action
    end if
    n_failed = cut%n_failed
    n = min(cut%n, size(tau))
    if (n > 0) then
      tau(1:n) = cut%tau(1:n)
      r(1:n) = cut%r(1:n)
      pr(1:n) = cut%pr(1:n)
      time(1:n) = cut%time(1:n)
      xs(:, 1:n) = cut%x(:, 1:n)
    end if
    area = cut%area
    area_polygon = cut%area_polygon
  end subroutine cut_outputs
end module tubes_study
