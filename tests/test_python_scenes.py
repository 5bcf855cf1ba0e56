"""The scenes from Python against the program: the same numbers, bit for bit, for the paper's ball,
Henon-Heiles, the restricted three-body problem and a 3-DOF formula, with the defaults taken from
the program's own namelist reader. Every scene
is here: equilibria, trajectory, orbits, tubes, transition, montecarlo, sections, flux and the
synthetic experiment."""
import importlib.util

import h5py
import numpy as np
import pytest

import tubes
from conftest import ROOT, run_tubes


def _run(tmp_path, text):
    return _run_any(tmp_path, text, 0)


def _run_any(tmp_path, text, rc):
    """The program on an input text; its exit code must be rc."""
    (tmp_path / "s.nml").write_text(text)
    r = run_tubes(["s.nml", "-o", "s.h5"], tmp_path, timeout=600)
    assert r.returncode == rc, r.stderr
    return h5py.File(tmp_path / "s.h5", "r")


def test_orbits_transition_montecarlo_ball(tmp_path):
    f = _run(tmp_path, "&run scenes = 'orbits', 'transition', 'montecarlo' /\n"
                       "&orbits de = 1, 50, 300 /\n&transition de = 10, 100 /\n"
                       "&montecarlo de = 100, n_samples = 1500, seed = 4 /\n")
    m = tubes.Model()
    o = m.orbit_family(dE=[1, 50, 300])
    for k in ("period", "action", "mu_unstable", "residual", "closure", "mu_trivial", "mu_trivial_imag",
              "monodromy", "min_eq_distance"):
        assert np.array_equal(o[k], f["orbits"][k][:]), k
    t = m.transition(dE=[10, 100])
    for k in ("A_tube", "action", "A_E", "p_trans"):
        assert np.array_equal(t[k], f["transition"][k][:]), k
    mc = m.monte_carlo(dE=100, n_samples=1500, seed=4)
    g = f["montecarlo"]
    assert np.array_equal(mc["r"], g["r"][:]) and np.array_equal(mc["transit"], g["transit"][:])
    assert np.array_equal(mc["inside"].astype(int), g["inside"][:])
    assert mc["fraction"] == g.attrs["fraction"] and mc["p_trans"] == g.attrs["p_trans"]


def test_equilibria_trajectory_tubes_flux_ball(tmp_path):
    f = _run(tmp_path, "&run scenes = 'equilibria', 'trajectory', 'tubes', 'flux' /\n"
                       "&trajectory t_end = 2 /\n&tubes de = 50 /\n"
                       "&flux de = 1, 10, n_samples = 3000, seed = 5 /\n")
    eq = tubes.equilibria()
    g = f["equilibria"]
    assert [n.decode() for n in g["name"][:]] == list(eq["name"])
    for k in ("x", "y", "height", "energy", "grad_norm", "morse_index", "lambda", "omega", "state"):
        assert np.array_equal(np.asarray(eq[k]), g[k][:]), k
    g = f["trajectory"]
    tr = tubes.trajectory(g["state"][0], 2.0)       # the scene's start, its method ('auto') and dt
    for k in ("t", "state", "energy"):
        assert np.array_equal(tr[k], g[k][:]), k
    assert tr["nsteps"] == g.attrs["nsteps"] and tr["nfev"] == g.attrs["nfev"]
    cut = tubes.tube_cut(dE=50)
    g = f["tubes/stable_000"]
    assert cut["area"] == g.attrs["area"] and cut["action"] == g.attrs["action"]
    for k in ("r", "p_r", "tau", "time", "state"):
        assert np.array_equal(cut[k], g[k][:]), k
    fl = tubes.flux(dE=[1, 10], n_samples=3000, seed=5)
    for k in ("flux_sampled", "flux_sampled_err", "flux_leading_order", "n_inside", "n_reacting",
              "n_recrossing", "n_undecided"):
        assert np.array_equal(fl[k], f["flux"][k][:]), k


