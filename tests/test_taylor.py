"""The Taylor method through the executable and Python (docs/integrators-taylor.md): the paper's
scenes (orbits, tube cut, p_trans, Monte Carlo, Poincare map) with method = 'taylor' give
DOP853's numbers; a formula model; Python's trajectory is the executable's bit for bit; the
kernel that cannot be built is refused with its reason, the run exits non-zero without a file.
(tests/test_taylor.f90 checks the method itself: orders, events, the real128 reference.)"""
import os
import subprocess
import textwrap

import h5py
import numpy as np
import pytest

import tubes
from conftest import ROOT, TUBES, TIMEOUT_SCALE

PAPER_SCENES = """\
&run scenes = 'orbits', 'tubes', 'transition', 'montecarlo', 'sections', output = '{out}' /
&integrator method = '{method}', rtol = 1e-12, atol = 1e-12 /
&orbits saddle = 'S12', de = 10, 100, 500 /
&tubes de = 100 /
&transition de = 10, 100, 500 /
&montecarlo de = 100, n_samples = 2000, seed = 7 /
&sections de = 100, n_seeds = 4, n_iter = 20 /
"""


def run(tmp, name, text, env=None, timeout=600):
    path = os.path.join(tmp, name)
    with open(path, "w") as f:
        f.write(textwrap.dedent(text))
    e = dict(os.environ, OMP_NUM_THREADS="2")
    e.update(env or {})
    return subprocess.run([str(TUBES), path], cwd=tmp, capture_output=True, text=True, env=e,
                          timeout=timeout * TIMEOUT_SCALE)


def read(path):
    """Every dataset by path, and every attribute as path@name."""
    with h5py.File(path) as f:
        out = {}

        def take(k, v):
            if isinstance(v, h5py.Dataset):
                out[k] = v[()]
            for a, val in v.attrs.items():
                out[f"{k}@{a}"] = val
        f.visititems(take)
        return out


@pytest.fixture(scope="module")
def paper_runs(tmp_path_factory):
    tmp = str(tmp_path_factory.mktemp("taylor"))
    out = {}
    for method in ("dop853", "taylor", "auto"):
        p = run(tmp, f"{method}.nml", PAPER_SCENES.format(out=f"{method}.h5", method=method))
        assert p.returncode == 0, p.stdout + p.stderr
        out[method] = read(os.path.join(tmp, f"{method}.h5"))
    return out


