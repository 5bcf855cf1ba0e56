"""The Birkhoff normal form and its flux (src/orbits/tubes_normal_form.f90, `&flux order`; docs/theory.md,
"The normal form"), through the executable, against independent references: the closed form of a
separable 3-DOF saddle (1e-12), a 2-D quadrature of the NHIM's interior where a quartic coupling
keeps {q1 = p1 = 0} invariant, the Lyapunov orbit's action in 2 DOF (the orbits scene: shooting,
another computation), the sampled flux (within 4 standard errors); convergence with the order;
the refusals (a built-in model, a resonance)."""
import math

import numpy as np
import pytest
from scipy import integrate, optimize

from test_flux import SIGMAS, cache, flux_of, run  # noqa: F401  (cache: the fixture)

COUPLED = ("(p1^2 + p2^2 + p3^2)/2 - q1^2/2 + q1^4/4 + w2^2*q2^2/2 + w3^2*q3^2/2 + a*q1^2*q2^2"
           " + b*q1^2*q3^2 + c*q2^2*q3^2 + d*q2^4")
CONSTS = "'w2 = 1.3', 'w3 = 2.1', 'a = 0.2', 'b = 0.1', 'c = 0.3', 'd = 0.05'"


def _section_of(tmp):
    """/flux/section: its datasets and attributes."""
    import os

    import h5py
    with h5py.File(os.path.join(tmp, "f.h5")) as fh:
        g = fh["flux/section"]
        out = {k: g[k][()] for k in g}
        out.update(dict(g.attrs))
        return out


def _nml(h, consts, de, order, extra="", n_samples=20000, seed=3, ndof=3, scenes="'flux'"):
    coords = "'q1', 'q2', 'q3'" if ndof == 3 else "'q1', 'q2'"
    moms = "'p1', 'p2', 'p3'" if ndof == 3 else "'p1', 'p2'"
    return f"""
        &run scenes = {scenes}, output = 'f.h5' /
        &model system = 'expression', hamiltonian = '{h}',
          coordinates = {coords}, momenta = {moms}, constants = {consts} /
        &equilibria box = 1.0, n_grid = 5 /
        &orbits saddle_near = {', '.join(['0'] * ndof)} {extra} /
        &flux de = {', '.join(map(str, de))}, order = {order}, n_samples = {n_samples}, seed = {seed} /
        """


def test_separable_saddle_is_exact(tmp_path, cache):
    """H = |p|^2/2 - q1^2/2 + w2^2 q2^2/2 + w3^2 q3^2/2: the normal form is H itself, the flux
    2 pi^2 dE^2 / (w2 w3) to 1e-12; the sampled flux agrees within 4 standard errors."""
    tmp = str(tmp_path)
    p = run(tmp, _nml("(p1^2 + p2^2 + p3^2)/2 - q1^2/2 + w2^2*q2^2/2 + w3^2*q3^2/2", "'w2 = 1.3', 'w3 = 2.1'",
                      [0.01, 0.2], 6), cache)
    assert p.returncode == 0, p.stdout + p.stderr
    f = flux_of(tmp)
    exact = 2 * math.pi**2 * f["dE"] ** 2 / (1.3 * 2.1)
    np.testing.assert_allclose(f["flux_normal_form"], exact, rtol=1e-12)
    assert np.all(np.abs(f["flux_sampled"] - exact) < SIGMAS * f["flux_sampled_err"])
    assert "Birkhoff normal form of order 6" in p.stdout


