!> Status codes shared by Fortran, C (include/tubes.h: its enum, checked against these by
!> tests/test_capi.c) and Python (tubes.OK, tubes.EINPUT, ...: read from here through the f2py
!> facade's status_code).
!> Codes >= 0 are successes, codes < 0 are failures.
module tubes_status
  implicit none
  private
  integer, parameter, public :: TUBES_OK = 0         !! success
  integer, parameter, public :: TUBES_EVENT = 1      !! success: stopped at a terminal event
  integer, parameter, public :: TUBES_FULL = 2       !! success, before t_end: max_crossings crossings recorded
  integer, parameter, public :: TUBES_EINPUT = -1    !! invalid argument
  integer, parameter, public :: TUBES_EMAXSTEPS = -2 !! step budget exhausted
  integer, parameter, public :: TUBES_ESTEP = -3     !! step size underflow
  integer, parameter, public :: TUBES_EMODEL = -4    !! model returned NaN/Inf or refused the state
  integer, parameter, public :: TUBES_EIO = -5       !! file could not be read or written
  integer, parameter, public :: TUBES_ENOCONV = -6   !! an iteration (Newton, root finder) did not converge
  integer, parameter, public :: TUBES_EFAULT = -7    !! a failure injected by TUBES_FAULT (tests only)
  integer, parameter, public :: TUBES_EOUTSIDE = -8  !! a tube crossed the section outside its region
  integer, parameter, public :: TUBES_ENOCROSS = -9  !! no crossing of the section within t_max
  integer, parameter, public :: TUBES_EPASTEND = -10 !! past the end of the Lyapunov orbit family
  integer, parameter, public :: TUBES_ENARROW = -11  !! the slab (&flux gate) is narrower than the NHIM
  integer, parameter, public :: TUBES_ENOJET = -12   !! no Taylor kernel for the model (stderr says why)
  integer, parameter, public :: TUBES_EDIRECTION = -13   !! the tube crosses the section the other way first
  integer, parameter, public :: TUBES_EUNRESOLVED = -14  !! dE below what the energy resolves at the saddle
  integer, parameter, public :: TUBES_ENOREGION = -15    !! no bounded region of the energy surface on a plane
  integer, parameter, public :: TUBES_ESHAPE = -16       !! the transition region is not one star-shaped piece
  integer, parameter, public :: TUBES_EUNDECIDED = -17   !! a point neither transited nor returned within t_max
  integer, parameter, public :: TUBES_EDISSIPATIVE = -18 !! a conservative-only scene asked of a dissipative model
  integer, parameter, public :: TUBES_ENOISE = -19       !! a deterministic computation asked of a noisy model
  integer, parameter, public :: TUBES_EINTERRUPT = -20   !! stopped by the caller (Ctrl-C: tubes_cancel_shim.c)
  !> The codes' names (TUBES_<name>), for the languages that look them up by name (Python).
  character(len=*), parameter :: STATUS_NAMES(23) = [character(len=12) :: 'OK', 'EVENT', 'FULL', 'EINPUT', &
      'EMAXSTEPS', 'ESTEP', 'EMODEL', 'EIO', 'ENOCONV', 'EFAULT', 'EOUTSIDE', 'ENOCROSS', 'EPASTEND', &
      'ENARROW', 'ENOJET', 'EDIRECTION', 'EUNRESOLVED', 'ENOREGION', 'ESHAPE', 'EUNDECIDED', &
      'EDISSIPATIVE', 'ENOISE', 'EINTERRUPT']
  integer, parameter :: STATUS_CODES(23) = [TUBES_OK, TUBES_EVENT, TUBES_FULL, TUBES_EINPUT, TUBES_EMAXSTEPS, &
      TUBES_ESTEP, TUBES_EMODEL, TUBES_EIO, TUBES_ENOCONV, TUBES_EFAULT, TUBES_EOUTSIDE, TUBES_ENOCROSS, &
      TUBES_EPASTEND, TUBES_ENARROW, TUBES_ENOJET, TUBES_EDIRECTION, TUBES_EUNRESOLVED, TUBES_ENOREGION, &
      TUBES_ESHAPE, TUBES_EUNDECIDED, TUBES_EDISSIPATIVE, TUBES_ENOISE, TUBES_EINTERRUPT]
  integer, parameter, public :: STATUS_UNKNOWN = 1000   !! status_code's answer for no such name
  public :: status_message, callback_status, status_code
contains
  !> A model's status in the convention of GSL's and SUNDIALS' callbacks (0 success, 1 a
  !> recoverable failure, -1 a fatal one); a nonzero status is also kept in last, for the report.
  integer function callback_status(last, stat)
    integer, intent(inout) :: last   !! the last nonzero status the model returned
    integer, intent(in) :: stat      !! the model's status
    if (stat /= 0) last = stat
    callback_status = merge(0, merge(1, -1, stat > 0), stat == 0)
  end function callback_status

  !> The code TUBES_<name> of a status name ('OK', 'EINPUT', ...), STATUS_UNKNOWN for none.
  pure integer function status_code(name)
    character(*), intent(in) :: name
    integer :: k
    status_code = STATUS_UNKNOWN
    do k = 1, size(STATUS_NAMES)
      if (trim(STATUS_NAMES(k)) == name) status_code = STATUS_CODES(k)
    end do
  end function status_code

  !> Text for a status code.
  pure function status_message(code) result(msg)
    integer, intent(in) :: code       !! a TUBES_* code
    character(:), allocatable :: msg  !! its meaning
    select case (code)
    case (TUBES_OK);        msg = 'ok'
    case (TUBES_EVENT);     msg = 'stopped at a terminal event'
    case (TUBES_FULL);      msg = 'stopped before t_end: max_crossings crossings were recorded (raise max_crossings)'
    case (TUBES_EINPUT);    msg = 'invalid input'
    case (TUBES_EMAXSTEPS); msg = 'maximum number of steps reached'
    case (TUBES_ESTEP);     msg = 'step size underflow'
    case (TUBES_EMODEL);    msg = 'the model refused the state (NaN, Inf or a blown-up state)'
    case (TUBES_EIO);       msg = 'input/output error'
    case (TUBES_ENOCONV);   msg = 'iteration did not converge'
    case (TUBES_EFAULT);    msg = 'failure injected by TUBES_FAULT (testing)'
    case (TUBES_EOUTSIDE);  msg = 'the tube crosses the section outside the region of the energy surface chosen on it'
    case (TUBES_ENOCROSS);  msg = 'no crossing of the section within t_max: the tube does not reach this section'
    case (TUBES_EPASTEND);  msg = 'past the end of the Lyapunov orbit family: no orbit at this energy'
    case (TUBES_ENARROW);   msg = 'the gate lies within twice the NHIM''s reach along the reaction coordinate ' // &
                                  '(orbits near it would count as passages): raise gate (&flux, &montecarlo)'
    case (TUBES_ENOJET);    msg = 'the Taylor method has no kernel for this model: its code could not be ' // &
                                  'generated or compiled (the cause is on stderr)'
    case (TUBES_EDIRECTION); msg = 'the tube crosses the section in the other direction first: choose ' // &
                                  'the other direction (or p_theta_sign)'
    case (TUBES_EUNRESOLVED); msg = 'dE is below what the energy resolves at the saddle: E_e + dE is known ' // &
                                  'to worse than 1e-6 of dE (a larger dE, or a smaller additive constant in H)'
    case (TUBES_ENOREGION); msg = 'the energy surface meets the plane section (or the flux''s dividing surface) ' // &
                                  'in no bounded region within its search window (set by the &equilibria box): ' // &
                                  'another energy or section, or a larger box'
    case (TUBES_ESHAPE);    msg = 'the transition region is not one piece star-shaped about its centre, or it ' // &
                                  'reaches the edge of the energy surface (a ray crosses its boundary more than ' // &
                                  'once, or the scan of the section disagrees with the traced boundary)'
    case (TUBES_EUNDECIDED); msg = 'a section point neither passed the gate nor returned to the section within ' // &
                                  't_max: raise t_max (&montecarlo)'
    case (TUBES_EDISSIPATIVE); msg = 'the model is dissipative (damping_ratio or rolling_resistance > 0) ' // &
                                  'and this computation is ' // &
                                  'conservative only (the flux through the NHIM needs a Hamiltonian flow): ' // &
                                  'damping_ratio = 0, or the transition and montecarlo scenes (docs/dissipation.md)'
    case (TUBES_ENOISE);    msg = 'the model carries noise (noise or temperature > 0) and this computation is ' // &
                                  'deterministic (a transition region, a Poincare map): with noise the ' // &
                                  'montecarlo scene gives p_trans (docs/dissipation.md)'
    case (TUBES_EINTERRUPT); msg = 'interrupted: the caller asked the computation to stop (Ctrl-C)'
    case default;           msg = 'unknown status code'
    end select
  end function status_message
end module tubes_status