def test_henon_heiles_scenes(tmp_path):
    f = _run(tmp_path, "&model system = 'henon_heiles' /\n"
                       "&run scenes = 'orbits', 'tubes', 'transition', 'montecarlo' /\n"
                       "&orbits saddle_near = 0, 1, de = 0.001, 0.01 /\n&tubes de = 0.01 /\n"
                       "&transition de = 0.005, 0.02 /\n&montecarlo de = 0.02, n_samples = 1000, seed = 9 /\n")
    hh = tubes.Model(system="henon_heiles")
    o = hh.orbit_family(dE=[0.001, 0.01], saddle_near=(0, 1))
    assert o["saddle"] == "S2"
    assert np.array_equal(o["period"], f["orbits/period"][:])
    c = hh.tube_cut(0.01, saddle_near=(0, 1))
    g = f["tubes/stable_000"]
    assert c["area"] == g.attrs["area"] and np.array_equal(c["r"], g["r"][:])
    t = hh.transition(dE=[0.005, 0.02], saddle_near=(0, 1))
    assert np.array_equal(t["p_trans"], f["transition/p_trans"][:])
    mc = hh.monte_carlo(0.02, n_samples=1000, seed=9, saddle_near=(0, 1))
    assert mc["fraction"] == f["montecarlo"].attrs["fraction"] and mc["misclassified"] == 0


def test_cr3bp_scenes(tmp_path):
    """The Earth-Moon restricted three-body problem (gyroscopic, no default section): L1's orbits,
    tube cut, p_trans, Monte Carlo and Poincare map on the plane x = 0.7, from Python with the
    section and the saddle as keywords, equal to the program's bit for bit."""
    sec = "&section kind = 'plane', index = 1, value = 0.7, direction = 1 /\n"
    f = _run(tmp_path, "&model system = 'cr3bp' /\n&equilibria box = 1.5 /\n" + sec +
                       "&run scenes = 'equilibria', 'orbits', 'tubes', 'transition', 'montecarlo', 'sections' /\n"
                       "&orbits saddle_near = 0.84, 0.0, de = 0.001, 0.002 /\n&tubes de = 0.002 /\n"
                       "&transition de = 0.001, 0.002 /\n&montecarlo de = 0.002, n_samples = 400, seed = 3 /\n"
                       "&sections de = 0.002, n_seeds = 3, n_iter = 8 /\n")
    cr = tubes.Model(system="cr3bp")
    kw = {"saddle_near": (0.84, 0.0), "section": {"kind": "plane", "index": 1, "value": 0.7, "direction": 1},
          "equilibria": {"box": 1.5}}
    eq = tubes.equilibria(cr, box=1.5)
    assert np.array_equal(np.asarray(eq["state"]), f["equilibria/state"][:])
    o = cr.orbit_family(dE=[0.001, 0.002], saddle_near=(0.84, 0.0), equilibria={"box": 1.5})
    assert o["saddle"] == "L1"
    for k in ("period", "action", "mu_unstable"):
        assert np.array_equal(o[k], f["orbits"][k][:]), k
    c = cr.tube_cut(0.002, **kw)
    g = f["tubes/stable_000"]
    assert c["area"] == g.attrs["area"] and np.array_equal(c["r"], g["r"][:]) and np.array_equal(c["state"], g["state"][:])
    t = cr.transition(dE=[0.001, 0.002], **kw)
    for k in ("A_tube", "A_E", "p_trans"):
        assert np.array_equal(t[k], f["transition"][k][:]), k
    mc = cr.monte_carlo(0.002, n_samples=400, seed=3, **kw)
    assert mc["fraction"] == f["montecarlo"].attrs["fraction"] and np.array_equal(mc["transit"], f["montecarlo/transit"][:])
    pts = cr.poincare(0.002, n_seeds=3, n_iter=8, **kw)
    assert np.array_equal(pts.points, f["sections/map_000/points"][:], equal_nan=True)