def _nhim_volume(de):
    """(2 pi) int int_{V < dE} (dE - V) dq2 dq3 on q1 = p1 = 0 (the momenta's disc integrated):
    polar coordinates, Brent for the boundary, QUADPACK (scipy), relative 1e-13."""
    w2, w3, c, d = 1.3, 2.1, 0.3, 0.05

    def v(x, y):
        return w2**2 * x**2 / 2 + w3**2 * y**2 / 2 + c * x**2 * y**2 + d * x**4

    def inner(phi):
        g = lambda r: v(r * math.cos(phi), r * math.sin(phi)) - de  # noqa: E731
        rmax = optimize.brentq(g, 0, 10.0, xtol=1e-15, rtol=1e-15)
        return integrate.quad(lambda r: (de - v(r * math.cos(phi), r * math.sin(phi))) * r, 0, rmax,
                              epsabs=0, epsrel=1e-13)[0]

    return 2 * math.pi * integrate.quad(inner, 0, 2 * math.pi, epsabs=0, epsrel=1e-13, limit=200)[0]


@pytest.mark.parametrize("order", [4, 6, 8, 10])
def test_coupled_quartic_converges_to_the_quadrature(tmp_path, cache, order):
    """A quartic coupling that keeps {q1 = p1 = 0} invariant: the flux is the 4-volume of
    {H(0, 0, q2, p2, q3, p3) <= E} (quadrature). The normal form's error falls with the order
    (measured: 3e-4, 1e-6, 2e-8, 1e-10 relative at dE = 0.1... below), its printed change from
    order K - 2 bounds it, and the sampled flux agrees within 4 standard errors."""
    tmp = str(tmp_path)
    p = run(tmp, _nml(COUPLED, CONSTS, [0.05, 0.1], order), cache)
    assert p.returncode == 0, p.stdout + p.stderr
    f = flux_of(tmp)
    ref = np.array([_nhim_volume(de) for de in f["dE"]])
    err = np.abs(f["flux_normal_form"] / ref - 1)
    bound = {4: 2e-3, 6: 2e-5, 8: 3e-7, 10: 3e-9}[order]
    assert np.all(err < bound), (order, err)
    if order > 4:
        assert np.all(np.abs(f["flux_normal_form"] - ref) <= 3 * f["flux_normal_form_change"] + 1e-13 * ref)
    assert np.all(np.abs(f["flux_sampled"] - ref) < SIGMAS * f["flux_sampled_err"])


def test_a_coupling_that_moves_the_nhim(tmp_path, cache):
    """With q1 q2^2 and q1 q3^2 terms the NHIM is no longer {q1 = p1 = 0}: the normal form
    (orders 8 and 10 agree to its printed change) against the sampled flux only."""
    tmp = str(tmp_path)
    h = COUPLED + " + e*q1*q2^2 + e*q1*q3^2"
    p = run(tmp, _nml(h, CONSTS + ", 'e = 0.15'", [0.1], 10, n_samples=100000), cache)
    assert p.returncode == 0, p.stdout + p.stderr
    f = flux_of(tmp)
    assert f["flux_normal_form_change"][0] < 1e-6 * f["flux_normal_form"][0]
    assert abs(f["flux_sampled"][0] - f["flux_normal_form"][0]) < SIGMAS * f["flux_sampled_err"][0]
    # and it is not the invariant case's number (4e-4 relative away: 100 times the normal form's change)
    rel_change = f["flux_normal_form_change"][0] / f["flux_normal_form"][0]
    assert abs(f["flux_normal_form"][0] / _nhim_volume(0.1) - 1) > 100 * rel_change


def _action_errors(tmp_path, cache, orders, des, n_samples, near, model):
    """|the normal form's flux / the Lyapunov orbit's action (2 pi J) - 1| of a 2-DOF model (its
    &model and &equilibria groups; the saddle near `near`), a row per order, a column per dE."""
    tmp = str(tmp_path)
    errs = []
    for order in orders:
        p = run(tmp, f"""
            &run scenes = 'orbits', 'flux', output = 'f.h5' /
            &orbits saddle_near = {near}, de = {des} /
            &flux de = {des}, order = {order}, n_samples = {n_samples} /
            {model}
            """, cache)
        assert p.returncode == 0, p.stdout + p.stderr
        f = flux_of(tmp)
        errs.append(np.abs(f["flux_normal_form"] / f["action"] - 1))
    return np.array(errs)


