!> The settings of a run (tubes_config_t): every namelist variable as the reader
!> (src/io/tubes_nml.f90) leaves it, then what it resolved. The one definition of their layout:
!> C's struct is generated from this file (src/io/tubes_config_gen.awk), and the scenes
!> (src/workflow/tubes_scene_*.f90) read their settings from it, called alike by the C driver and
!> by Python (docs/development.md, "Scenes and their records").
module tubes_config
  use, intrinsic :: iso_c_binding, only: c_int, c_double, c_char, c_int64_t
  use tubes_models, only: MAX_PARAMS, MAX_DOF
  implicit none
  private
  public :: NGROUPS, NSCENES, LSCENE, LPATH, LNAME, MAXDE, LSADDLE, MAXGUESS, LEXPR, LSYM, LCONST, MAXCONST, &
            LMSG, UNSET, UNSET_INT

  !> run, model, equilibria, trajectory, integrator, orbits, section, tubes, transition,
  !> montecarlo, sections, experiment, flux, scan
  integer, parameter :: NGROUPS = 14
  integer, parameter :: NSCENES = 16, LSCENE = 32, LPATH = 1024, LNAME = 32, MAXDE = 256, LSADDLE = 8, MAXGUESS = 64
  !> models written as formulas: a formula, a name, a constant 'name = value', how many
  integer, parameter :: LEXPR = 2048, LSYM = 16, LCONST = 128, MAXCONST = 32, LMSG = 1024
  !> An unset entry of a list (dE): any value a user cannot mean.
  real(c_double), parameter :: UNSET = -huge(1.0_c_double)
  !> An unset integer (&section index, direction, p_theta_sign): 0 is a value a user can mean.
  integer, parameter :: UNSET_INT = -huge(1)

  !> The settings of a run: every namelist variable, then what the reader resolved. A field with an
  !> annotation (a line '!@ &group name | units | default | allowed | text' right before it) is a
  !> registered variable: the reader's table row, its range check, its namelist variable and its copies
  !> are generated from the annotation (src/io/tubes_registry_gen.awk; docs/development.md). The one
  !> definition of their layout: C's struct (include/tubes_config.h) is generated from this type
  !> and the length parameters above (src/io/tubes_config_gen.awk, at build time): a field added
  !> here is C's too. Unset reals are -huge (C: -DBL_MAX).
  type, bind(C), public :: tubes_config_t
    character(kind=c_char) :: scenes(LSCENE, NSCENES)   ! &run
    character(kind=c_char) :: output(LPATH)
    real(c_double) :: alpha, beta, gamma, xi, h0, g, damping_ratio, rolling_resistance, noise_d, temperature   ! &model
    real(c_double) :: box   ! &equilibria
    !@ &equilibria n_grid | - | 41 | 2 .. 2001, n_grid^N <= 1e6 | Newton starts per axis
    integer(c_int) :: n_grid
    character(kind=c_char) :: saddle(LSADDLE)
    !@ &trajectory x0 | cm | rolling_ball: 4; other models: required | finite | initial x
    real(c_double) :: x0
    !@ &trajectory y0 | cm | rolling_ball: 12.614863819914357; other models: required | finite | initial y
    real(c_double) :: y0
    !@ &trajectory px0 | cm/s | 0 | finite | initial p_x (ignored if at_rest)
    real(c_double) :: px0
    !@ &trajectory py0 | cm/s | 0 | finite | initial p_y (ignored if at_rest)
    real(c_double) :: py0
    !@ &trajectory at_rest | - | .true. | .true., .false. | start from rest at (x0, y0)
    integer(c_int) :: at_rest
    !@ &trajectory t_end | s | 10 | >= 0 | final time
    real(c_double) :: t_end
    !@ &trajectory dt_out | s | 0.01 | > 0 | sample spacing of the output (t_end is always the last sample)
    real(c_double) :: dt_out
    !@ &trajectory section | - | 'none' | none, U1-, U1+, U1, theta, x, y | Poincare section whose crossings are recorded (docs/events.md)
    character(kind=c_char) :: section(LNAME)
    !@ &trajectory section_angle | deg | 45 | -360 .. 360 | section = 'theta': the ray's angle
    real(c_double) :: section_angle
    !@ &trajectory section_level | cm | 0 | finite | section = 'x' or 'y': the line x = c or y = c
    real(c_double) :: section_level
    !@ &trajectory section_direction | - | 0 | -1, 0, 1 | theta: sign of p_theta; x, y: sign of dx/dt or dy/dt; 0 both
    integer(c_int) :: section_direction
    !@ &trajectory max_crossings | - | 10000 | 1 .. 10000000 | crossings recorded at most (then the run stops)
    integer(c_int) :: max_crossings
    !@ &trajectory stop_at_first | - | .false. | .true., .false. | stop at the first crossing
    integer(c_int) :: stop_at_first
    !@ &integrator method | - | 'auto' | dop853, rk4, tao2, tao4, tao6, gauss4, gauss6, gauss8, gsl_rk8pd, gsl_rk4imp, cvode_adams, arkode_erk8, taylor, auto | integration method (docs/integrators.md)
    character(kind=c_char) :: method(LNAME)
    !@ &integrator rtol | 1 | 1e-12 | 1e-15 <= rtol < 1 | relative tolerance (variable-step methods)
    real(c_double) :: rtol
    !@ &integrator atol | state units | 1e-12 | > 0 | absolute tolerance (variable-step methods)
    real(c_double) :: atol
    !@ &integrator h | s | 0 | >= 0 | fixed step; 0 = variable step with rtol/atol
    real(c_double) :: h
    !@ &integrator max_steps | - | 10000000 | >= 1 | step budget
    integer(c_int64_t) :: max_steps
    !@ &integrator omega_bind | 1/s | 200 | > 0 | tao*: binding constant of the extended phase space
    real(c_double) :: omega_bind
    !@ &integrator solver | - | 'newton' | newton, fixed_point | gauss*: stage equation solver
    character(kind=c_char) :: solver(LNAME)
    !@ &integrator max_iter | - | 0 | 0 .. 1000 | gauss*: iterations per step (0: 10 newton, 100 fixed_point)
    integer(c_int) :: max_iter
    character(kind=c_char) :: orb_saddle(LSADDLE)   ! &orbits
    !@ &orbits de | default rolling_ball: 1, 10, 100; other models: required
    real(c_double) :: orb_de(MAXDE)
    integer(c_int) :: orb_nde
    !@ &orbits method | - | 'single' | single, multiple | single shooting of the brake orbit, or multiple shooting
    character(kind=c_char) :: orb_method(LNAME)
    !@ &orbits n_segments | - | 8 | 2 .. 64 | segments of multiple shooting
    integer(c_int) :: orb_n_segments
    !@ &orbits tol | cm, cm/s | 1e-11 | 1e-14 .. 1e-4 | Newton tolerance on the periodicity mismatch (and |H - E|/E)
    real(c_double) :: orb_tol
    !@ &orbits rtol | 1 | 1e-13 | 1e-15 <= rtol < 1e-4 | integration tolerance (relative)
    real(c_double) :: orb_rtol
    !@ &orbits atol | state units | 1e-13 | > 0 | integration tolerance (absolute)
    real(c_double) :: orb_atol
    !@ &orbits max_iter | - | 25 | 1 .. 200 | Newton iterations per orbit
    integer(c_int) :: orb_max_iter
    !@ &orbits n_samples | - | 201 | 2 .. 100000 | samples along each orbit in the output
    integer(c_int) :: orb_n_samples
    real(c_double) :: sec_angle   ! &section
    integer(c_int) :: sec_pth_sign
    !@ &tubes de | (cm/s)^2 | rolling_ball: 10, 100; other models: required | > 0, increasing | excess energies of the tube cuts
    real(c_double) :: tub_de(MAXDE)
    integer(c_int) :: tub_nde
    !@ &tubes kind | - | 'stable' | stable, unstable, both | which manifold
    character(kind=c_char) :: tub_kind(LNAME)
    !@ &tubes eps | cm | 1e-6 | 1e-10 .. 1e-2 | step-off from the orbit
    real(c_double) :: tub_eps
    !@ &tubes area_tol | 1 | 1e-10 | 1e-13 .. 1e-2 | relative area change that ends the refinement
    real(c_double) :: tub_area_tol
    !@ &tubes t_max | s | 30 | > 0 | longest flight from the orbit to the section
    real(c_double) :: tub_t_max
    !@ &tubes n_init | - | 64 | 8 .. 100000 | seeds of the first round
    integer(c_int) :: tub_n_init
    !@ &tubes n_max | - | 8192 | n_init .. 1000000 | seeds at most
    integer(c_int) :: tub_n_max
    !@ &transition de | (cm/s)^2 | rolling_ball: 1, 2, 5, 10, 20, 50, 100, 200, 300, 400, 500, 600, 700, 750; other models: required | > 0, increasing | excess energies of p_trans(dE)
    real(c_double) :: tra_de(MAXDE)
    integer(c_int) :: tra_nde
    !@ &transition area_tol | 1 | 1e-8 | 1e-13 .. 1e-2 | relative accuracy of each tube area
    real(c_double) :: tra_area_tol
    !@ &montecarlo de | (cm/s)^2 | rolling_ball: 100; other models: required | > 0 | excess energy of the samples
    real(c_double) :: mc_de
    !@ &montecarlo n_samples | - | 10000 | 1 .. 10000000 | points on the section
    integer(c_int) :: mc_n_samples
    !@ &montecarlo seed | - | 12345 | >= 0 | seed of GSL's MT19937
    integer(c_int) :: mc_seed
    !@ &montecarlo t_max | s | 20 | > 0 | longest integration of a point
    real(c_double) :: mc_t_max
    !@ &montecarlo gate
    real(c_double) :: mc_gate
    !@ &montecarlo area_tol | 1 | 1e-8 | 1e-13 .. 1e-2 | relative accuracy of the tube cut the points are sorted by
    real(c_double) :: mc_area_tol
    !@ &sections de | (cm/s)^2 | rolling_ball: 100, 500; other models: required | > 0, increasing | excess energies of the maps
    real(c_double) :: pm_de(MAXDE)
    integer(c_int) :: pm_nde
    !@ &sections n_seeds | - | 40 | 1 .. 100000 | trajectories per map
    integer(c_int) :: pm_n_seeds
    !@ &sections n_iter | - | 300 | 1 .. 1000000 | returns recorded per trajectory
    integer(c_int) :: pm_n_iter
    !@ &sections t_max | s | 2000 | > 0 | longest integration per trajectory
    real(c_double) :: pm_t_max
    !@ &experiment n_tracks | - | 120 | 1 .. 100000 | trajectories released
    integer(c_int) :: exp_n_tracks
    !@ &experiment duration | s | 14 | > 0 | length of each track
    real(c_double) :: exp_duration
    !@ &experiment camera_rate | Hz | 50 | > 0, duration*camera_rate <= 1e6 | frames per second
    real(c_double) :: exp_camera_rate
    !@ &experiment pixel | cm | 0.16 | >= 0 | pixel size: measured positions are multiples of it (0 = no rounding)
    real(c_double) :: exp_pixel
    !@ &experiment noise | cm | 0.05 | >= 0 | standard deviation of the Gaussian position noise (before rounding)
    real(c_double) :: exp_noise
    !@ &experiment de_min | (cm/s)^2 | 1000 | finite, < de_max | release excess energy g H - E_e at rest: lower bound
    real(c_double) :: exp_de_min
    !@ &experiment de_max | (cm/s)^2 | 3000 | finite, > de_min | release excess energy: upper bound
    real(c_double) :: exp_de_max
    !@ &experiment damping_ratio | 1 | 0.014 | 0 <= zeta < 1 | damping ratio of the experiment's ball (docs/theory.md#damping)
    real(c_double) :: exp_damping_ratio
    !@ &experiment rolling_resistance | 1 | 0 | 0 <= C_rr < 1 | rolling resistance coefficient of the experiment's ball (docs/dissipation.md)
    real(c_double) :: exp_rolling_resistance
    !@ &experiment seed | - | 2018 | >= 0 | seed of GSL's MT19937
    integer(c_int) :: exp_seed
    character(kind=c_char) :: exp_csv(LPATH)
    ! the any-Hamiltonian additions (docs/input.md): &model system and the other systems' parameters,
    ! &equilibria box (list) and box_center, &orbits saddle_near, &section kind, index, direction, value
    character(kind=c_char) :: system(LNAME)
    real(c_double) :: m_a, m_b, d, lambda, zeta, eps_s, omega, eps, mu
    real(c_double) :: box_list(MAX_DOF), box_center(MAX_DOF), orb_saddle_near(MAX_DOF)
    character(kind=c_char) :: sec_kind(LNAME)
    integer(c_int) :: sec_index, sec_direction
    real(c_double) :: sec_value
    ! resolved by the reader from the library's table (src/models/tubes_models.f90): the system's degrees
    ! of freedom and parameters in the table's order (nparams = -1: unknown system), the search box,
    ! whether the saddle is chosen by position; box_list, box_center, the section's fields, the saddle
    ! and mc_gate then hold the effective values
    integer(c_int) :: ndof, nparams, orb_use_near
    real(c_double) :: params(MAX_PARAMS), box_lo(MAX_DOF), box_hi(MAX_DOF)
    ! models written as formulas (docs/models.md): &model hamiltonian, coordinates, momenta, constants,
    ! surface, height; then model: the name the library knows the model by (the system's, or expr_<hash>
    ! for a formula; nparams = -2 when building it failed: expr_var names the variable at fault, expr_msg
    ! says why), expr_lib its shared library, expr_seconds the time the build or the cache lookup took,
    ! expr_hit 1 for a cache hit
    character(kind=c_char) :: hamiltonian(LEXPR), coordinates(LSYM, MAX_DOF), momenta(LSYM, MAX_DOF), &
      constants(LCONST, MAXCONST), surface(LNAME), height(LEXPR)
    character(kind=c_char) :: dissipation(LNAME)   !! &model dissipation as declared ('' : not; checked by nml_validate)
    character(kind=c_char) :: model(LNAME), expr_var(LNAME), expr_msg(LMSG), expr_lib(LPATH)
    real(c_double) :: expr_seconds
    integer(c_int) :: expr_hit
    !@ &flux de | energy | the &transition list | > 0, increasing | excess energies of the flux
    real(c_double) :: flux_de(MAXDE)   ! (flux_gate resolved like mc_gate)
    integer(c_int) :: flux_nde
    !@ &flux n_samples | - | 4000 | 2 .. 1e7 | points on the dividing surface per energy
    integer(c_int) :: flux_n_samples
    !@ &flux seed | - | 1 | >= 0 | seed of GSL's MT19937
    integer(c_int) :: flux_seed
    !@ &flux t_max | time | 20 | > 0 | integration limit of each point's future and past
    real(c_double) :: flux_t_max
    !@ &flux gate
    real(c_double) :: flux_gate
    !@ &flux tol | 1 | 1e-10 | 1e-14 .. 1e-3 | rtol = atol of the integrations
    real(c_double) :: flux_tol
    !@ &flux order | - | 0 | 0, or 2 .. 16 (2 DOF), 2 .. 10 (3 DOF) | degree of the Birkhoff normal form (formula models); 0 = none
    integer(c_int) :: flux_order
    !@ &flux n_cut | - | 16 | 0, or even 4 .. 64 | 3 DOF with order and a plane &section: the tube's cut on a grid of n_cut + 1 rings of (2 n_cut)^2 NHIM points; 0 = none
    integer(c_int) :: flux_n_cut
    !@ &flux cut_eps | 1 | 1e-3 | 1e-8 .. 0.1 | step-off of the tube's seeds from the NHIM, in units of its radius sqrt(2 dE / omega_2)
    real(c_double) :: flux_cut_eps
    integer(c_int) :: orb_family   !! &orbits family: a centre mode (1 .. N-1), a family by name (< 0), 'branch:K' = -100 - K
    integer(c_int) :: spatial      !! &model spatial: the cr3bp in three dimensions (model cr3bp_spatial)
    ! &scan (docs/scan.md): the parameter, its end value (unset: -huge), the steps, the orbits' dE
    ! (scan_nde 0: none; &orbits de when &scan de is not set and &orbits de is); scan_ipar resolved by
    ! the reader: the parameter's index (1-based) in params, 0 when the scan does not take it
    character(kind=c_char) :: scan_parameter(LNAME)
    real(c_double) :: scan_to
    real(c_double) :: scan_de(MAXDE)
    !@ &scan n | - | 10 | 1 .. 100000 | steps (n + 1 parameter values, equally spaced)
    integer(c_int) :: scan_n
    !@ &scan de
    integer(c_int) :: scan_nde, scan_ipar
    real(c_double) :: orb_guess(2*MAX_DOF)   !! &orbits guess (the first 2 MAX_DOF values)
    integer(c_int) :: orb_nguess             !! how many values guess was given (0: none)
    real(c_double) :: orb_period             !! &orbits period (of the guess)
    !@ &scan p_trans | - | .false. | .true., .false. (2 degrees of freedom, as the transition scene) | p_trans(dE) = A_tube/A_E at each step and each de, as the transition scene computes it (costs a tube cut per step and dE: docs/scan.md)
    integer(c_int) :: scan_p_trans
    real(c_double) :: orb_jacobi(MAXDE)      !! &orbits jacobi (the first orb_njacobi)
    real(c_double) :: orb_periods(MAXDE)     !! &orbits periods (the first orb_nperiods)
    integer(c_int) :: orb_njacobi, orb_nperiods, orb_de_given   !! orb_de_given 1: &orbits de given
  end type tubes_config_t

end module tubes_config
