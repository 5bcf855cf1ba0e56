"""Models written as formulas (docs/models.md): through the executable, the expression forms of the
built-in systems give the built-ins' equilibria, orbits and p_trans to 1e-10 relative; a 3-DOF
formula linearises to its closed form; bad formulas are refused with the file, line, variable and
column; the cache builds once, is shared by concurrent runs, and says what is missing."""
import math
import os
import subprocess
import textwrap

import h5py
import numpy as np
import pytest

from conftest import ROOT, TUBES, TIMEOUT_SCALE

REL = 1e-10

HH = "(px^2 + py^2)/2 + (x^2 + y^2)/2 + x^2*y - y^3/3"
DLB = ("px^2/(2*m_a) + py^2/(2*m_b) + D*(1 - exp(-lam*x))^2 + 4*y^2*(y^2 - 1)*exp(-zeta*lam*x) + eps_s")
DLB_CONSTANTS = "'m_a = 8', 'm_b = 8', 'D = 10', 'lam = 1.5', 'zeta = 1', 'eps_s = 1'"
CR3BP = ("(px^2 + py^2)/2 + y*px - x*py - (1 - mu)/sqrt((x + mu)^2 + y^2) "
         "- mu/sqrt((x - 1 + mu)^2 + y^2)")
# the four-well surface and the ball's Hamiltonian on it, T = (5/14) p^T M^-1 p, M = I + grad h grad h^T
FOURWELL = "alpha*(x^2 + y^2) - beta*(sqrt(x^2 + gamma) + sqrt(y^2 + gamma)) - xi*x*y + h0"
HX = "(2*alpha*x - beta*x/sqrt(x^2 + gamma) - xi*y)"
HY = "(2*alpha*y - beta*y/sqrt(y^2 + gamma) - xi*x)"
BALL = (f"(5/14)*(px^2 + py^2 - ({HX}*px + {HY}*py)^2/(1 + {HX}^2 + {HY}^2)) + g*({FOURWELL})")
PAPER = {"alpha": 0.07, "beta": 1.017, "gamma": 15.103, "xi": 0.00656, "h0": 12.065, "g": 981.0}


@pytest.fixture(scope="module")
def cache(model_cache):
    return model_cache          # the tests' shared model cache (conftest.py)


def run(tmp, name, text, cache, env=None, timeout=300):
    path = os.path.join(tmp, name)
    with open(path, "w") as f:
        f.write(textwrap.dedent(text))
    e = dict(os.environ, OMP_NUM_THREADS="1", TUBES_CACHE_DIR=cache, **(env or {}))
    return subprocess.run([str(TUBES), path], cwd=tmp, capture_output=True, text=True, env=e,
                          timeout=timeout * TIMEOUT_SCALE)


def ok(p):
    assert p.returncode == 0, p.stdout + p.stderr
    return p


def read(tmp, name):
    with h5py.File(os.path.join(tmp, name)) as f:
        out = {}
        f.visititems(lambda k, v: out.__setitem__(k, v[()]) if isinstance(v, h5py.Dataset) else None)
        return out


def close(a, b, keys, rel=REL):
    for k in keys:
        x, y = np.asarray(a[k], float), np.asarray(b[k], float)
        if k.startswith("equilibria/"):   # the same points, maybe named and ordered otherwise
            x, y = x[order(a)], y[order(b)]
        assert x.shape == y.shape, k
        scale = max(np.max(np.abs(y)), 1e-300)
        assert np.max(np.abs(x - y)) <= rel * scale, (k, x, y)


def order(d):
    """The equilibria sorted by position."""
    q = np.round(np.asarray(d["equilibria/state"], float), 8)
    return np.lexsort(q.T[::-1])


EQ_KEYS = ["equilibria/state", "equilibria/energy", "equilibria/morse_index", "equilibria/lambda", "equilibria/omega"]
ORB_KEYS = ["orbits/period", "orbits/action", "orbits/energy"]


def pair(tmp, cache, tag, model_expr, model_builtin, rest):
    """The same scenes on the formula and on the built-in; their two outputs."""
    a = ok(run(tmp, f"{tag}_e.nml", f"&run scenes = 'equilibria', 'orbits', 'transition', "
                                    f"output = '{tag}_e.h5' /\n{model_expr}\n{rest}", cache))
    b = ok(run(tmp, f"{tag}_b.nml", f"&run scenes = 'equilibria', 'orbits', 'transition', "
                                    f"output = '{tag}_b.h5' /\n{model_builtin}\n{rest}", cache))
    return a, b, read(tmp, f"{tag}_e.h5"), read(tmp, f"{tag}_b.h5")


