!> The /section group of the scenes that draw on a Poincare section (transition; tubes and
!> montecarlo to follow, docs/output.md /section): the energy surface on the section at the
!> saddle's energy E_e (its interval, its area A0 and tau = dA_E/dE), the saddle's Lyapunov period
!> at dE -> 0 and the growth rate T_po/A0, its console line and its verdicts, into a scene's
!> result record (tubes_record). With 3 degrees of freedom the plane serves the tubes' crossings
!> alone: no region, no A0.
module tubes_scene_section
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan, ieee_is_finite
  use tubes_kinds, only: wp, PI
  use tubes_status, only: TUBES_OK, TUBES_EINPUT, TUBES_ENOREGION, status_message
  use tubes_cstrings, only: num
  use tubes_scene_text, only: itoa
  use tubes_record, only: record_t, EXIT_NUMERIC
  use tubes_hamiltonian, only: hamiltonian_t
  use tubes_equilibria, only: equilibrium_t
  use tubes_models, only: MAX_DOF
  use tubes_study, only: study_t, section_choice_t, seed_stores_t, model_equilibria, equilibria_table, section_info
  use tubes_config, only: tubes_config_t
  use tubes_settings, only: settings_study, settings_section
  implicit none
  private

  integer, parameter, public :: SEC_KIND_RAY = 1, SEC_KIND_PLANE = 2   !! section_choice_t%kind
  integer, parameter :: NEQ_MAX = 256      ! the equilibria a saddle is looked up among (as the C API's)

  public :: scene_section, scene_section_alone, saddle_props

contains

  !> /section of the study's saddle and section (sec: the ray's level in rad, angle_deg the
  !> same in degrees as the input gave it); written: the output already holds /section (an
  !> earlier scene wrote it: nothing is recorded again). a0, tau, tpo: A0, tau and T_po for the
  !> scene (a0 and tau NaN with 3 degrees of freedom); ok: .false. after a verdict (the scene stops).
  !> /section alone on the run's settings cfg, the saddle and the method the run chose, for a scene
  !> that draws on the section without its own use of it (sections); written: /section is in the
  !> output already (nothing recorded).
  subroutine scene_section_alone(cfg, saddle, method, written, stores, rec)
    type(tubes_config_t), intent(in) :: cfg
    character(*), intent(in) :: saddle
    integer, intent(in) :: method
    logical, intent(in) :: written
    type(seed_stores_t), pointer, intent(in) :: stores
    type(record_t), intent(inout) :: rec
    real(wp) :: a0, tau, tpo
    logical :: ok
    call scene_section(settings_study(cfg, saddle, method), settings_section(cfg), cfg%sec_angle, written, stores, rec, &
                       a0, tau, tpo, ok)
  end subroutine scene_section_alone

  subroutine scene_section(st, sec, angle_deg, written, stores, rec, a0, tau, tpo, ok, ndof)
    type(study_t), intent(in) :: st
    type(section_choice_t), intent(in) :: sec
    real(wp), intent(in) :: angle_deg
    logical, intent(in) :: written
    type(seed_stores_t), pointer, intent(in) :: stores
    type(record_t), intent(inout) :: rec
    real(wp), intent(out) :: a0, tau, tpo
    logical, intent(out) :: ok
    integer, intent(out), optional :: ndof      !! the model's degrees of freedom
    real(wp) :: ee, rmin, rmax
    integer :: stat, nd
    character(:), allocatable :: dir, line
    ok = .false.
    a0 = ieee_value(1.0_wp, ieee_quiet_nan)
    tau = a0
    tpo = a0
    call saddle_props(st, stores, ee, tpo, nd, stat)
    if (present(ndof)) ndof = nd
    dir = merge('>', '<', sec%dir > 0)
    if (nd > 2) then     ! the tubes scene's plane, for its crossings alone: no region, no A0
      if (stat < 0) then
        call rec%verdict(EXIT_NUMERIC, 'tubes: section: the saddle ' // trim(st%saddle) // &
                         ' could not be found (status ' // itoa(stat) // ')')
        return
      end if
      ok = .true.
      if (written) return
      call rec%out('section q' // itoa(sec%index) // ' = ' // num(sec%level, '.10g') // ' (dq' // itoa(sec%index) // &
                   '/dt ' // dir // ' 0), ' // itoa(nd) // " degrees of freedom: the tubes' crossings of the plane (no " // &
                   'region: the transition scenes are 2-DOF)')
      call rec%attr_string('section', 'kind', 'plane')
      call rec%attr_int('section', 'index', sec%index)
      call rec%attr_real('section', 'value', sec%level)
      call rec%attr_int('section', 'direction', sec%dir)
      call rec%attr_real('section', 'E_e', ee)
      call rec%attr_string('section', 'saddle', trim(st%saddle))
      return
    end if
    if (stat == TUBES_OK) call section_info(study_t(system=st%system, params=st%params, lo=st%lo, hi=st%hi, &
                                                    n_grid=st%n_grid, saddle=st%saddle), sec, 0.0_wp, rmin, rmax, a0, &
                                            tau, stat, stores)
    if (stat < 0) then
      a0 = ieee_value(1.0_wp, ieee_quiet_nan)
      tau = a0
      if (sec%kind == SEC_KIND_RAY .or. stat /= TUBES_ENOREGION) then
        line = 'tubes: section: the energy surface on the section could not be computed: ' // status_message(stat) // &
               ' (status ' // itoa(stat) // ')'
      else
        line = 'tubes: section: the plane q' // itoa(sec%index) // ' = ' // num(sec%level) // &
               ' does not meet a bounded region of the energy surface at E_e of ' // trim(st%saddle) // &
               ' (searched q' // itoa(3 - sec%index) // ' over the &equilibria box widened by half its width on ' // &
               'each side; status ' // itoa(stat) // '): choose another value, or a box that holds the region'
      end if
      call rec%verdict(EXIT_NUMERIC, line)
      return
    end if
    if (.not. ieee_is_finite(tau)) then   ! dA_E/dE's quadrature failed (the area stands): no tau to print
      call rec%verdict(EXIT_NUMERIC, 'tubes: section: dA_E/dE at E_e of ' // trim(st%saddle) // ' could not be ' // &
                       'computed (its quadrature did not converge; the energy surface on the section touches a ' // &
                       'maximum of V?)')
      return
    end if
    ok = .true.
    if (written) return
    if (sec%kind == SEC_KIND_RAY) then
      call rec%out('section theta = ' // num(angle_deg) // ' deg (p_theta ' // dir // ' 0): at E_e r in [' // &
                   num(rmin, '.6f') // ', ' // num(rmax, '.6f') // '] cm, A0 = ' // num(a0, '.8g') // &
                   ' cm^2/s, tau = dA_E/dE = ' // num(tau, '.8g') // ' s, T_po/A0 = ' // num(tpo/a0, '.6g') // &
                   ' (s/cm)^2')
      call rec%attr_real('section', 'angle', sec%level)
      call rec%attr_int('section', 'p_theta_sign', sec%dir)
    else
      call rec%out('section q' // itoa(sec%index) // ' = ' // num(sec%level, '.10g') // ' (dq' // itoa(sec%index) // &
                   '/dt ' // dir // ' 0): at E_e q' // itoa(3 - sec%index) // ' in [' // num(rmin, '.8g') // ', ' // &
                   num(rmax, '.8g') // '], A0 = ' // num(a0, '.10g') // ', tau = dA_E/dE = ' // num(tau, '.10g') // &
                   ', T_po/A0 = ' // num(tpo/a0, '.6g'))
      call rec%attr_string('section', 'kind', 'plane')
      call rec%attr_int('section', 'index', sec%index)
      call rec%attr_real('section', 'value', sec%level)
      call rec%attr_int('section', 'direction', sec%dir)
    end if
    call rec%attr_real('section', 'A0', a0)
    call rec%attr_real('section', 'tau', tau)
    call rec%attr_real('section', 'growth_rate', tpo/a0)
    call rec%attr_real('section', 'T_po', tpo)
    call rec%attr_real('section', 'E_e', ee)
    call rec%attr_string('section', 'saddle', trim(st%saddle))
    call rec%attr_real('section', 'r_min', rmin)
    call rec%attr_real('section', 'r_max', rmax)
  end subroutine scene_section

  !> E_e and T_po = 2 pi/omega of the study's saddle (a rank-1 saddle of the model in its box:
  !> else TUBES_EINPUT), and the model's degrees of freedom nd (0 if it could not be made).
  subroutine saddle_props(st, stores, ee, tpo, nd, stat)
    type(study_t), intent(in) :: st
    type(seed_stores_t), pointer, intent(in) :: stores
    real(wp), intent(out) :: ee, tpo
    integer, intent(out) :: nd, stat
    class(hamiltonian_t), allocatable :: model
    type(equilibrium_t), allocatable :: eqs(:)
    real(wp), allocatable :: q(:, :), p(:, :), hgt(:), en(:), gn(:), lam(:), om(:, :), ev(:, :)
    integer, allocatable :: morse(:), rank1(:)
    integer :: k, n
    ee = 0
    tpo = 0
    nd = 0
    call model_equilibria(trim(st%system), st%params, st%lo, st%hi, st%n_grid, stores, model, eqs, stat)
    if (allocated(model)) nd = model%ndof()
    if (stat /= TUBES_OK) return
    n = size(eqs)
    stat = TUBES_EINPUT
    if (n > NEQ_MAX) return
    allocate (q(MAX_DOF, n), p(MAX_DOF, n), hgt(n), en(n), gn(n), lam(n), om(MAX_DOF - 1, n), &
              ev(4*MAX_DOF*MAX_DOF, n), morse(n), rank1(n))
    q = 0; p = 0; om = 0; ev = 0
    call equilibria_table(eqs, nd, q, p, hgt, en, gn, morse, rank1, lam, om, ev)
    do k = 1, n
      if (eqs(k)%name /= st%saddle) cycle
      if (rank1(k) /= 1) return
      ee = en(k)
      tpo = 2*PI/om(1, k)
      stat = TUBES_OK
      return
    end do
  end subroutine saddle_props
end module tubes_scene_section