def test_three_dof_orbits(tmp_path):
    """A 3-DOF model written as a formula: the Lyapunov family of each centre mode (family = 1, 2),
    from Python equal to the program's bit for bit."""
    h = "(p1^2 + p2^2 + p3^2)/2 - q1^2/2 + q1^4/4 + 1.3^2*q2^2/2 + 2.1^2*q3^2/2 + 0.3*q2^2*q3^2"
    model = (f"&model system = 'expression', hamiltonian = '{h}', coordinates = 'q1', 'q2', 'q3', "
             "momenta = 'p1', 'p2', 'p3' /\n&equilibria box = 1.0, n_grid = 5 /\n&run scenes = 'orbits' /\n")
    m = tubes.Model(system="expression", hamiltonian=h, coordinates=["q1", "q2", "q3"], momenta=["p1", "p2", "p3"])
    for fam in (1, 2):
        f = _run(tmp_path, model + f"&orbits saddle_near = 0, 0, 0, de = 0.02, 0.05, family = {fam} /\n")
        o = m.orbit_family(dE=[0.02, 0.05], saddle_near=(0, 0, 0), family=fam, equilibria={"box": 1.0, "n_grid": 5})
        for k in ("period", "action", "mu_unstable", "state0", "monodromy"):
            assert np.array_equal(o[k], f["orbits"][k][:]), (fam, k)
        f.close()


def test_poincare_maps(tmp_path):
    f = _run(tmp_path, "&run scenes = 'sections' /\n&sections de = 100, n_seeds = 4, n_iter = 30 /\n")
    pts = tubes.Model().poincare(100, n_seeds=4, n_iter=30)
    assert np.array_equal(pts.points, f["sections/map_000/points"][:], equal_nan=True)
    assert pts.dE == f["sections/map_000"].attrs["dE"] and pts.units["points"] == "cm, cm/s"


def test_the_integrator_is_the_inputs_choice(tmp_path):
    """&integrator method reaches the tube analyses: another method gives the same p_trans to its
    own accuracy but not the same bits, and Python with the same choice gives the program's bits;
    a fixed-step method without a step is refused."""
    f = _run(tmp_path, "&run scenes = 'transition' /\n&transition de = 100 /\n&integrator method = 'arkode_erk8' /\n")
    at, act = f["transition/A_tube"][0], f["transition/action"][0]
    ref = tubes.Model().transition(dE=[100])
    assert at != ref["A_tube"][0]                         # not DOP853's bits
    assert abs(at / act - 1) < 1e-7                       # area = action to the cut's tolerance
    assert abs(at / ref["A_tube"][0] - 1) < 1e-7
    py = tubes.Model().transition(dE=[100], integrator={"method": "arkode_erk8"})
    assert py["A_tube"][0] == at
    (tmp_path / "r.nml").write_text("&run scenes = 'tubes' /\n&integrator method = 'rk4' /\n")
    r = run_tubes(["r.nml"], tmp_path)
    assert r.returncode == 1 and "is fixed-step: it needs h > 0" in r.stderr


def test_the_p_trans_example_is_the_papers_run(paper_h5):
    """docs/examples/p_trans.py, the paper's p_trans from the API alone, gives input/paper.nml's
    /transition and /montecarlo bit for bit."""
    spec = importlib.util.spec_from_file_location("p_trans_example", ROOT / "docs" / "examples" / "p_trans.py")
    ex = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(ex)
    f = h5py.File(paper_h5[0], "r")
    assert list(f["transition/dE"][:]) == ex.DE
    tr, mc = ex.compute()
    for k in ("A_tube", "A_E", "p_trans"):
        assert np.array_equal(tr[k], f["transition"][k][:]), k
    g = f["montecarlo"]
    assert mc["fraction"] == g.attrs["fraction"] and mc["p_trans"] == g.attrs["p_trans"]
    assert np.array_equal(mc["transit"], g["transit"][:])