def test_henon_heiles(tmp_path):
    # its own empty cache: the formula is compiled in this run ("compiled in")
    a, _, e, b = pair(str(tmp_path), str(tmp_path / "cache"), "hh", f"&model system = 'expression', hamiltonian = '{HH}' /",
                      "&model system = 'henon_heiles' /", """
        &equilibria box = 1.5 /
        &orbits saddle_near = 0.0, 1.0, de = 0.01, 0.03 /
        &section kind = 'plane', index = 2, value = 0.0, direction = 1 /
        &transition de = 0.01, 0.03 /""")
    assert "natural" in a.stdout and "compiled in" in a.stdout
    close(e, b, EQ_KEYS + ORB_KEYS + ["transition/p_trans", "transition/A_tube"])
    # and the closed forms: saddles at E = 1/6 with lambda = 1, omega = sqrt(3)
    s = e["equilibria/morse_index"] == 1
    assert np.allclose(e["equilibria/energy"][s], 1 / 6, rtol=1e-12)


def test_de_leon_berne(tmp_path, cache):
    _, _, e, b = pair(str(tmp_path), cache, "dlb",
                      f"&model system = 'expression', hamiltonian = '{DLB}', constants = {DLB_CONSTANTS} /",
                      "&model system = 'de_leon_berne' /", """
        &equilibria box = 1.0, 1.5 /
        &orbits saddle_near = 0.0, 0.0, de = 0.05, 0.1 /
        &section kind = 'plane', index = 2, value = 0.7071067811865476, direction = -1 /
        &transition de = 0.05, 0.1 /""")
    close(e, b, EQ_KEYS + ORB_KEYS + ["transition/p_trans"])


def test_cr3bp_gyroscopic(tmp_path, cache):
    tmp = str(tmp_path)
    # the section: the plane x = 0.7 between the Earth and L1, which the L1 tube crosses with dx/dt > 0
    rest = ("&equilibria box = 1.5 /\n&orbits saddle_near = 0.84, 0.0, de = 0.001, 0.002 /\n"
            "&section kind = 'plane', index = 1, value = 0.7, direction = 1 /\n&transition de = 0.001, 0.002 /")
    p = ok(run(tmp, "cr_e.nml", "&run scenes = 'equilibria', 'orbits', 'transition', output = 'cr_e.h5' /\n"
                                f"&model system = 'expression', hamiltonian = '{CR3BP}', "
                                f"constants = 'mu = 0.01215058560962404' /\n{rest}", cache))
    assert "natural" not in p.stdout.splitlines()[0]
    ok(run(tmp, "cr_b.nml", "&run scenes = 'equilibria', 'orbits', 'transition', output = 'cr_b.h5' /\n"
                            f"&model system = 'cr3bp' /\n{rest}", cache))
    e, b = read(tmp, "cr_e.h5"), read(tmp, "cr_b.h5")
    close(e, b, EQ_KEYS + ORB_KEYS + ["transition/p_trans"])


def test_four_well_ball_as_hamiltonian(tmp_path, cache):
    consts = ", ".join(f"'{k} = {v}'" for k, v in PAPER.items())
    _, _, e, b = pair(str(tmp_path), cache, "ball",
                      f"&model system = 'expression', hamiltonian = '{BALL}', constants = {consts} /",
                      "&model system = 'rolling_ball' /", """
        &equilibria box = 20.0 /
        &orbits saddle_near = 0.0, 11.0, de = 100.0, 300.0 /
        &section kind = 'plane', index = 1, value = 8.0, direction = -1 /
        &transition de = 100.0, 300.0 /""")
    close(e, b, EQ_KEYS + ORB_KEYS + ["transition/p_trans"])