def rel(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    return np.max(np.abs(a - b)) / max(np.max(np.abs(b)), 1e-300)


@pytest.mark.parametrize("method", ["taylor", "auto"])
def test_orbits_as_dop853(paper_runs, method):
    """Periods, actions and Floquet multipliers of the S12 family: the two methods integrate the
    same equations at tol 1e-12 (Newton to 1e-11): agreement to 1e-9 relative ('auto': the
    orbits' variational equations are DOP853's, the same bits)."""
    d, t = paper_runs["dop853"], paper_runs[method]
    if method == "auto":
        for k in ("orbits/period", "orbits/action", "orbits/mu_unstable"):
            assert np.array_equal(t[k], d[k]), k
    for k in ("orbits/period", "orbits/action", "orbits/energy"):
        assert rel(t[k], d[k]) < 1e-9, k
    assert rel(t["orbits/mu_unstable"], d["orbits/mu_unstable"]) < 1e-6   # an exponential of the period


@pytest.mark.parametrize("method", ["taylor", "auto"])
def test_tube_and_transition_as_dop853(paper_runs, method):
    """The tube's area at dE = 100 equals the action (Green's theorem) with both methods, and
    p_trans agrees to 1e-9 (area_tol 1e-10 and 1e-8); input/paper.nml's 'auto' is held to the
    stated tolerance of docs/paper.md (areas and p_trans to 1e-8 relative)."""
    d, t = paper_runs["dop853"], paper_runs[method]
    assert abs(t["tubes/stable_000@area"] / t["tubes/stable_000@action"] - 1) < 1e-10
    assert rel(t["tubes/stable_000@area"], d["tubes/stable_000@area"]) < 1e-9
    assert rel(t["transition/p_trans"], d["transition/p_trans"]) < 1e-8


@pytest.mark.parametrize("method", ["taylor", "auto"])
def test_monte_carlo_and_sections_as_dop853(paper_runs, method):
    """The same points classified the same way (the integrations agree to ~1e-10; a point that
    close to the tube's boundary has probability ~1e-8), and the same Poincare returns."""
    d, t = paper_runs["dop853"], paper_runs[method]
    for k in ("montecarlo/inside", "montecarlo/transit", "montecarlo@undecided", "montecarlo@misclassified"):
        assert np.array_equal(t[k], d[k]), k
    pts_d, pts_t = d["sections/map_000/points"], t["sections/map_000/points"]
    assert pts_d.shape == pts_t.shape
    # the first return: the two tol-1e-12 integrations differ by ~3e-10 there (measured); later
    # returns drift apart as chaos amplifies it (1e-5 by the 5th, O(1) by the 18th)
    assert np.max(np.abs(pts_t[:, 0] - pts_d[:, 0])) < 1e-8 * np.max(np.abs(pts_d[:, 0]))


def test_python_trajectory_is_the_executable_s(tmp_path):
    """tubes.trajectory(method='taylor') is the executable's trajectory scene bit for bit."""
    p = run(str(tmp_path), "t.nml", """\
        &run scenes = 'trajectory', output = 't.h5' /
        &integrator method = 'taylor', rtol = 1e-10, atol = 1e-10 /
        &trajectory x0 = 4.0, y0 = 12.614863819914357, at_rest = .true., t_end = 2.0, dt_out = 0.5 /
        """)
    assert p.returncode == 0, p.stderr
    f = read(str(tmp_path / "t.h5"))
    tr = tubes.trajectory([4.0, 12.614863819914357, 0.0, 0.0], 2.0, dt_out=0.5, method="taylor",
                          rtol=1e-10, atol=1e-10)
    assert np.array_equal(tr["state"], f["trajectory/state"])


def test_formula_model_as_dop853(tmp_path):
    """input/expression.nml's model (a formula): p_trans with both methods to 1e-9."""
    text = open(ROOT / "input" / "expression.nml").read()
    out = {}
    for method in ("dop853", "taylor"):
        t = text.replace("&run", f"&integrator method = '{method}', rtol = 1e-12, atol = 1e-12 /\n&run", 1)
        t = t.replace("'expression.h5'", f"'{method}.h5'")
        p = run(str(tmp_path), f"{method}.nml", t)
        assert p.returncode == 0, p.stdout + p.stderr
        out[method] = read(str(tmp_path / f"{method}.h5"))
    assert rel(out["taylor"]["transition/p_trans"], out["dop853"]["transition/p_trans"]) < 1e-9


def test_synthetic_experiment_as_dop853(tmp_path):
    """The synthetic experiment's damped tracks with the input's method: the same releases and
    noise draws; the true states of Taylor and DOP853 (both rtol 1e-10) agree to 1e-7 cm over the
    first 2 s (the tracks are chaotic: the two methods' errors of ~1e-10 grow with t); each run
    says its method."""
    out = {}
    for method in ("dop853", "taylor"):
        p = run(str(tmp_path), f"{method}.nml", f"""\
            &run scenes = 'synthetic_experiment', output = '{method}.h5' /
            &integrator method = '{method}' /
            &experiment n_tracks = 8, duration = 4, damping_ratio = 0.01 /
            """)
        assert p.returncode == 0, p.stdout + p.stderr
        with h5py.File(tmp_path / f"{method}.h5") as f:
            g = f["tracks"]
            assert g.attrs["method"] == method
            out[method] = {k: g["truth"][k][()] for k in ("state", "release", "noisy")}
    a, b = out["taylor"], out["dop853"]
    assert np.array_equal(a["release"], b["release"])
    xa, xb = a["state"].reshape(8, -1, 4), b["state"].reshape(8, -1, 4)   # (track, frame, state)
    assert np.all(np.isfinite(xa)) and xa.shape[1] == 201
    assert np.abs(xa[:, :101, :2] - xb[:, :101, :2]).max() < 1e-7
    noise_a = a["noisy"].reshape(8, -1, 2) - xa[..., :2]
    noise_b = b["noisy"].reshape(8, -1, 2) - xb[..., :2]
    assert np.abs(noise_a - noise_b).max() < 1e-9           # the same draws


def test_no_kernel_is_refused(tmp_path):
    """With code generation off and an empty cache the kernel cannot be had: the run says why
    and exits non-zero, and writes no file."""
    cache = tmp_path / "empty-cache"
    cache.mkdir()
    p = run(str(tmp_path), "n.nml", """\
        &run scenes = 'trajectory', output = 'n.h5' /
        &integrator method = 'taylor' /
        """, env={"TUBES_CACHE_DIR": str(cache), "TUBES_NO_CODEGEN": "1"})
    assert p.returncode != 0
    assert "TUBES_NO_CODEGEN" in p.stderr and "Taylor" in p.stderr, p.stderr
    assert not (tmp_path / "n.h5").exists()


def test_lanes_do_not_depend_on_threads(tmp_path):
    """The Monte Carlo and the Poincare map in the Taylor method's lanes: 1 and 2 OpenMP threads,
    and lanes of forced widths 2 and 8 (TUBES_LANES), write the same numbers bit for bit (items
    fall into other lanes and chunks); the file records the width."""
    text = """\
        &run scenes = 'montecarlo', 'sections', output = '{out}' /
        &integrator method = 'taylor', rtol = 1e-10, atol = 1e-10 /
        &montecarlo de = 100, n_samples = 501, seed = 3 /
        &sections de = 100, n_seeds = 7, n_iter = 15 /
        """
    out = {}
    for th, w in (("1", "8"), ("2", "2")):
        p = run(str(tmp_path), f"l{th}.nml", text.format(out=f"l{th}.h5"),
                env={"OMP_NUM_THREADS": th, "TUBES_LANES": w})
        assert p.returncode == 0, p.stdout + p.stderr
        out[th] = read(str(tmp_path / f"l{th}.h5"))
        with h5py.File(tmp_path / f"l{th}.h5") as f:
            assert int(f.attrs["taylor_lanes"]) == int(w)
    for k in ("montecarlo/inside", "montecarlo/transit", "montecarlo/r", "sections/map_000/points"):
        assert np.array_equal(out["1"][k], out["2"][k], equal_nan=True), k


def test_python_ensemble_at_every_lanes_width(monkeypatch):
    """tubes.ensemble's rows at the lanes' widths 1, 2, 4 and 8 (TUBES_LANES, read at each call):
    each row the kept integrator's from it, bit for bit; an invalid width fails every row with
    TUBES_EINPUT."""
    x0 = np.array([4.0, 12.614863819914357, 0.0, 0.0])
    rng = np.random.default_rng(36)
    s = np.tile(x0, (13, 1))                      # 13: no width divides it
    s[:, :2] += rng.uniform(-0.1, 0.1, (13, 2))
    kw = dict(model=tubes.Model(), method="taylor", rtol=1e-8, atol=1e-8)
    it = tubes.Integrator(**kw)
    lone = np.array([it.propagate(x, 3.0)[0] for x in s])
    for w in ("1", "2", "4", "8"):
        monkeypatch.setenv("TUBES_LANES", w)
        assert np.array_equal(tubes.ensemble(s, 3.0, threads=1, **kw)["state"], lone), w
    monkeypatch.setenv("TUBES_LANES", "3")
    with pytest.raises(tubes.TubesError) as err:
        tubes.ensemble(s, 3.0, threads=1, **kw)
    assert np.all(err.value.partial["status"] == tubes.EINPUT)


@pytest.mark.parametrize("method", ["taylor", "dop853"])
def test_python_ensemble_is_lone_integrations(method):
    """tubes.ensemble (the lanes for the Taylor method): every row is integrate()'s final state
    from it bit for bit, in any order of the rows and for 1 or 2 threads; Henon-Heiles too (a
    model of another dimension of parameters); a row that fails says so (status, TubesError with
    the partial result) without spoiling the others."""
    x0 = np.array([4.0, 12.614863819914357, 0.0, 0.0])
    rng = np.random.default_rng(5)
    s = np.tile(x0, (23, 1))
    s[:, 1] += rng.uniform(-0.5, 0.5, 23)
    s[:, 2] += rng.uniform(-5, 5, 23)
    m = tubes.Model()
    kw = dict(model=m, method=method, rtol=1e-10, atol=1e-10)
    lone = np.array([tubes.integrate(x, 2.5, **kw)["state"][-1] for x in s])
    e2 = tubes.ensemble(s, 2.5, threads=2, **kw)
    e1 = tubes.ensemble(s[::-1], 2.5, threads=1, **kw)
    assert np.array_equal(e2["state"], lone) and np.array_equal(e1["state"][::-1], lone)
    assert np.all(e2["status"] == 0) and np.all(e2["nsteps"] > 10)
    hh = tubes.Model(system="henon_heiles")
    sh = np.array([[0.0, 0.1, 0.35, 0.0], [0.1, 0.0, 0.0, 0.3], [0.0, -0.2, 0.2, 0.1]])
    eh = tubes.ensemble(sh, 50.0, model=hh, method=method, rtol=1e-10, atol=1e-10)
    for x, y in zip(sh, eh["state"]):
        assert np.array_equal(y, tubes.integrate(x, 50.0, model=hh, method=method, rtol=1e-10,
                                                 atol=1e-10)["state"][-1])
    with pytest.raises(tubes.TubesError) as err:
        tubes.ensemble(s[:5], 2.5, max_steps=20, **kw)
    assert np.all(err.value.partial["status"] == tubes.EMAXSTEPS)
    with pytest.raises(ValueError, match=r"states must have shape \(m, 4\)"):
        tubes.ensemble(s[:, :3], 1.0, **kw)


def test_auto_without_a_kernel_falls_back_to_dop853(tmp_path):
    """The default method, 'auto', where no Taylor kernel can be had (code generation off, an
    empty cache): the run says so, uses DOP853 throughout and succeeds; its trajectory is DOP853's
    (rejected steps: a Taylor step is never rejected) and says what 'auto' became. Python warns
    and does the same."""
    cache = tmp_path / "empty-cache"
    cache.mkdir()
    env = {"TUBES_CACHE_DIR": str(cache), "TUBES_NO_CODEGEN": "1"}
    p = run(str(tmp_path), "a.nml", """\
        &run scenes = 'trajectory', output = 'a.h5' /
        &trajectory t_end = 2.0 /
        """, env=env)
    assert p.returncode == 0, p.stderr
    assert "method = 'auto': DOP853 throughout" in p.stderr and "TUBES_NO_CODEGEN" in p.stderr
    with h5py.File(tmp_path / "a.h5") as f:
        assert f["trajectory"].attrs["method"] in (b"auto (dop853)", "auto (dop853)")
    code = ("import warnings, tubes\n"
            "with warnings.catch_warnings(record=True) as w:\n"
            "    warnings.simplefilter('always')\n"
            "    tr = tubes.integrate([4.0, 12.614863819914357, 0, 0], 1.0)\n"
            "print(tr['nrejected'] > 0, any('DOP853 throughout' in str(x.message) for x in w))\n")
    q = subprocess.run([str(ROOT / ".venv" / "bin" / "python"), "-c", code], capture_output=True, text=True,
                       env=dict(os.environ, **env), timeout=120)
    assert q.returncode == 0, q.stderr
    assert q.stdout.split() == ["True", "True"], q.stdout + q.stderr


@pytest.mark.parametrize("method", [m for m in tubes.METHODS if m != "auto"])
def test_a_kept_integrator_is_a_new_one_on_every_call(method):
    """tubes.Integrator (the model, method and kernel set up once): every propagate is a new
    integration from t = 0, bit for bit a new integrator's (tubes.ensemble's row) whatever came
    before it on the same Integrator (another start, another end time), with this call's
    counters; Henon-Heiles too; failures and misuse say so."""
    x0 = np.array([4.0, 12.614863819914357, 0.0, 0.0])
    kw = dict(rtol=1e-9, atol=1e-9)
    if method in tubes.FIXED_STEP:
        kw = dict(h=1 / 256, solver="fixed_point") if method.startswith("gauss") else dict(h=1 / 256)
    m = tubes.Model()
    with tubes.Integrator(m, method=method, **kw) as it:
        x1, c1 = it.propagate(x0, 1.5)
        it.propagate(x0 + [0.3, -0.2, 1.0, 0.0], 0.7)
        x2, c2 = it.propagate(x0, 1.5)
        e = tubes.ensemble([x0], 1.5, model=m, method=method, **kw)
        assert np.array_equal(x1, e["state"][0]) and np.array_equal(x2, x1)
        assert c1[1] == c2[1] == e["nsteps"][0] > 0 and np.array_equal(c1, c2)
        x0_, c0 = it.propagate(x0, 0.0)
        assert np.array_equal(x0_, x0) and c0[1] == 0
        with pytest.raises(ValueError, match="state0 must have 4 components"):
            it.propagate(x0[:3], 1.0)
    with pytest.raises(ValueError, match="closed"):
        it.propagate(x0, 1.0)
    if method in ("taylor", "dop853"):
        assert np.array_equal(x1, tubes.integrate(x0, 1.5, model=m, method=method, **kw)["state"][-1])
        hh = tubes.Model(system="henon_heiles")
        xh = np.array([0.0, 0.1, 0.35, 0.0])
        ih = tubes.Integrator(hh, method=method, **kw)
        assert np.array_equal(ih.propagate(xh, 50.0)[0],
                              tubes.ensemble([xh], 50.0, model=hh, method=method, **kw)["state"][0])
        with pytest.raises(tubes.TubesError) as err:
            tubes.Integrator(m, method=method, max_steps=20, **kw).propagate(x0, 5.0)
        assert err.value.code == tubes.EMAXSTEPS and err.value.partial[1][1] == 20