def test_synthetic_experiment(tmp_path):
    """The synthetic tracks (damped ball, Taylor method by 'auto', GSL's stream) from Python are
    the scene's, every frame and every attribute; another system is refused."""
    f = _run(tmp_path, "&run scenes = 'synthetic_experiment' /\n&experiment n_tracks = 5, duration = 3, seed = 7 /\n")
    g = f["tracks"]
    ex = tubes.Model().synthetic_experiment(n_tracks=5, duration=3, seed=7)
    for k in ("track", "t", "x", "y"):
        assert np.array_equal(ex[k], g[k][:]), k
    for k in ("state", "energy", "dE", "noisy", "release", "release_dE"):
        assert np.array_equal(ex["truth"][k], g["truth"][k][:]), k
    for k in ("E_e", "damping_rate", "n_draws", "n_samples", "box", "rtol", "seed", "damping_ratio", "pixel"):
        assert ex[k] == g.attrs[k], k
    with pytest.raises(ValueError, match="it needs system = .rolling_ball., not .henon_heiles."):
        tubes.synthetic_experiment(tubes.Model(system="henon_heiles"))
    with pytest.raises(ValueError, match="widen"):
        tubes.synthetic_experiment(n_tracks=3, de_min=1e5, de_max=2e5, duration=1)   # beyond the box


def test_monte_carlo_agreement_is_the_scene_s(tmp_path):
    """monte_carlo returns the scene's agreement (/montecarlo@agrees) and refuses, as the program
    exits 2, when the count and the tube disagree: Henon-Heiles with t_max = 1, far too short for
    its points to transit or return (1933 of 2000 undecided, fraction 0 against p_trans 0.06)."""
    (tmp_path / "s.nml").write_text("&model system = 'henon_heiles' /\n&run scenes = 'montecarlo' /\n"
                                    "&montecarlo de = 0.02, n_samples = 2000, t_max = 1.0 /\n")
    r = run_tubes(["s.nml", "-o", "s.h5"], tmp_path, timeout=600)
    assert r.returncode == 2 and "disagrees" in r.stderr, r.stderr
    g = h5py.File(tmp_path / "s.h5", "r")["montecarlo"]
    hh = tubes.Model(system="henon_heiles")
    with pytest.raises(tubes.DisagreementError, match="1933 undecided") as err:
        hh.monte_carlo(0.02, n_samples=2000, t_max=1.0)
    mc = err.value.partial
    assert mc["agrees"] is False and g.attrs["agrees"] == 0
    assert mc["undecided"] == g.attrs["undecided"] and mc["fraction"] == g.attrs["fraction"]
    assert mc["undecided_limit"] == 2 + 2000 // 100 and mc["sigmas"] > tubes.MC_SIGMA
    again = hh.monte_carlo(0.02, n_samples=2000, t_max=1.0, check=False)   # no raise, the same numbers
    assert again["agrees"] is False and np.array_equal(again["transit"], mc["transit"])
    # a run that agrees: the scene's 1 (the default t_max)
    ok = tubes.Model().monte_carlo(100.0, n_samples=1000, seed=3)
    assert ok["agrees"] is True and ok["sigmas"] <= tubes.MC_SIGMA


def test_monte_carlo_arguments_are_the_input_file_s():
    """The &montecarlo ranges of docs/input.md, with messages naming the argument (not f2py's or an
    OverflowError), and no default dE outside the ball's units."""
    hh = tubes.Model(system="henon_heiles")
    for kw, msg in (({"n_samples": -5}, r"n_samples = -5 is out of range: allowed 1 \.\. 10000000"),
                    ({"n_samples": 2.5}, "value 2.5 of 'n_samples' is not an integer"),
                    ({"seed": -1}, "seed = -1 is out of range: allowed >= 0"),
                    ({"seed": 2**40}, "seed = 1099511627776 is out of range"),
                    ({"dE": -0.01}, r"de(\(1\))? = -0.01 is out of range: allowed > 0"),
                    ({"dE": float("nan")}, "monte_carlo: dE = nan is out of range: allowed a finite real number"),
                    ({"dE": None}, "monte_carlo: &montecarlo: de is not set: system henon_heiles has no default excess energies")):
        with pytest.raises(ValueError, match=msg):
            hh.monte_carlo(**{"dE": 0.02, "n_samples": 100, **kw})
    with pytest.raises(ValueError, match=r"poincare: &sections: de\(1\) = -0.01 is out of range"):
        hh.poincare(-0.01, n_seeds=2, n_iter=2)