def test_ball_on_a_formula_surface(tmp_path, cache):
    """Another parameter set than the paper's, given as the height formula, against the built-in
    surface with the same parameters (the ray section, the saddle between quadrants 1 and 2)."""
    par = {"alpha": 0.08, "beta": 1.2, "gamma": 12.0, "xi": 0.01, "h0": 10.0}
    consts = ", ".join(f"'{k} = {v}'" for k, v in par.items())
    builtin = ", ".join(f"{k} = {v}" for k, v in par.items())
    rest = """
        &orbits saddle_near = 0.0, 11.0, de = 100.0, 300.0 /
        &section kind = 'ray', angle = 45.0, p_theta_sign = 1 /
        &transition de = 100.0, 300.0 /"""
    _, _, e, b = pair(str(tmp_path), cache, "surf",
                      f"&model system = 'rolling_ball', surface = 'expression', height = '{FOURWELL}', "
                      f"constants = {consts} /",
                      f"&model system = 'rolling_ball', {builtin} /", rest)
    close(e, b, EQ_KEYS + ORB_KEYS + ["transition/p_trans", "transition/A_E"])


def test_three_degrees_of_freedom(tmp_path, cache):
    """H = |p|^2/2 - q1^2/2 + q2^2/2 + q3^2: a saddle x centre x centre at 0 with lambda = 1 and
    omega = 1, sqrt(2) (the 3-DOF issue builds on this)."""
    tmp = str(tmp_path)
    p = ok(run(tmp, "three.nml", """
        &run scenes = 'equilibria', 'trajectory', output = 'three.h5' /
        &model system = 'expression', hamiltonian = '(p1^2 + p2^2 + p3^2)/2 - q1^2/2 + q2^2/2 + q3^2',
          coordinates = 'q1', 'q2', 'q3', momenta = 'p1', 'p2', 'p3' /
        &equilibria box = 1.0, n_grid = 5 /
        """.replace("'trajectory', ", ""), cache))
    assert "3 degrees of freedom" in p.stdout
    e = read(tmp, "three.h5")
    assert e["equilibria/morse_index"].tolist() == [1]
    assert abs(e["equilibria/lambda"][0] - 1) < 1e-12
    assert np.allclose(sorted(e["equilibria/omegas"][0]), [1, math.sqrt(2)], rtol=1e-12)


BAD = [
    ("hamiltonian = '(px^2 + py^2)/2 + x^2 y'", "hamiltonian", "syntax error at column"),
    ("hamiltonian = 'px^2/2 + py^2/2 + x^2 + z'", "hamiltonian", "unknown symbol 'z' at column 25"),
    ("hamiltonian = 'px^2/2 + py^2/2 + x^2'", "hamiltonian", "the coordinate 'y' never appears"),
    ("hamiltonian = 'px^2/2 + py^2/2 + abs(x) + y^2'", "hamiltonian", "function 'abs' at column 19"),
    ("hamiltonian = 'px^2/2 + py^2/2 + x^2 + y^2', coordinates = 'x', 'x'", "coordinates",
     "'x' is named twice"),
    ("hamiltonian = 'px^2/2 + py^2/2 + a*x^2 + y^2', constants = 'a = log(0)'", "constants",
     "a = log(0): 'log(0)' at column 1 is not a real number: log needs an argument > 0"),
    ("hamiltonian = 'px^2/2 + py^2/2 + x^2 + y^2', momenta = 'px'", "momenta", "1 momenta for 2"),
    ("hamiltonian = 'px^2/2 + py^2/2 + x^2 + y^2 if x else 0'", "hamiltonian", "a conditional"),
]


@pytest.mark.parametrize("model,var,msg", BAD)
def test_bad_formulas(tmp_path, cache, model, var, msg):
    tmp = str(tmp_path)
    p = run(tmp, "bad.nml", f"&run scenes = 'equilibria', output = 'bad.h5' /\n"
                            f"&model system = 'expression',\n  {model} /\n", cache)
    assert p.returncode == 1, p.stdout + p.stderr
    assert f"bad.nml:3: &model: {var}: " in p.stderr and msg in p.stderr, p.stderr
    assert not any(f.startswith("bad.h5") for f in os.listdir(tmp))


def test_too_long_formula_is_refused(tmp_path, cache):
    p = run(str(tmp_path), "long.nml", "&model system = 'expression', hamiltonian = '"
            + "+".join(["x^2"] * 700) + "' /\n", cache)
    assert p.returncode == 1 and "at most 2047 are allowed" in p.stderr, p.stderr


