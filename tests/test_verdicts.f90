!> The scenes' verdicts and set-up rules (src/workflow/tubes_verdicts.f90, tubes_setup.f90) on
!> their own, without ./tubes: each limit checked from both sides against the number the rule
!> states, derived here from its definition (the binomial standard error, the closure over mu,
!> 16 ulps a millionth of E_e, ...), not from the code's own expression.
program test_verdicts
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan, ieee_positive_inf
  use, intrinsic :: ieee_exceptions, only: ieee_get_halting_mode, ieee_set_halting_mode, ieee_invalid
  use tubes_kinds, only: wp
  use tubes_check, only: check_true, check_eq, check_close, finish
  use tubes_verdicts, only: mc_check, orbit_coarse, flux_too_small, flux_undecided, flux_normal_form_check, &
                            section_check, cut3_check, VERDICT_FAILS
  use tubes_setup, only: default_refused, de_unresolved, scene_refused, SCENE_TAKEN, SCENE_NOT_FOR_MODEL, &
                         SCENE_NEEDS_PLANE
  implicit none
  real(wp) :: nan, inf
  logical :: halts   ! the debug build traps invalid operations (-ffpe-trap=invalid): NaN's cases run without

  call ieee_get_halting_mode(ieee_invalid, halts)
  nan = ieee_value(1.0_wp, ieee_quiet_nan)
  inf = ieee_value(1.0_wp, ieee_positive_inf)
  call monte_carlo()
  call orbits()
  call flux()
  call section()
  call cut3()
  call setup_rules()
  call finish('test_verdicts')