def test_two_dof_normal_form_is_the_lyapunov_action(tmp_path, cache):
    """Henon-Heiles as a formula: the flux 2 pi J(dE) of the normal form against the action of the
    Lyapunov orbit of the same energy found by shooting (the orbits scene), the error falling
    with the order."""
    errs = _action_errors(tmp_path, cache, (4, 6, 8, 10, 12), "0.01, 0.1", 4000, "0, 1", """
        &model system = 'expression', hamiltonian = '(px^2 + py^2)/2 + (x^2 + y^2)/2 + x^2*y - y^3/3',
          coordinates = 'x', 'y' /""")
    assert np.all(np.diff(errs[:, 1]) < 0), errs          # dE = 0.1: falls at every order
    assert errs[-1, 0] < 1e-9 and errs[-1, 1] < 1e-6, errs


def test_the_four_well_ball_written_as_a_formula(tmp_path, cache):
    """The ball's Hamiltonian (square roots and the kinetic metric: the Taylor expansion by
    automatic differentiation, python/tubes/codegen.py) at S12: the normal form's flux against the
    Lyapunov orbit's action, the error falling with the order at dE = 100 and 400 (cm/s)^2 and
    below 1e-6 at order 10, dE = 100."""
    from test_expression import BALL, PAPER
    consts = ", ".join(f"'{k} = {v}'" for k, v in PAPER.items())
    errs = _action_errors(tmp_path, cache, (4, 6, 8, 10), "100, 400", 2000, "0.0, 6.1", f"""
        &model system = 'expression', hamiltonian = '{BALL}', constants = {consts} /
        &equilibria box = 20.0 /""")
    assert np.all(np.diff(errs, axis=0) < 0), errs
    assert errs[-1, 0] < 1e-6, errs


def test_refusals(tmp_path, cache):
    """A built-in model has no formula to expand: exit 1 naming &flux order. A 1:2 resonance of
    the centres with a resonant term (q2^2 q3 with w3 = 2 w2): refused naming it, exit 2, the
    sampled flux still written."""
    tmp = str(tmp_path)
    p = run(tmp, """
        &run scenes = 'flux', output = 'f.h5' /
        &model system = 'henon_heiles' /
        &flux de = 0.01, order = 6 /
        """, cache)
    assert p.returncode == 1 and "&flux: order = 6" in p.stderr and "formula" in p.stderr, p.stderr
    p = run(tmp, _nml("(p1^2 + p2^2 + p3^2)/2 - q1^2/2 + w2^2*q2^2/2 + w3^2*q3^2/2 + 0.1*q2^2*q3",
                      "'w2 = 1.0', 'w3 = 2.0'", [0.01], 6, n_samples=2000), cache)
    assert p.returncode == 2, p.stdout + p.stderr
    assert "resonance" in p.stderr and "-2 omega_2 +1 omega_3 = 0" in p.stderr, p.stderr
    f = flux_of(tmp)
    assert np.isfinite(f["flux_sampled"][0]) and np.isnan(f["flux_normal_form"][0])


