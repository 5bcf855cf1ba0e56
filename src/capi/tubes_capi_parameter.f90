!> The C API of the orbits asked for by Jacobi constant or period (include/tubes.h:
!> tubes_orbit_by_parameter, tubes_jacobi_constant; src/workflow/tubes_orbit_parameter.f90).
module tubes_capi_parameter
  use, intrinsic :: iso_c_binding, only: c_int, c_double, c_char, c_ptr
  use tubes_kinds, only: wp
  use tubes_cstrings, only: c_to_f
  use tubes_status, only: TUBES_OK, TUBES_EINPUT
  use tubes_hamiltonian, only: hamiltonian_t, jacobi_of_energy
  use tubes_models, only: MAX_PARAMS, MAX_DOF, LEN_SYSTEM, make_model
  use tubes_orbits, only: orbit_opts_t
  use tubes_study, only: study_t, section_choice_t, seed_stores_t
  use tubes_orbit_parameter, only: family_parameter_des
  use tubes_capi, only: study_of, stores_of, guess_opts, integ_of
  implicit none
  private
  public :: c_orbit_parameter, c_jacobi_constant

contains

  !> The excess energies of the family's orbits (the arguments of tubes_orbit_family up to
  !> int_max_iter, then local, stores and the guess) at n values of kind 1 (Jacobi constant) or 2
  !> (period): des[k], found[k] (0 found, 1 not reached, 2 not converged, 3 no Jacobi constant),
  !> t_po, t_reach, de_reach, e_saddle (tubes_orbit_parameter family_parameter_des).
  integer(c_int) function c_orbit_parameter(system, params, lo, hi, n_grid, saddle, pkind, n, values, n_segments, &
      family, tol, rtol, atol, max_iter, nsamp, method, h, omega_bind, solver, int_max_iter, local, stores, nguess, &
      guess, guess_period, des, found, t_po, t_reach, de_reach, e_saddle) result(stat) &
      bind(C, name='tubes_orbit_by_parameter')
    character(kind=c_char), intent(in) :: system(LEN_SYSTEM), saddle(8)
    real(c_double), intent(in) :: params(MAX_PARAMS), lo(MAX_DOF), hi(MAX_DOF)
    integer(c_int), value :: n_grid, pkind, n, n_segments, family, max_iter, nsamp, method, solver, int_max_iter, &
                             local, nguess
    real(c_double), value :: tol, rtol, atol, h, omega_bind, guess_period
    real(c_double), intent(in) :: values(n), guess(*)
    type(c_ptr), value :: stores
    real(c_double), intent(out) :: des(n), t_po, t_reach, de_reach, e_saddle
    integer(c_int), intent(out) :: found(n)
    type(orbit_opts_t) :: opts
    type(study_t) :: st
    type(section_choice_t) :: sec
    type(seed_stores_t), pointer :: kept
    integer :: fnd(n)
    opts = orbit_opts_t(n_segments=n_segments, tol=tol, rtol=rtol, atol=atol, max_iter=max_iter, &
                        n_samples=nsamp, family=family, local=local /= 0, &
                        integ=integ_of(method, h, omega_bind, solver, int_max_iter))
    call guess_opts(nguess, guess, guess_period, opts)
    call study_of(system, params, lo, hi, n_grid, saddle, 0, 0, 0.0_c_double, 0, opts%integ, st, sec)
    kept => stores_of(stores)
    call family_parameter_des(st, opts, int(pkind), values, des, fnd, t_po, t_reach, de_reach, e_saddle, stat, kept)
    found = fnd
  end function c_orbit_parameter

  !> The Jacobi constants c[k] of the model at the energies energy[k] (the model's definition,
  !> tubes_hamiltonian jacobi_of_energy): TUBES_EINPUT (c = 0) for a model without one.
  integer(c_int) function c_jacobi_constant(system, params, n, energy, c) result(stat) &
      bind(C, name='tubes_jacobi_constant')
    character(kind=c_char), intent(in) :: system(LEN_SYSTEM)
    real(c_double), intent(in) :: params(MAX_PARAMS)
    integer(c_int), value :: n
    real(c_double), intent(in) :: energy(n)
    real(c_double), intent(out) :: c(n)
    class(hamiltonian_t), allocatable :: model
    integer :: k
    c = 0
    call make_model(trim(c_to_f(system)), params, model, stat)
    if (stat /= TUBES_OK) return
    if (model%jacobi_factor() == 0) then
      stat = TUBES_EINPUT
      return
    end if
    do k = 1, n
      c(k) = jacobi_of_energy(model, real(energy(k), wp))
    end do
  end function c_jacobi_constant
end module tubes_capi_parameter