contains

  !> Around the cases with a NaN input (the verdicts take NaN for "no number there"): a comparison
  !> with NaN is an invalid operation, which the debug build's -ffpe-trap=invalid would stop on.
  subroutine nan_inputs(on)
    logical, intent(in) :: on
    if (halts) call ieee_set_halting_mode(ieee_invalid, .not. on)
  end subroutine nan_inputs

  !> The Monte Carlo fraction f = k/n against the tube's p: within 5 binomial standard errors
  !> sqrt(p (1 - p) / n) of p, at most 2 + n/1000 misclassified and 2 + n/100 undecided (docs/theory.md).
  subroutine monte_carlo()
    integer, parameter :: n = 10000
    real(wp), parameter :: p = 0.08_wp
    real(wp) :: se, sig
    logical :: ok
    character(1024) :: msg
    integer :: k_in, k_out
    se = sqrt(p*(1 - p)/n)                               ! 0.0027129...
    k_in = floor((p + 4.9_wp*se)*n)                      ! 4.9 standard errors above p
    k_out = ceiling((p + 5.1_wp*se)*n)                   ! 5.1
    call check_eq('mc: 4.9 sigma agrees', mc_check(100.0_wp, n, k_in, 0, 0, p, .false., 'S12', sig, ok, msg), 0)
    call check_close('mc: sigmas is |f - p| / se_p', sig, abs(real(k_in, wp)/n - p)/se, 1e-12_wp)
    call check_eq('mc: 5.1 sigma fails', mc_check(100.0_wp, n, k_out, 0, 0, p, .false., 'S12', sig, ok, msg), &
                  VERDICT_FAILS)
    call check_true('mc: its message names the saddle and the tube', &
                    index(msg, 'disagrees with the tube') > 0 .and. index(msg, 'saddle S12') > 0, trim(msg))
    call check_true('mc: 5.1 sigma below fails too', &
                    mc_check(100.0_wp, n, floor((p - 5.1_wp*se)*n), 0, 0, p, .false., 'S12', sig, ok, msg) &
                    == VERDICT_FAILS)
    call check_eq('mc: 12 misclassified (2 + n/1000) agree', &
                  mc_check(100.0_wp, n, nint(p*n), 0, 12, p, .false., 'S12', sig, ok, msg), 0)
    call check_eq('mc: 13 misclassified fail', &
                  mc_check(100.0_wp, n, nint(p*n), 0, 13, p, .false., 'S12', sig, ok, msg), VERDICT_FAILS)
    call check_eq('mc: 102 undecided (2 + n/100) agree', &
                  mc_check(100.0_wp, n, nint(p*n), 102, 0, p, .false., 'S12', sig, ok, msg), 0)
    call check_eq('mc: 103 undecided fail', &
                  mc_check(100.0_wp, n, nint(p*n), 103, 0, p, .false., 'S12', sig, ok, msg), VERDICT_FAILS)
    ! a noisy model has no deterministic prediction: only the undecided count is held
    call check_eq('mc noisy: any fraction agrees', &
                  mc_check(100.0_wp, n, n/2, 0, 500, p, .true., 'S12', sig, ok, msg), 0)
    call check_eq('mc noisy: 103 undecided fail', &
                  mc_check(100.0_wp, n, n/2, 103, 0, p, .true., 'S12', sig, ok, msg), VERDICT_FAILS)
    call check_true('mc noisy: says t_max', index(msg, 'raise &montecarlo t_max') > 0, trim(msg))
    ! p = 0 (no tube there): any transit is infinitely many standard errors off
    call check_eq('mc: p = 0 with no transit agrees', mc_check(1.0_wp, n, 0, 0, 0, 0.0_wp, .false., 'S12', sig, ok, &
                  msg), 0)
    call check_eq('mc: p = 0 with one transit fails', mc_check(1.0_wp, n, 1, 0, 0, 0.0_wp, .false., 'S12', sig, ok, &
                  msg), VERDICT_FAILS)
  end subroutine monte_carlo

  !> One period's closure over mu_unstable is the integration error: at most 1e-8 of the state's
  !> largest component; an orbit that is not unstable (mu <= 1, NaN) is not judged.
  subroutine orbits()
    character(1024) :: msg
    call check_eq('orbit: closure/mu = 0.99e-8 of the state holds', orbit_coarse(1.0_wp, 0.99e-5_wp, 1e3_wp, 1.0_wp, &
                  msg), 0)
    call check_eq('orbit: 1.01e-8 is too coarse', orbit_coarse(1.0_wp, 1.01e-5_wp, 1e3_wp, 1.0_wp, msg), VERDICT_FAILS)
    call check_true('orbit: says tighten &integrator', index(msg, 'tighten &integrator') > 0, trim(msg))
    call check_eq('orbit: scaled by the state (12 cm)', orbit_coarse(1.0_wp, 1.1e-4_wp, 1e3_wp, 12.0_wp, msg), 0)
    call check_eq('orbit: mu = 1 not judged', orbit_coarse(1.0_wp, 1.0_wp, 1.0_wp, 1.0_wp, msg), 0)
    call nan_inputs(.true.)
    call check_eq('orbit: mu NaN not judged', orbit_coarse(1.0_wp, 1.0_wp, nan, 1.0_wp, msg), 0)
    call nan_inputs(.false.)
  end subroutine orbits

  !> The flux's verdicts: a leading order below the smallest normal double, more than 1 % undecided,
  !> the normal form and the sampled flux more than 5 combined standard errors apart.
  subroutine flux()
    character(1024) :: msg
    real(wp) :: z, fe, ch
    call check_eq('flux: leading order 1e-300 is a number', flux_too_small(1e-100_wp, 4, 1e-300_wp, msg), 0)
    call check_eq('flux: a subnormal leading order is not', flux_too_small(1e-160_wp, 3, 1e-310_wp, msg), VERDICT_FAILS)
    call check_true('flux: says dE^(N-1)', index(msg, 'of order dE^2') > 0, trim(msg))
    call check_eq('flux: leading order 0 is not', flux_too_small(1e-200_wp, 3, 0.0_wp, msg), VERDICT_FAILS)
    call check_eq('flux: 40 of 4000 undecided hold', flux_undecided(1.0_wp, [4000, 100, 10, 40], 1.5_wp, 20.0_wp, &
                  msg), 0)
    call check_eq('flux: 41 of 4000 undecided fail', flux_undecided(1.0_wp, [4000, 100, 10, 41], 1.5_wp, 20.0_wp, &
                  msg), VERDICT_FAILS)
    fe = 3e-3_wp
    ch = 4e-3_wp                                          ! combined: 5e-3
    call check_eq('flux: normal form 4.9 sigma off holds', &
                  flux_normal_form_check(1.0_wp, 8, 1.0_wp + 4.9_wp*5e-3_wp, ch, 1.0_wp, fe, z, msg), 0)
    call check_close('flux: z in combined standard errors sqrt(fe^2 + change^2)', z, 4.9_wp, 1e-12_wp)
    call check_eq('flux: 5.1 sigma fails', &
                  flux_normal_form_check(1.0_wp, 8, 1.0_wp - 5.1_wp*5e-3_wp, ch, 1.0_wp, fe, z, msg), VERDICT_FAILS)
    call check_eq('flux: no change (order 2) uses fe alone', &
                  flux_normal_form_check(1.0_wp, 2, 1.0_wp + 5.1_wp*fe, nan, 1.0_wp, fe, z, msg), VERDICT_FAILS)
    call check_eq('flux: a normal form without a bounded region fails', &
                  flux_normal_form_check(1.0_wp, 8, inf, ch, 1.0_wp, fe, z, msg), VERDICT_FAILS)
    call check_true('flux: says lower dE', index(msg, 'lower dE') > 0, trim(msg))
  end subroutine flux

  !> The section's Monte Carlo fraction sf against flux / volume: the score test's standard error
  !> under the prediction, sqrt(p (1 - p) sum w^2) / sum w, with the prediction's own.
  subroutine section()
    integer, parameter :: n = 1000
    real(wp) :: w(n), p, se0, sp, comb, pt, z
    logical :: use_nf
    character(1024) :: msg
    w = 1
    p = 0.3_wp                                   ! flux 0.3 over a unit volume
    se0 = sqrt(p*(1 - p)*n)/n
    sp = p*sqrt((1e-3_wp/0.3_wp)**2 + (1e-3_wp)**2)   ! fe = 1e-3 of the flux, sve = 1e-3 of the volume
    comb = sqrt(se0**2 + sp**2)
    call check_eq('section: 4.9 sigma holds', section_check(1.0_wp, nan, nan, 0.3_wp, 1e-3_wp, 1.0_wp, 1e-3_wp, &
                  p + 4.9_wp*comb, 0.01_wp, w, [n, 300, 700, 0], 20.0_wp, use_nf, pt, z, msg), 0)
    call check_close('section: z', z, 4.9_wp, 1e-10_wp)
    call check_true('section: sampled flux (no normal form)', .not. use_nf)
    call check_close('section: p_theory = flux / volume', pt, 0.3_wp, 1e-15_wp)
    call check_eq('section: 5.1 sigma fails', section_check(1.0_wp, nan, nan, 0.3_wp, 1e-3_wp, 1.0_wp, 1e-3_wp, &
                  p - 5.1_wp*comb, 0.01_wp, w, [n, 300, 700, 0], 20.0_wp, use_nf, pt, z, msg), VERDICT_FAILS)
    ! the normal form's flux where its change is within 10 % of it
    call check_eq('section: the normal form used', section_check(1.0_wp, 0.3_wp, 0.029_wp, 0.5_wp, 1e-3_wp, 1.0_wp, &
                  1e-3_wp, 0.3_wp, 0.01_wp, w, [n, 300, 700, 0], 20.0_wp, use_nf, pt, z, msg), 0)
    call check_true('section: change 0.029 of 0.3: normal form', use_nf)
    call check_eq('section: change 0.031 of 0.3: the sampled flux', section_check(1.0_wp, 0.3_wp, 0.031_wp, 0.3_wp, &
                  1e-3_wp, 1.0_wp, 1e-3_wp, 0.3_wp, 0.01_wp, w, [n, 300, 700, 0], 20.0_wp, use_nf, pt, z, msg), 0)
    call check_true('section: sampled used', .not. use_nf)
    call check_eq('section: 11 of 1000 undecided fail', section_check(1.0_wp, nan, nan, 0.3_wp, 1e-3_wp, 1.0_wp, &
                  1e-3_wp, 0.3_wp, 0.01_wp, w, [n, 300, 689, 11], 20.0_wp, use_nf, pt, z, msg), VERDICT_FAILS)
    call check_eq('section: flux/volume 1.2 +- 0.001 above 1 fails', section_check(1.0_wp, nan, nan, 1.2_wp, 1e-3_wp, &
                  1.0_wp, 0.0_wp, 1.0_wp, 0.0_wp, w, [n, n, 0, 0], 20.0_wp, use_nf, pt, z, msg), VERDICT_FAILS)
    call check_true('section: says exceeds 1', index(msg, 'exceeds 1') > 0, trim(msg))
    call nan_inputs(.true.)
    call check_eq('section: no flux, nothing checked', section_check(1.0_wp, nan, nan, nan, nan, 1.0_wp, 1e-3_wp, &
                  0.5_wp, 0.01_wp, w, [n, 500, 500, 0], 20.0_wp, use_nf, pt, z, msg), 0)
    call check_true('section: no flux, p_theory NaN', pt /= pt)
    call nan_inputs(.false.)
  end subroutine section

  !> The 3-DOF cut: its extrapolated 4-volume within a quarter of the grid's change (plus 1e-6) of
  !> the normal form's flux; misclassified points within mu + 5 sqrt(mu) + 2 of the shell's mu.
  subroutine cut3()
    character(1024) :: msg
    ! vol 1.0, on every other node 0.96: the change 0.04, a quarter of it 0.01
    call check_eq('cut3: extrapolated within a quarter of the change', &
                  cut3_check(1.0_wp, 1.0_wp, 0.96_wp, 1.013_wp, 1.0039_wp, 10.0_wp, 1000, 0, msg), 0)
    call check_eq('cut3: beyond it', cut3_check(1.0_wp, 1.0_wp, 0.96_wp, 1.013_wp, 1.0029_wp, 10.0_wp, 1000, 0, msg), &
                  VERDICT_FAILS)
    call check_true('cut3: says n_cut', index(msg, 'raise &flux n_cut') > 0, trim(msg))
    ! mu = 1000 * 0.013 / 10 = 1.3: limit 1.3 + 5 sqrt(1.3) + 2 = 9.0
    call check_eq('cut3: 9 misclassified hold', cut3_check(1.0_wp, 1.0_wp, 0.96_wp, 1.013_wp, 1.0039_wp, 10.0_wp, &
                  1000, 9, msg), 0)
    call check_eq('cut3: 10 fail', cut3_check(1.0_wp, 1.0_wp, 0.96_wp, 1.013_wp, 1.0039_wp, 10.0_wp, 1000, 10, msg), &
                  VERDICT_FAILS)
  end subroutine cut3

  subroutine setup_rules()
    character(1024) :: msg
    real(wp) :: ee, need
    ! the paper's defaults: the library's rolling ball only
    call check_eq('defaults: the ball has them', default_refused('rolling_ball', 'transition', 'rolling_ball', msg), 0)
    call check_eq('defaults: Henon-Heiles has none', default_refused('henon_heiles', 'transition', 'henon_heiles', &
                  msg), 1)
    call check_true('defaults: names the group and the system', &
                    index(msg, '&transition: de is not set: system henon_heiles') > 0, trim(msg))
    call check_eq('defaults: a formula model has no start', default_refused('expr_0123', 'trajectory', 'expression', &
                  msg), 1)
    call check_true('defaults: says x0, y0', index(msg, 'x0 or y0 is not set') > 0, trim(msg))
    ! dE resolvable at the saddle: at least a million times 16 ulps of |E_e| (2^-52 each)
    ee = 1.0e4_wp
    need = 1.0e6_wp*16*ee*2.0_wp**(-52)
    call check_eq('de: 1.01 times the floor resolves', de_unresolved([1.0_wp, 1.01_wp*need], 'transition', 'S12', &
                  ee, msg), 0)
    call check_eq('de: 0.99 times the floor does not (the 2nd)', de_unresolved([1.0_wp, 0.99_wp*need], &
                  'transition', 'S12', ee, msg), 2)
    call check_true('de: names the group and the saddle', index(msg, '&transition de = ') > 0 .and. &
                    index(msg, 'saddle S12') > 0, trim(msg))
    ! the scenes each model takes
    call check_eq('scenes: transition with 2 DOF', scene_refused('transition', 2, .false., 'm', msg), SCENE_TAKEN)
    call check_eq('scenes: transition with 3 DOF', scene_refused('transition', 3, .true., 'm', msg), &
                  SCENE_NOT_FOR_MODEL)
    call check_eq('scenes: tubes with 3 DOF and a plane', scene_refused('tubes', 3, .true., 'm', msg), SCENE_TAKEN)
    call check_eq('scenes: tubes with 3 DOF and the ray', scene_refused('tubes', 3, .false., 'm', msg), &
                  SCENE_NEEDS_PLANE)
    call check_eq('scenes: orbits with 1 DOF', scene_refused('orbits', 1, .true., 'm', msg), SCENE_NOT_FOR_MODEL)
    call check_eq('scenes: trajectory with 3 DOF', scene_refused('trajectory', 3, .true., 'm', msg), &
                  SCENE_NOT_FOR_MODEL)
  end subroutine setup_rules

end program test_verdicts