def test_python_gives_the_scenes_numbers(tmp_path, cache, monkeypatch):
    """tubes.flux(..., order=K): the scene's flux_normal_form and its change, bitwise (one path:
    the program's reader, the formula's library, the same Fortran), and the normal form's terms;
    a built-in model is refused."""
    import os

    import h5py

    import tubes
    tmp = str(tmp_path)
    hh = "(px^2 + py^2)/2 + (x^2 + y^2)/2 + x^2*y - y^3/3"
    p = run(tmp, f"""
        &run scenes = 'flux', output = 'f.h5' /
        &model system = 'expression', hamiltonian = '{hh}', coordinates = 'x', 'y' /
        &orbits saddle_near = 0, 1 /
        &flux de = 0.01, 0.05, order = 8, n_samples = 2000 /
        """, cache)
    assert p.returncode == 0, p.stderr
    f = flux_of(tmp)
    monkeypatch.setenv("TUBES_CACHE_DIR", cache)
    r = tubes.flux(tubes.Model(system="expression", hamiltonian=hh, coordinates=["x", "y"]), dE=[0.01, 0.05],
                   saddle_near=[0, 1], n_samples=2000, order=8)
    with pytest.raises(ValueError, match="written as a formula"):
        tubes.flux(tubes.Model(system="henon_heiles"), dE=[0.01], order=6)
    assert np.array_equal(r["flux_normal_form"], f["flux_normal_form"])
    assert np.array_equal(r["flux_normal_form_change"], f["flux_normal_form_change"])
    nf = r["normal_form"]
    assert nf["lambda"] == pytest.approx(1.0, rel=1e-14) and nf["omegas"][0] == pytest.approx(3**0.5, rel=1e-14)
    with h5py.File(os.path.join(tmp, "f.h5")) as h:
        g = h["flux/normal_form"]
        assert np.array_equal(nf["coefficients"], g["coefficients"][()])
        assert np.array_equal(nf["powers"][:, 1], g["power_J2"][()])


def test_a_quartic_bath_is_sampled_not_normalised(tmp_path, cache, monkeypatch):
    """H = |p|^2/2 - q1^2/2 + w2^2 q2^2/2 + q3^4/4: the bath mode has no quadratic term, the saddle
    is degenerate (named D1). The normal form is refused naming that (exit 2); the sampled flux
    still works and matches the closed form (2 pi / w2) int_0^dE A3(e) de = (8 pi C / (7 w2))
    dE^(7/4), A3(e) = C e^(3/4) the area of p^2/2 + q^4/4 <= e, C = 4 4^(1/4) sqrt 2 int_0^1
    sqrt(1 - u^4) du. The orbits scene refuses D1, saying why."""
    tmp = str(tmp_path)
    h = "(p1^2 + p2^2 + p3^2)/2 - q1^2/2 + w2^2*q2^2/2 + q3^4/4"
    p = run(tmp, _nml(h, "'w2 = 1.3'", [0.1, 0.5], 6, n_samples=20000, scenes="'equilibria', 'flux'"), cache)
    assert p.returncode == 2, p.stdout + p.stderr
    assert "degenerate" in p.stderr and "no Birkhoff normal form" in p.stderr, p.stderr
    assert "D1" in p.stdout and "no leading-order flux" in p.stdout
    f = flux_of(tmp)
    c = 4 * 4**0.25 * math.sqrt(2) * integrate.quad(lambda u: math.sqrt(1 - u**4), 0, 1, epsabs=0, epsrel=1e-13)[0]
    exact = 8 * math.pi * c / (7 * 1.3) * f["dE"] ** 1.75
    assert np.all(np.abs(f["flux_sampled"] - exact) < SIGMAS * f["flux_sampled_err"]), (f["flux_sampled"], exact)
    assert np.all(np.isnan(f["flux_normal_form"])) and np.all(np.isnan(f["flux_leading_order"]))
    # Python's saddle_near takes the degenerate saddle for the flux, as the program does (it said
    # "no rank-1 saddle in the search box"): the same sampled flux, bit for bit
    import tubes
    monkeypatch.setenv("TUBES_CACHE_DIR", cache)
    m = tubes.Model(system="expression", hamiltonian=h, coordinates=["q1", "q2", "q3"],
                    momenta=["p1", "p2", "p3"], constants={"w2": 1.3})
    r = tubes.flux(m, dE=[0.1, 0.5], saddle_near=[0, 0, 0], n_samples=20000, seed=3,
                   equilibria={"box": 1.0, "n_grid": 5})
    assert np.array_equal(r["flux_sampled"], f["flux_sampled"]), (r["flux_sampled"], f["flux_sampled"])
    p = run(tmp, _nml(h, "'w2 = 1.3'", [0.1], 0, scenes="'orbits'").replace("saddle_near = 0, 0, 0", "saddle = 'D1'"),
            cache)
    assert p.returncode == 1 and "D1 is a degenerate saddle" in p.stderr, p.stderr


