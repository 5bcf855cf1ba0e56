!> The scenes' verdicts: the checks whose failure makes the program exit 2 and Python's calls
!> (tubes.flux, tubes.monte_carlo, tubes.orbit_family) raise. One definition for both front ends:
!> src/io/tubes_scenes.c calls the bind(C) entries, python/tubes_f2py.f90 the Fortran ones. Each takes the
!> numbers the scene computed and returns 0 (holds) or 2 (fails) with the message; the limits are
!> the parameters below (docs/flux.md, docs/theory.md "Flux in N degrees of freedom").
module tubes_verdicts
  use, intrinsic :: iso_c_binding, only: c_double, c_int, c_char
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite, ieee_value, ieee_quiet_nan
  use tubes_kinds, only: wp
  use tubes_cstrings, only: num, f_to_c
  implicit none
  private

  integer, parameter, public :: VERDICT_FAILS = 2                 !! the program's exit code (numerical)
  real(wp), parameter, public :: UNDECIDED_MAX = 0.01_wp          !! undecided points allowed (share)
  real(wp), parameter, public :: SIGMA_MAX = 5                    !! standard errors two estimates may differ by
  real(wp), parameter, public :: NF_CHANGE_MAX = 0.1_wp           !! the normal form's change from order K - 2
                                                                  !! allowed (share of it) to be used for a flux
  real(wp), parameter, public :: ORBIT_ERROR_MAX = 1e-8_wp        !! an orbit's integration error allowed
                                                                  !! (share of its state's largest component)

  public :: flux_too_small, flux_undecided, flux_normal_form_check, section_check, cut3_check
  public :: orbit_coarse, mc_check

contains

  !> The sampled flux at de is below the smallest double (of order dE^(N-1)): no number there.
  integer function flux_too_small(de, ndof, lead, msg) result(code)
    real(wp), intent(in) :: de, lead      !! the energy, the flux's leading order
    integer, intent(in) :: ndof
    character(*), intent(out) :: msg
    code = 0
    msg = ''
    if (ieee_is_finite(lead) .and. .not. (lead > tiny(1.0_wp))) then
      code = VERDICT_FAILS
      write (msg, '(a,i0,a)') 'tubes: flux: dE = ' // num(de) // ' is too small: the flux, of order dE^', ndof - 1, &
        ', is below the smallest double (leading order ' // num(lead) // '); NaN there: raise dE'
    end if
  end function flux_too_small

  !> More than UNDECIDED_MAX of the dividing surface's points inside the shell (counts: inside,
  !> reacting, recrossing, undecided) left the slab neither way within t_max.
  integer function flux_undecided(de, counts, gate, t_max, msg) result(code)
    real(wp), intent(in) :: de, gate, t_max
    integer, intent(in) :: counts(4)
    character(*), intent(out) :: msg
    code = 0
    msg = ''
    if (counts(4) > UNDECIDED_MAX*counts(1)) then
      code = VERDICT_FAILS
      write (msg, '(a,i0,a,i0,a)') 'tubes: flux: dE = ' // num(de) // ': ', counts(4), ' of ', counts(1), &
        ' points on the dividing surface neither left the slab |(q - q_s) . n| <= ' // num(gate) // &
        ' forwards nor backwards within t_max = ' // num(t_max) // ': raise &flux t_max (or lower gate)'
    end if
  end function flux_undecided

  !> The normal form's flux nf of order K (its change from order K - 2: change, NaN if none) against
  !> the sampled flux fl +- fe: z their difference in combined standard errors; fails where the
  !> normal form has no flux (no bounded region of actions) or |z| > SIGMA_MAX.
  integer function flux_normal_form_check(de, order, nf, change, fl, fe, z, msg) result(code)
    real(wp), intent(in) :: de, nf, change, fl, fe
    integer, intent(in) :: order
    real(wp), intent(out) :: z
    character(*), intent(out) :: msg
    real(wp) :: sd
    code = 0
    msg = ''
    sd = fe*fe
    if (ieee_is_finite(change)) sd = sd + change*change
    sd = sqrt(sd)
    z = (nf - fl)/sd
    if (.not. ieee_is_finite(nf)) then
      code = VERDICT_FAILS
      write (msg, '(a,i0,a)') 'tubes: flux: dE = ' // num(de) // ': the normal form of order ', order, &
        ' has no bounded region of actions there (beyond the series'' reach): lower dE'
    else if (ieee_is_finite(fl) .and. abs(z) > SIGMA_MAX) then
      write (msg, '(a,i0,a)') 'tubes: flux: dE = ' // num(de) // ': the normal form (' // num(nf, '.10g') // &
        ', change ' // num(change, '.3g') // ' from order ', order - 2, ') and the sampled flux (' // &
        num(fl, '.10g') // ' +- ' // num(fe, '.3g') // ') disagree by ' // num(z, '.1f') // ' standard errors'
      code = VERDICT_FAILS
    end if
  end function flux_normal_form_check

  !> The transition fraction on a plane section at de: the Monte Carlo fraction sf +- sfe of the
  !> section's points (weights w, counts: inside, transits, returns, undecided) against
  !> p_theory = flux / volume (sv +- sve), the flux the normal form's nf (change nfc) where its change
  !> is within NF_CHANGE_MAX of it (use_nf), else the sampled fl +- fe. z: their difference in
  !> combined standard errors, the fraction's under the prediction (a score test:
  !> sqrt(p (1 - p) sum w^2) / sum w; the sample's own is 0 with no transit). Without a flux
  !> p_theory and z are NaN and nothing is checked. Fails on more than UNDECIDED_MAX undecided,
  !> p_theory above 1 by SIGMA_MAX of its error, or |z| > SIGMA_MAX.
  integer function section_check(de, nf, nfc, fl, fe, sv, sve, sf, sfe, w, counts, t_max, use_nf, p_theory, z, &
                                 msg) result(code)
    real(wp), intent(in) :: de, nf, nfc, fl, fe, sv, sve, sf, sfe, w(:), t_max
    integer, intent(in) :: counts(4)
    logical, intent(out) :: use_nf
    real(wp), intent(out) :: p_theory, z
    character(*), intent(out) :: msg
    real(wp) :: f, ferr, sp, sw1, sw2, se0
    integer :: i
    character(16) :: which
    code = 0
    msg = ''
    use_nf = ieee_is_finite(nf) .and. ieee_is_finite(nfc)
    if (use_nf) use_nf = abs(nfc) <= NF_CHANGE_MAX*abs(nf)
    if (use_nf) then
      f = nf; ferr = nfc
    else
      f = fl; ferr = fe
    end if
    p_theory = ieee_value(1.0_wp, ieee_quiet_nan)
    z = p_theory
    if (.not. (ieee_is_finite(f) .and. f > 0)) return   ! no flux there (failed, past the bottleneck, too small)
    p_theory = f/sv
    sp = p_theory*sqrt((ferr/f)**2 + (sve/sv)**2)
    sw1 = 0; sw2 = 0
    do i = 1, size(w)
      if (ieee_is_finite(w(i))) then
        sw1 = sw1 + w(i); sw2 = sw2 + w(i)*w(i)
      end if
    end do
    se0 = sfe
    if (sw1 > 0) se0 = sqrt(max(p_theory*(1 - p_theory), 0.0_wp)*sw2)/sw1
    z = 0
    if (sf /= p_theory) z = (sf - p_theory)/sqrt(se0*se0 + sp*sp)
    if (counts(4) > UNDECIDED_MAX*counts(1)) then
      write (msg, '(a,i0,a,i0,a)') 'tubes: flux: the section at dE = ' // num(de) // ': ', counts(4), ' of ', &
        counts(1), ' points neither transited nor returned within t_max = ' // num(t_max) // ': raise &flux t_max'
      code = VERDICT_FAILS
    else if (p_theory - 1 > SIGMA_MAX*sp) then
      which = 'sampled'
      if (use_nf) which = 'normal form''s'
      msg = 'tubes: flux: the section at dE = ' // num(de) // ': flux / volume = ' // num(p_theory, '.6g') // &
        ' +- ' // num(sp, '.2g') // ' exceeds 1 (a fraction of the section''s points): the ' // trim(which) // &
        ' flux or the volume is wrong there'
      code = VERDICT_FAILS
    else if (.not. ieee_is_finite(z) .or. abs(z) > SIGMA_MAX) then
      msg = 'tubes: flux: the section at dE = ' // num(de) // ': the Monte Carlo transition fraction ' // &
        num(sf, '.6g') // ' +- ' // num(sfe, '.2g') // ' and flux / volume ' // num(p_theory, '.6g') // &
        ' disagree by ' // num(z, '.1f') // ' standard errors (a section crossed by the tube more than once?)'
      code = VERDICT_FAILS
    end if
  end function section_check

  !> The stable tube's cut with the section at de (3 DOF): its 4-volume (vol, on every other node
  !> vol_half, extrapolated vol_x) against the normal form's flux f, and of the n_decided Monte
  !> Carlo points the misclassified ones against what the piecewise-linear cut's shell (about
  !> n_decided |vol_x - vol| / sv of them) explains.
  integer function cut3_check(de, vol, vol_half, vol_x, f, sv, n_decided, n_misclassified, msg) result(code)
    real(wp), intent(in) :: de, vol, vol_half, vol_x, f, sv
    integer, intent(in) :: n_decided, n_misclassified
    character(*), intent(out) :: msg
    real(wp) :: mu
    code = 0
    msg = ''
    mu = n_decided*abs(vol_x - vol)/sv
    if (.not. (abs(vol_x - f) <= 0.25_wp*abs(vol - vol_half) + 1e-6_wp*f)) then
      msg = 'tubes: flux: the tube''s cut at dE = ' // num(de) // ': its 4-volume ' // num(vol, '.8g') // ' (' // &
        num(vol_half, '.8g') // ' on every other node, extrapolated ' // num(vol_x, '.8g') // &
        ') and the normal form''s flux ' // num(f, '.8g') // ' differ by more than the grid explains: the cut ' // &
        'is under-resolved (raise &flux n_cut) or the normal form does not reach dE (raise &flux order, lower dE)'
      code = VERDICT_FAILS
    else if (n_misclassified > mu + 5*sqrt(mu) + 2) then
      write (msg, '(a,i0,a,i0,a)') 'tubes: flux: the tube''s cut at dE = ' // num(de) // ': ', n_misclassified, &
        ' of the ', n_decided, ' decided Monte Carlo points lie on the wrong side of it for their fate, more ' // &
        'than its resolution explains (about ' // num(mu, '.1f') // ' lie in the shell the piecewise-linear cut ' // &
        'misses): the tube does not separate transit from return on this section'
      code = VERDICT_FAILS
    end if
  end function cut3_check

  !> The orbit at de integrated too coarsely: one period's closure |x(T) - x(0)| grows like
  !> mu_unstable times the integration error, which bounds every quantity of the orbit (the Newton
  !> residual measures the integrator's map, not the flow's). Fails where closure / mu_unstable
  !> exceeds ORBIT_ERROR_MAX of the state's largest component (scale); an orbit that did not
  !> converge or is not unstable (mu <= 1, NaN) is not judged (rk4 with h = 0.05 on the ball:
  !> 1.4e-6 of the state with a residual of 3e-12).
  integer function orbit_coarse(de, closure, mu, scale, msg) result(code)
    real(wp), intent(in) :: de, closure, mu, scale
    character(*), intent(out) :: msg
    real(wp) :: est
    code = 0
    msg = ''
    if (.not. (mu > 1)) return
    est = closure/mu
    if (est > ORBIT_ERROR_MAX*max(scale, 1e-300_wp)) then
      msg = 'tubes: orbits: dE = ' // num(de) // ': the integration is too coarse for the orbit: one period''s ' // &
        'closure ' // num(closure, '.2g') // ' over mu_unstable ' // num(mu, '.6g') // ' is an integration error ' // &
        'of ~' // num(est, '.2g') // ', ' // num(est/scale, '.2g') // ' of the state (the limit: ' // &
        num(ORBIT_ERROR_MAX, 'g') // '); the period, action and multipliers are only that good: tighten ' // &
        '&integrator (rtol, atol, or h)'
      code = VERDICT_FAILS
    end if
  end function orbit_coarse

  !> The Monte Carlo check at de: of n points n_transit transited, n_undecided neither transited
  !> nor returned within t_max, misclassified ended otherwise than the prediction p (the tube's or
  !> the damped region's A / A_E) says; the rule is tubes_transport's mc_agreement (the fraction
  !> within MC_SIGMA standard errors of p, few misclassified, few undecided). A noisy model has no
  !> deterministic prediction: only its undecided count is held to the limit. sigmas and agrees as
  !> mc_agreement's (agrees the undecided count's alone for a noisy model).
  integer function mc_check(de, n, n_transit, n_undecided, misclassified, p, noisy, saddle, sigmas, agrees, msg) &
      result(code)
    use tubes_transport, only: mc_agreement, MC_SIGMA
    real(wp), intent(in) :: de, p
    integer, intent(in) :: n, n_transit, n_undecided, misclassified
    logical, intent(in) :: noisy
    character(*), intent(in) :: saddle
    real(wp), intent(out) :: sigmas
    logical, intent(out) :: agrees
    character(*), intent(out) :: msg
    integer :: mis_lim, und_lim
    real(wp) :: f, se
    code = 0
    msg = ''
    call mc_agreement(n, n_transit, n_undecided, misclassified, p, sigmas, mis_lim, und_lim, agrees)
    if (noisy) agrees = n_undecided <= und_lim
    if (agrees) return
    code = VERDICT_FAILS
    if (noisy) then
      write (msg, '(a,i0,a,i0,a,i0,a)') 'tubes: montecarlo: ', n_undecided, ' of ', n, &
        ' points neither transited nor returned within t_max (limit ', und_lim, '): raise &montecarlo t_max'
      return
    end if
    f = real(n_transit, wp)/n
    se = sqrt(f*(1 - f)/n)
    write (msg, '(a,i0,a,i0,a,i0,a,i0,a)') 'tubes: montecarlo: the direct check disagrees with the tube at dE = ' // &
      num(de) // ': fraction ' // num(f, '.5f') // ' +- ' // num(se, '.5f') // ' against p_trans = ' // &
      num(p, '.5f') // ' (' // num(sigmas, '.1f') // ' standard errors, limit ' // num(MC_SIGMA, 'g') // '); ', &
      misclassified, ' misclassified (limit ', mis_lim, '); ', n_undecided, ' undecided (limit ', und_lim, &
      '). The transit test, the section or the tube does not fit saddle ' // trim(saddle) // &
      ': check &section and &orbits saddle'
  end function mc_check

  ! ---------------------------------------------------------------- the C entries (src/io/tubes_scenes.c)

  integer(c_int) function c_orbit_coarse(de, closure, mu, scale, msg, len) result(code) &
      bind(C, name='tubes_verdict_orbit_coarse')
    real(c_double), value :: de, closure, mu, scale
    integer(c_int), value :: len
    character(kind=c_char), intent(out) :: msg(len)
    character(1024) :: m
    code = orbit_coarse(de, closure, mu, scale, m)
    call f_to_c(m, msg)
  end function c_orbit_coarse

  integer(c_int) function c_mc_check(de, n, n_transit, n_undecided, misclassified, p, noisy, saddle, sigmas, agrees, &
                                     msg, len) result(code) bind(C, name='tubes_verdict_montecarlo')
    use tubes_cstrings, only: c_to_f
    real(c_double), value :: de, p
    integer(c_int), value :: n, n_transit, n_undecided, misclassified, noisy, len
    character(kind=c_char), intent(in) :: saddle(8)
    real(c_double), intent(out) :: sigmas
    integer(c_int), intent(out) :: agrees
    character(kind=c_char), intent(out) :: msg(len)
    character(1024) :: m
    logical :: ok
    code = mc_check(de, n, n_transit, n_undecided, misclassified, p, noisy /= 0, c_to_f(saddle(1:8)), sigmas, ok, m)
    agrees = merge(1, 0, ok)
    call f_to_c(m, msg)
  end function c_mc_check

  integer(c_int) function c_flux_too_small(de, ndof, lead, msg, len) result(code) &
      bind(C, name='tubes_verdict_flux_too_small')
    real(c_double), value :: de, lead
    integer(c_int), value :: ndof, len
    character(kind=c_char), intent(out) :: msg(len)
    character(1024) :: m
    code = flux_too_small(de, ndof, lead, m)
    call f_to_c(m, msg)
  end function c_flux_too_small

  integer(c_int) function c_flux_undecided(de, counts, gate, t_max, msg, len) result(code) &
      bind(C, name='tubes_verdict_flux_undecided')
    real(c_double), value :: de, gate, t_max
    integer(c_int), intent(in) :: counts(4)
    integer(c_int), value :: len
    character(kind=c_char), intent(out) :: msg(len)
    character(1024) :: m
    code = flux_undecided(de, counts, gate, t_max, m)
    call f_to_c(m, msg)
  end function c_flux_undecided

  integer(c_int) function c_flux_normal_form_check(de, order, nf, change, fl, fe, z, msg, len) result(code) &
      bind(C, name='tubes_verdict_flux_normal_form')
    real(c_double), value :: de, nf, change, fl, fe
    integer(c_int), value :: order, len
    real(c_double), intent(out) :: z
    character(kind=c_char), intent(out) :: msg(len)
    character(1024) :: m
    code = flux_normal_form_check(de, order, nf, change, fl, fe, z, m)
    call f_to_c(m, msg)
  end function c_flux_normal_form_check

  integer(c_int) function c_section_check(de, nf, nfc, fl, fe, sv, sve, sf, sfe, ns, w, counts, t_max, use_nf, &
                                          p_theory, z, msg, len) result(code) bind(C, name='tubes_verdict_section')
    real(c_double), value :: de, nf, nfc, fl, fe, sv, sve, sf, sfe, t_max
    integer(c_int), value :: ns, len
    real(c_double), intent(in) :: w(ns)
    integer(c_int), intent(in) :: counts(4)
    integer(c_int), intent(out) :: use_nf
    real(c_double), intent(out) :: p_theory, z
    character(kind=c_char), intent(out) :: msg(len)
    character(1024) :: m
    logical :: u
    code = section_check(de, nf, nfc, fl, fe, sv, sve, sf, sfe, w, counts, t_max, u, p_theory, z, m)
    use_nf = merge(1, 0, u)
    call f_to_c(m, msg)
  end function c_section_check

  integer(c_int) function c_cut3_check(de, vol, vol_half, vol_x, f, sv, n_decided, n_misclassified, msg, len) &
      result(code) bind(C, name='tubes_verdict_cut3')
    real(c_double), value :: de, vol, vol_half, vol_x, f, sv
    integer(c_int), value :: n_decided, n_misclassified, len
    character(kind=c_char), intent(out) :: msg(len)
    character(1024) :: m
    code = cut3_check(de, vol, vol_half, vol_x, f, sv, n_decided, n_misclassified, m)
    call f_to_c(m, msg)
  end function c_cut3_check
end module tubes_verdicts