def test_transition_keeps_every_energy_as_the_scene(tmp_path):
    """A failure at one energy (the ball at dE = 780: past the end of the orbit family, 777) is NaN
    and a status there, as the scene's /transition: the program exits 4, Python raises TubesError
    with the whole Table (dE = 760 kept) as its partial; check=False returns it with a warning."""
    f = _run_any(tmp_path, "&run scenes = 'transition' /\n&transition de = 760, 780 /\n", 4)
    with pytest.raises(tubes.TubesError, match="failed at dE = 780") as e:
        tubes.Model().transition([760.0, 780.0])
    assert e.value.code == tubes.EPASTEND and np.isfinite(e.value.partial["p_trans"][0])
    with pytest.warns(RuntimeWarning, match="failed at dE = 780"):
        t = tubes.Model().transition([760.0, 780.0], check=False)
    g = f["transition"]
    assert np.array_equal(t["status"], g["status"][:]) and t["status"][0] == 0 and t["status"][1] < 0
    for k in ("A_tube", "action", "A_E", "p_trans"):
        assert np.array_equal(t[k], g[k][:], equal_nan=True), k
    assert np.isnan(t["p_trans"][1]) and np.isfinite(t["p_trans"][0]) and t["message"][0] == ""


def test_unconverged_orbits_are_nan():
    """Past the family's end (the ball's ends near dE = 777) an orbit has no period: NaN, not 0.
    The orbits scene exits 4 there: Python raises EPASTEND with the Table as its partial."""
    with pytest.raises(tubes.TubesError, match="no orbit at dE = 800") as e:
        tubes.Model().orbit_family(dE=[700.0, 800.0])
    assert e.value.code == tubes.EPASTEND and list(e.value.partial["converged"]) == [True, False]
    o = tubes.Model().orbit_family(dE=[700.0, 800.0], check=False)
    assert list(o["converged"]) == [True, False] and o["end_dE"] < 800
    for k in ("period", "action", "mu_unstable", "stability_index", "state0", "monodromy"):
        assert np.all(np.isfinite(o[k][0])) and np.all(np.isnan(o[k][1])), k


def test_string_choices_and_saddles_are_checked():
    hh = tubes.Model(system="henon_heiles")
    with pytest.raises(ValueError, match="kind = 'stabel' is not allowed: allowed 'stable', 'unstable'"):
        hh.tube_cut(0.02, kind="stabel")
    for bad in ("S9", "W1"):
        with pytest.raises(ValueError, match=f"saddle = '{bad}' is not a rank-1 saddle.*are: S1, S2, S3"):
            hh.transition([0.01], saddle=bad)
    # 3 DOF: tube_cut takes a plane (docs/tubes.md, "Tubes of halo orbits"); the CR3BP has no default
    with pytest.raises(ValueError, match="this system has no default section: give section="):
        tubes.Model(system="cr3bp_spatial").tube_cut(0.001)
    with pytest.raises(ValueError, match="transition: 'transition' works on the region of a Poincare section of a "
                       "model with 2 degrees of freedom; system cr3bp_spatial has 3"):
        tubes.Model(system="cr3bp_spatial").transition([0.001])
    with pytest.raises(ValueError, match="poincare: 'sections' works on the region of a Poincare section"):
        tubes.Model(system="cr3bp_spatial").poincare(0.001)
    with pytest.raises(ValueError, match=r"tube_cut: the tubes scene of system cr3bp_spatial \(3 degrees of freedom\) "
                       "cuts the manifolds with a plane"):
        tubes.Model(system="cr3bp_spatial").tube_cut(0.001, section={"kind": "ray"})
    for f, msg in ((lambda: hh.tube_cut(-0.01), r"tube_cut: &tubes: de\(1\) = -0.01 is out of range: allowed > 0"),
                   (lambda: hh.tube_cut(), "tube_cut: give dE"),
                   (lambda: hh.transition([0.0]), r"transition: &transition: de\(1\) = 0 is out of range"),
                   (lambda: hh.transition(), "transition: &transition: de is not set: system henon_heiles has no default"),
                   (lambda: hh.orbit_family(), "orbit_family: &orbits: de is not set: system henon_heiles")):
        with pytest.raises(ValueError, match=msg):
            f()