def test_nhim_points_lie_on_the_lyapunov_orbit(tmp_path, cache):
    """The normal form's coordinate change maps points of its NHIM (I_1 = 0, H_NF = E_s + dE) to the
    model's (q, p): there the model's own energy is E_s + dE (nhim_energy_error), the change and
    its inverse round-trip, and each point, integrated by the model for the Lyapunov orbit's period
    (the orbits scene, by shooting), comes back to itself: the points are on the orbit."""
    import h5py

    import tubes
    tmp = str(tmp_path)
    hh = "(px^2 + py^2)/2 + (x^2 + y^2)/2 + x^2*y - y^3/3"
    p = run(tmp, f"""
        &run scenes = 'orbits', 'flux', output = 'f.h5' /
        &model system = 'expression', hamiltonian = '{hh}', coordinates = 'x', 'y' /
        &orbits saddle_near = 0, 1, de = 0.01 /
        &flux de = 0.01, order = 12, n_samples = 2000 /
        """, cache)
    assert p.returncode == 0, p.stdout + p.stderr
    f = flux_of(tmp)
    assert f["nhim_energy_error"][0] < 1e-11 and f["round_trip_error"][0] < 1e-11, f
    with h5py.File(f"{tmp}/f.h5") as h:
        pts = h["flux/normal_form/nhim_points"][0]
        period = h["orbits/period"][0]
    m = tubes.Model(system="henon_heiles")        # the built-in: another code for the same H
    for z in pts:
        r = tubes.integrate(z, period, model=m, rtol=1e-13, atol=1e-13)
        assert np.max(np.abs(r["state"][-1] - z)) < 1e-8, (z, r["state"][-1])


def test_a_gyroscopic_saddle_the_planar_cr3bp(tmp_path, cache):
    """The planar CR3BP (written as a formula) at Earth-Moon L1 is gyroscopic (H quadratic in p,
    the ellipse of momenta centred at (-y, x)): the normal form's flux is the Lyapunov orbit's
    action (shooting) to 1e-8 at dE = 1e-3, 1e-2, the sampled flux (the past followed backwards,
    the dividing surface x = x_L1 mapped to itself by the reversor) agrees within 4 standard
    errors; the NHIM points carry the model's energy."""
    tmp = str(tmp_path)
    h = ("(px^2 + py^2)/2 + y*px - x*py - (1 - mu)/sqrt((x + mu)^2 + y^2) - mu/sqrt((x - 1 + mu)^2 + y^2)")
    p = run(tmp, f"""
        &run scenes = 'orbits', 'flux', output = 'f.h5' /
        &model system = 'expression', hamiltonian = '{h}', constants = 'mu = 0.01215058560962404' /
        &equilibria box = 1.5, n_grid = 31 /
        &orbits saddle_near = 0.84, 0, de = 0.001, 0.01 /
        &flux de = 0.001, 0.01, order = 10, n_samples = 20000 /
        """, cache)
    assert p.returncode == 0, p.stdout + p.stderr
    f = flux_of(tmp)
    np.testing.assert_allclose(f["flux_normal_form"], f["action"], rtol=1e-8)
    assert np.all(np.abs(f["flux_sampled"] - f["action"]) < SIGMAS * f["flux_sampled_err"]), (f["flux_sampled"],
                                                                                            f["action"])
    assert np.all(f["nhim_energy_error"] < 1e-5)