def test_cache_hit_and_missing_tools(tmp_path):
    tmp = str(tmp_path)
    cache = os.path.join(tmp, "cache")
    text = f"&run scenes = 'equilibria', output = 'c.h5' /\n&model system = 'expression', hamiltonian = '{HH}' /\n"
    # no compiler: a clear error naming it, exit 1, no output
    p = run(tmp, "c.nml", text, cache, env={"TUBES_CC": "/nonexistent/cc"})
    assert p.returncode == 1 and "'/nonexistent/cc' cannot be run" in p.stderr and "TUBES_CC" in p.stderr
    # no Python with SymPy
    p = run(tmp, "c.nml", text, cache, env={"TUBES_PYTHON": "/nonexistent/python"})
    assert p.returncode == 1 and "needs Python 3 with SymPy" in p.stderr, p.stderr
    assert not os.path.exists(os.path.join(tmp, "c.h5"))
    # built once, then loaded
    assert "compiled in" in ok(run(tmp, "c.nml", text, cache)).stdout
    p = ok(run(tmp, "c.nml", text, cache, env={"TUBES_PYTHON": "/nonexistent/python"}))
    assert "loaded from the cache" in p.stdout
    # the library and the SHA-256 its build recorded (docs/cluster.md "The model cache"), nothing else
    assert [f for f in os.listdir(cache) if not f.endswith((".so", ".so.sha256"))] == []


def test_concurrent_builds(tmp_path):
    """Four runs of a new model at once, one cache: each builds or loads a whole library."""
    tmp = str(tmp_path)
    cache = os.path.join(tmp, "cache")
    procs = []
    for k in range(4):
        path = os.path.join(tmp, f"r{k}.nml")
        with open(path, "w") as f:
            f.write(f"&run scenes = 'equilibria', output = 'r{k}.h5' /\n"
                    f"&model system = 'expression', hamiltonian = '{HH} + 0*x*y*px*py', "
                    f"constants = 'c = {k}' /\n&equilibria box = 1.5 /\n")
        procs.append(subprocess.Popen([str(TUBES), path], cwd=tmp, stdout=subprocess.PIPE,
                                      stderr=subprocess.PIPE, text=True,
                                      env=dict(os.environ, TUBES_CACHE_DIR=cache, OMP_NUM_THREADS="1")))
    # constants differ, so these are four models; now the same model four times at once
    for p in procs:
        out, err = p.communicate(timeout=300 * TIMEOUT_SCALE)
        assert p.returncode == 0, err
    procs = [subprocess.Popen([str(TUBES), os.path.join(tmp, "r0.nml"), "-o", f"s{k}.h5"], cwd=tmp,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                              env=dict(os.environ, TUBES_CACHE_DIR=os.path.join(tmp, "c2"),
                                       OMP_NUM_THREADS="1")) for k in range(4)]
    for p in procs:
        out, err = p.communicate(timeout=300 * TIMEOUT_SCALE)
        assert p.returncode == 0, err
    e = [read(tmp, f"s{k}.h5") for k in range(4)]
    for k in range(1, 4):
        close(e[k], e[0], ["equilibria/state", "equilibria/energy"], rel=0)
    # one library and the SHA-256 its build recorded (docs/cluster.md "The model cache")
    lib = sorted(os.listdir(os.path.join(tmp, "c2")))
    assert len(lib) == 2 and lib[0].endswith(".so") and lib[1] == lib[0] + ".sha256", lib


def test_effective_namelist_runs_again(tmp_path, cache):
    """The effective namelist of a formula's run is an input file for the same run."""
    tmp = str(tmp_path)
    ok(run(tmp, "a.nml", f"&run scenes = 'equilibria', output = 'a.h5' /\n&model system = 'expression', "
                         f"hamiltonian = '{DLB}', constants = {DLB_CONSTANTS} /\n&equilibria box = 1.0, 1.5 /\n",
           cache))
    with h5py.File(os.path.join(tmp, "a.h5")) as f:
        text = f.attrs["input_namelist"]
        text = text.decode() if isinstance(text, bytes) else text
        model = dict(f["model"].attrs)
    assert "HAMILTONIAN" in text.upper() and model["system"] in ("expression", b"expression")
    with open(os.path.join(tmp, "again.nml"), "w") as f:
        f.write(text.replace("a.h5", "again.h5"))
    ok(subprocess.run([str(TUBES), "again.nml"], cwd=tmp, capture_output=True, text=True,
                      env=dict(os.environ, TUBES_CACHE_DIR=cache)))
    close(read(tmp, "again.h5"), read(tmp, "a.h5"), ["equilibria/state", "equilibria/energy"], rel=0)