def test_cr3bp_action_is_the_gauge_fixed_integral():
    """The CR3BP's momenta are O(1) at L1 (p = (-y, x)), and an orbit's p . dq integrated over its
    period weighs the orbit's closure error with |p|: the action was 2e-7 off at dE = 1e-5 (1e-3 at
    1e-11). The orbit's action is now the integral of (p - p_L1) . dq, against an independent
    quadrature of it (the periodic trapezoid rule on 2048 samples of a DOP853 trajectory at tol
    1e-14, spectrally accurate)."""
    m = tubes.Model(system="cr3bp")
    eq = m.equilibria()
    ps = eq["state"][eq["name"].index("L1")][2:]
    for de in (1e-5, 1e-4):
        o = m.orbit_family(dE=[de])
        x0, period, n = o["state0"][0], o["period"][0], 2048
        r = tubes.integrate(x0, period, dt_out=period / n * (1 - 1e-14), model=m, method="dop853",
                            rtol=1e-14, atol=1e-16)
        st = r["state"][:n]
        qd = np.array([tubes.vector_field(s, m)[:2] for s in st])
        a = np.sum((st[:, 2:] - ps) * qd) * period / n
        assert abs(o["action"][0] / a - 1) < 1e-9, (de, o["action"][0] / a - 1)


def test_an_unresolved_de_is_refused_by_the_library():
    """The dE-resolution rule (tubes_study de_floor) is checked before any work, as the program checks
    it when it reads an input (src/workflow/tubes_setup.f90 de_unresolved: a ValueError with the
    program's message), and the library refuses such a dE itself too (EUNRESOLVED; orbit_family once
    answered "invalid input" or, with a findable saddle, a 0.3 % wrong action). The ball with h0 =
    1e8 cm: E_e ~ 9.8e10 (cm/s)^2 is known to 16 ulps, and a dE below 1e6 times that (349) is refused
    by every call that takes one; a dE above it is computed."""
    m = tubes.Model(h0=1e8)
    e_s = m.equilibria()["energy"][list(m.equilibria()["name"]).index("S12")]
    floor = 1e6 * 16 * np.finfo(float).eps * abs(e_s)
    assert 340 < floor < 360
    for call in (lambda: m.orbit_family(dE=[0.99 * floor]), lambda: m.poincare(1.0), lambda: m.flux(dE=[1.0]),
                 lambda: m.tube_cut(1.0), lambda: m.transition(dE=[1.0]), lambda: m.monte_carlo(1.0, 10, 1)):
        with pytest.raises(ValueError, match="below what the energy resolves at the saddle S12"):
            call()
    # the core's own refusal, past Python's check
    st = tubes._settings(m, None, None)
    r = tubes._lib().orbit_family(*tubes._study(m, st), np.array([0.99 * floor]), 1, 1, 1e-11, 1e-13, 1e-13,
                                  25, 201, *tubes._integ(st, m), m._stores(), 0, np.zeros(6), 0.0)   # no guess
    assert r[0] == tubes.EUNRESOLVED
    assert m.orbit_family(dE=[1.01 * floor])["converged"][0]


def test_the_default_saddle_is_checked_as_a_named_one():
    """The ball with beta = 0 has one well and no saddle: its default saddle S12 does not exist.
    A call that names no saddle said 'invalid input (status -1)'; it says what the named case
    says, and that the name is the system's default."""
    m = tubes.Model(beta=0)
    for call in (lambda: m.orbit_family(dE=[1.0]), lambda: m.tube_cut(1.0)):
        with pytest.raises(ValueError, match=r"saddle = 'S12' \(the system's default\) is not a rank-1 saddle"):
            call()
