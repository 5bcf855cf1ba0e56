"""The scenes from Python against the program: the same numbers, bit for bit, for the paper's ball
and for Henon-Heiles, with the defaults taken from the program's own namelist reader."""
import h5py
import numpy as np

import tubes
from conftest import run_tubes


def _run(tmp_path, text):
    (tmp_path / "s.nml").write_text(text)
    r = run_tubes(["s.nml", "-o", "s.h5"], tmp_path, timeout=600)
    assert r.returncode == 0, r.stderr
    return h5py.File(tmp_path / "s.h5", "r")


def test_orbits_transition_montecarlo_ball(tmp_path):
    f = _run(tmp_path, "&run scenes = 'orbits', 'transition', 'montecarlo' /\n"
                       "&orbits de = 1, 50, 300 /\n&transition de = 10, 100 /\n"
                       "&montecarlo de = 100, n_samples = 1500, seed = 4 /\n")
    m = tubes.Model()
    o = m.orbit_family(dE=[1, 50, 300])
    for k in ("period", "action", "mu_unstable", "residual", "closure"):
        assert np.array_equal(o[k], f["orbits"][k][:]), k
    t = m.transition(dE=[10, 100])
    for k in ("A_tube", "action", "A_E", "p_trans"):
        assert np.array_equal(t[k], f["transition"][k][:]), k
    mc = m.monte_carlo(dE=100, n_samples=1500, seed=4)
    g = f["montecarlo"]
    assert np.array_equal(mc["r"], g["r"][:]) and np.array_equal(mc["transit"], g["transit"][:])
    assert np.array_equal(mc["inside"].astype(int), g["inside"][:])
    assert mc["fraction"] == g.attrs["fraction"] and mc["p_trans"] == g.attrs["p_trans"]


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


def test_poincare_maps(tmp_path):
    f = _run(tmp_path, "&run scenes = 'sections' /\n&sections de = 100, n_seeds = 4, n_iter = 30 /\n")
    pts = tubes.Model().poincare(100, n_seeds=4, n_iter=30)
    assert np.array_equal(pts, f["sections/map_000/points"][:], equal_nan=True)


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