def test_transition_fraction_on_a_four_dimensional_section(tmp_path, cache):
    """Tube dynamics in 3 DOF (the paper's section II): on the section q1 = -0.7 (moving towards
    the saddle) the fraction of the energy surface that transits before returning is the flux
    over the section's 4-volume. The volume against a quadrature (2 pi int int (E - V(-0.7, q2, q3))
    over V < E, the momenta's disc integrated), the Monte Carlo fraction against the normal form's
    flux / volume, both within 4 standard errors."""
    tmp = str(tmp_path)
    text = _nml(COUPLED, CONSTS, [0.05, 0.1], 8, n_samples=20000).replace(
        "&flux", "&section kind = 'plane', index = 1, value = -0.7, direction = 1 /\n        &flux")
    p = run(tmp, text, cache)
    assert p.returncode == 0, p.stdout + p.stderr
    assert "the transition fraction on the section q1 = -0.7" in p.stdout
    f = flux_of(tmp)
    s = _section_of(tmp)
    assert s["index"] == 1 and s["value"] == -0.7 and s["direction"] == 1
    assert np.all(s["n_transit"] + s["n_return"] + s["n_undecided"] == s["n_inside"])
    w2, w3, a, b, c, d = 1.3, 2.1, 0.2, 0.1, 0.3, 0.05
    q1 = -0.7

    def v(x, y):
        return (-q1**2 / 2 + q1**4 / 4 + w2**2 * x**2 / 2 + w3**2 * y**2 / 2 + a * q1**2 * x**2 + b * q1**2 * y**2
                + c * x**2 * y**2 + d * x**4)

    for k, de in enumerate(f["dE"]):
        def inner(phi):
            g = lambda r: v(r * math.cos(phi), r * math.sin(phi)) - de  # noqa: E731
            rmax = optimize.brentq(g, 0, 10.0, xtol=1e-14)
            return integrate.quad(lambda r: (de - v(r * math.cos(phi), r * math.sin(phi))) * r, 0, rmax)[0]
        vol = 2 * math.pi * integrate.quad(inner, 0, 2 * math.pi, limit=200)[0]
        assert abs(s["volume"][k] - vol) < SIGMAS * s["volume_err"][k], (s["volume"][k], vol)
        theory = f["flux_normal_form"][k] / vol
        assert abs(s["p_trans"][k] - theory) < SIGMAS * s["p_trans_err"][k], (s["p_trans"][k], theory)


def test_python_section_fraction_is_the_scenes(tmp_path, cache, monkeypatch):
    """tubes.flux(..., section={...}) gives the scene's section volume, Monte Carlo fraction and
    flux / volume bitwise (one Fortran path)."""
    import os

    import tubes
    tmp = str(tmp_path)
    text = _nml(COUPLED, CONSTS, [0.05], 6, n_samples=4000).replace(
        "&flux", "&section kind = 'plane', index = 1, value = -0.7, direction = 1 /\n        &flux")
    p = run(tmp, text, cache)
    assert p.returncode == 0, p.stdout + p.stderr
    f = flux_of(tmp)
    consts = {"w2": 1.3, "w3": 2.1, "a": 0.2, "b": 0.1, "c": 0.3, "d": 0.05}
    monkeypatch.setenv("TUBES_CACHE_DIR", cache)
    m = tubes.Model(system="expression", hamiltonian=COUPLED, coordinates=["q1", "q2", "q3"],
                    momenta=["p1", "p2", "p3"], constants=consts)
    r = tubes.flux(m, dE=[0.05], saddle_near=[0, 0, 0], n_samples=4000, seed=3, order=6,
                   section={"kind": "plane", "index": 1, "value": -0.7, "direction": 1},
                   equilibria={"box": 1.0, "n_grid": 5})
    s = _section_of(tmp)
    for k, h in (("section_volume", "volume"), ("section_volume_err", "volume_err"), ("p_trans_section", "p_trans"),
                 ("p_trans_section_err", "p_trans_err"), ("p_trans_theory", "p_trans_theory")):
        assert np.array_equal(r[k], s[h]), (k, r[k], s[h])
    for k in ("flux_normal_form", "flux_sampled"):
        assert np.array_equal(r[k], f[k]), (k, r[k], f[k])