def test_start_where_the_formula_is_not_finite(tmp_path, cache):
    """log(x) at x0 = -1: H is NaN at the start; refused with the point, exit 1, no output."""
    tmp = str(tmp_path)
    p = run(tmp, "nf.nml", """
        &run scenes = 'trajectory', output = 'nf.h5' /
        &model system = 'expression', hamiltonian = '(px^2 + py^2)/2 + log(x) + y^2' /
        &trajectory x0 = -1.0, y0 = 0.0, t_end = 1.0 /
        """, cache)
    assert p.returncode == 1, p.stdout + p.stderr
    assert "&trajectory: the model is not defined at the starting point" in p.stderr
    assert not any(f.startswith("nf.h5") for f in os.listdir(tmp))


def test_python_model_from_a_string_and_from_sympy(tmp_path, monkeypatch):
    """tubes.Model(system='expression', ...) from text and from a SymPy expression: the library's
    numbers of the built-in, through the same reader and cache as the program."""
    monkeypatch.setenv("TUBES_CACHE_DIR", str(tmp_path / "cache"))
    import sympy as sp
    import tubes
    m = tubes.Model(system="expression", hamiltonian=HH)
    b = tubes.Model(system="henon_heiles")
    x = [0.1, 0.2, 0.3, -0.1]
    assert abs(tubes.energy(x, m) - tubes.energy(x, b)) < 1e-15
    assert np.allclose(tubes.vector_field(x, m), tubes.vector_field(x, b), rtol=0, atol=1e-15)
    sec = {"kind": "plane", "index": 2, "value": 0.0, "direction": 1}
    r1 = tubes.transition(m, [0.01, 0.02], saddle_near=(0, 1), section=sec, equilibria={"box": 1.5})
    r2 = tubes.transition(b, [0.01, 0.02], saddle_near=(0, 1), section=sec)
    assert np.allclose(r1["p_trans"], r2["p_trans"], rtol=REL, atol=0)
    # SymPy: symbols and a constant given as a number keep every digit
    x_, y_, px, py, a = sp.symbols("x y px py a")
    h = (px**2 + py**2) / 2 + (x_**2 + y_**2) / 2 + x_**2 * y_ - y_**3 / 3 + a * 0
    s = tubes.Model(system="expression", hamiltonian=h + a * x_**2 - a * x_**2, constants={"a": 0.1})
    assert abs(tubes.energy(x, s) - tubes.energy(x, b)) < 1e-15
    assert s.replace().name == s.name
    with pytest.raises(ValueError, match="function 'abs' at column"):
        tubes.Model(system="expression", hamiltonian="px^2 + py^2 + abs(x) + y")
    # the model of an output file
    assert tubes.Model.of({"model": type("G", (), {"attrs": {
        "system": "expression", "formula": HH, "coordinates": "x y", "momenta": "px py",
        "constants": ""}})()}) == m


def test_the_tutorial_input_file(tmp_path, cache):
    """input/expression.nml (docs/models.md's tutorial) runs through, and its numbers are the
    closed forms: lambda = 1, omega = 1.5, the orbit's action T_po dE, the tube's area the action,
    p_trans = action / A_E, the Monte Carlo check agreeing (the program exits 2 otherwise)."""
    tmp = str(tmp_path)
    p = subprocess.run([str(TUBES), str(ROOT / "input" / "expression.nml"), "-o", "e.h5"], cwd=tmp, capture_output=True,
                       text=True, timeout=300 * TIMEOUT_SCALE, env=dict(os.environ, TUBES_CACHE_DIR=cache))
    assert p.returncode == 0, p.stdout + p.stderr
    with h5py.File(os.path.join(tmp, "e.h5")) as f:
        s = f["equilibria/morse_index"][()] == 1
        assert np.allclose(f["equilibria/lambda"][()][s], 1.0, rtol=1e-12)
        assert np.allclose(f["equilibria/omega"][()][s], 1.5, rtol=1e-12)
        t_po = 2 * math.pi / 1.5
        assert np.allclose(f["orbits/action"][()], t_po * f["orbits/dE"][()], rtol=1e-10)
        assert np.allclose(f["transition/A_tube"][()], t_po * f["transition/dE"][()], rtol=1e-8)
        assert bool(f["montecarlo"].attrs["agrees"])