def test_bad_requests_are_refused(tmp_path, cache):
    """&flux order = 1 (out of range, exit 1 naming it); order 12 in 3 DOF (exit 1: at most 10); a
    section whose point nearest the saddle lies outside the energy surface (exit 2, saying so)."""
    tmp = str(tmp_path)
    p = run(tmp, _nml(COUPLED, CONSTS, [0.05], 1, n_samples=200), cache)
    assert p.returncode == 1 and "order = 1 is out of range" in p.stderr, p.stderr
    p = run(tmp, _nml(COUPLED, CONSTS, [0.05], 12, n_samples=200), cache)
    assert p.returncode == 1 and "at most 10 in 3 degrees of freedom" in p.stderr, p.stderr
    text = _nml(COUPLED, CONSTS, [0.05], 0, n_samples=200).replace(
        "&flux", "&section kind = 'plane', index = 1, value = -3.0, direction = 1 /\n        &flux")
    p = run(tmp, text, cache)
    assert p.returncode == 2 and "lies outside the energy surface" in p.stderr, p.stderr


def test_points_through_the_coordinate_change(cache, monkeypatch):
    """tubes.normal_form_map: real normal-form coordinates to the model's (q, p) and back. For the
    separable saddle the model's energy of the image is lambda x1 y1 + omega_2 J_2 + omega_3 J_3
    (1e-12); for the coupled quartic, points of the NHIM (x1 = y1 = 0) land on its invariant plane
    q1 = p1 = 0, and the round trip falls with the order."""
    import tubes
    monkeypatch.setenv("TUBES_CACHE_DIR", cache)
    names = {"coordinates": ["q1", "q2", "q3"], "momenta": ["p1", "p2", "p3"]}
    rng = np.random.default_rng(5)
    w = rng.uniform(-0.3, 0.3, size=(20, 6))
    sep = tubes.Model(system="expression", hamiltonian="(p1^2 + p2^2 + p3^2)/2 - q1^2/2 + 1.3^2*q2^2/2 + 2.1^2*q3^2/2",
                      **names)
    r = tubes.normal_form_map(sep, w, order=4, saddle_near=[0, 0, 0], equilibria={"box": 1.0, "n_grid": 5})
    q1, q2, q3, p1, p2, p3 = r["points"].T
    h = (p1**2 + p2**2 + p3**2) / 2 - q1**2 / 2 + 1.3**2 * q2**2 / 2 + 2.1**2 * q3**2 / 2
    hnf = w[:, 0] * w[:, 3] + 1.3 * (w[:, 1]**2 + w[:, 4]**2) / 2 + 2.1 * (w[:, 2]**2 + w[:, 5]**2) / 2
    np.testing.assert_allclose(h, hnf, atol=1e-12)
    assert np.all(r["round_trip"] < 1e-14)
    back = tubes.normal_form_map(sep, r["points"], order=4, to="normal_form", saddle_near=[0, 0, 0],
                                 equilibria={"box": 1.0, "n_grid": 5})
    np.testing.assert_allclose(back["points"], w, atol=1e-14)
    cq = tubes.Model(system="expression", hamiltonian=COUPLED,
                     constants={"w2": 1.3, "w3": 2.1, "a": 0.2, "b": 0.1, "c": 0.3, "d": 0.05}, **names)
    wn = w.copy()
    wn[:, [0, 3]] = 0
    trips = []
    for order in (4, 6, 8):
        r = tubes.normal_form_map(cq, wn, order=order, saddle_near=[0, 0, 0], equilibria={"box": 1.0, "n_grid": 5})
        assert np.all(np.abs(r["points"][:, [0, 3]]) < 1e-14)
        trips.append(r["round_trip"].max())
    assert trips[0] > 10 * trips[1] > 100 * trips[2], trips
    with pytest.raises(ValueError, match="formula"):
        tubes.normal_form_map(tubes.Model(system="henon_heiles"), np.zeros((1, 4)), saddle_near=[0, 1])
