"""Dissipation beyond the ball (docs/dissipation.md, "Other models"): viscous damping on any
natural model. The damped coupled-quartic system's transition region against a brute-force count
made here, independently of the program (its equations written out, a vectorised RK4 in numpy,
its own saddle, well frequency, section sampling and transit test); the same model written as a
formula gives the built-in's numbers; a model that is not natural has no damping to offer."""
import math

import h5py
import numpy as np
import pytest

from conftest import run_tubes

# coupled_quartic with its defaults (src/models/tubes_models.f90): m_a = m_b = 1, alpha = beta =
# omega = 1, eps = 0.1; H = (px^2 + py^2)/2 - x^2/2 + x^4/4 + y^2/2 + eps (x - y)^2/2
EPS = 0.1
X_SEC = -1.0        # its default section: x = -1, dx/dt > 0 (the left well's side)
GATE = 0.1          # its default gate: 0.1 past the saddle along the neck


def _pot(x, y):
    return -x * x / 2 + x ** 4 / 4 + y * y / 2 + EPS * (x - y) ** 2 / 2


def _rhs(X, c):
    x, y, px, py = X
    return np.array([px, py, x - x ** 3 - EPS * (x - y) - c * px, -y + EPS * (x - y) - c * py])


def _hess(x, y):
    return np.array([[-1 + 3 * x * x + EPS, -EPS], [-EPS, 1 + EPS]])


def _omega1():
    """The well's slow mode (unit masses: sqrt of the Hessian's lower eigenvalue at the minimum,
    x^2 = 1 - eps + eps/(1 + eps), y = eps x/(1 + eps))."""
    x = -math.sqrt(1 - EPS + EPS * EPS / (1 + EPS))
    y = EPS * x / (1 + EPS)
    g = np.array([-x + x ** 3 + EPS * (x - y), y - EPS * (x - y)])
    assert np.max(np.abs(g)) < 1e-14
    return math.sqrt(np.linalg.eigvalsh(_hess(x, y))[0])


def _neck():
    """The saddle is the origin (energy 0); the neck's direction: the Hessian's negative
    eigenvector, pointing away from the section's well (+x)."""
    w, v = np.linalg.eigh(_hess(0.0, 0.0))
    assert w[0] < 0 < w[1]
    return v[:, 0] * np.sign(v[0, 0])


NRM = _neck()


def _brute_fraction(c, de, n, seed, dt=5e-3, t_max=200.0):
    """The fraction of n points uniform on the section's energy surface at dE that pass the gate
    before they meet the section again; a point whose energy falls below the saddle's before the
    gate can never pass it (dE/dt = -c |p|^2 <= 0): no transit."""
    rng = np.random.default_rng(seed)
    y, py = np.empty(0), np.empty(0)
    while y.size < n:
        yy, pp = rng.uniform(-1.5, 1.5, 8 * n), rng.uniform(-2.0, 2.0, 8 * n)
        ok = 2 * (de - _pot(X_SEC, yy)) - pp * pp > 0
        y, py = np.concatenate([y, yy[ok]]), np.concatenate([py, pp[ok]])
    y, py = y[:n], py[:n]
    px = np.sqrt(2 * (de - _pot(X_SEC, y)) - py * py)
    X = np.array([np.full(n, X_SEC), y, px, py])
    out = np.full(n, 2)
    act = np.ones(n, bool)
    t = 0.0
    while t < t_max and act.any():
        i = np.flatnonzero(act)
        Y = X[:, i]
        k1 = _rhs(Y, c)
        k2 = _rhs(Y + dt / 2 * k1, c)
        k3 = _rhs(Y + dt / 2 * k2, c)
        k4 = _rhs(Y + dt * k3, c)
        Z = Y + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        X[:, i] = Z
        t += dt
        gone = (Z[:2].T @ NRM) > GATE
        back = (Y[0] < X_SEC) & (Z[0] >= X_SEC)
        low = (Z[2] ** 2 + Z[3] ** 2) / 2 + _pot(Z[0], Z[1]) < 0
        out[i[gone]] = 1
        out[i[(back | low) & ~gone]] = 0
        act[i[gone | back | low]] = False
    assert np.sum(out == 2) == 0
    return np.mean(out == 1)


def _run(tmp_path, name, text):
    (tmp_path / f"{name}.nml").write_text(text)
    r = run_tubes([f"{name}.nml", "-o", f"{name}.h5"], tmp_path, timeout=300)
    assert r.returncode == 0, r.stderr
    with h5py.File(tmp_path / f"{name}.h5") as f:
        g = f["transition"]
        return {k: g[k][()] for k in g} | {k: g.attrs[k] for k in g.attrs}, r.stdout


ZETA = 0.05
DES = (0.05, 0.2)


@pytest.fixture(scope="module")
def quartic(tmp_path_factory):
    return _run(tmp_path_factory.mktemp("quartic"), "q",
                "&run scenes = 'transition' /\n"
                f"&model system = 'coupled_quartic', damping_ratio = {ZETA} /\n"
                f"&transition de = 0.02, {', '.join(map(str, DES))} /\n")[0]


def test_the_damped_quartic_is_the_brute_force_count(quartic):
    """p_trans of the damped coupled-quartic system within 4 standard errors of 4000 section points
    integrated here, at two energies; below the threshold (dE = 0.02 at zeta = 0.05) the region is
    empty (it appears at dE = 0.0451) and not one of 2000 points transits."""
    c = 2 * ZETA * _omega1()
    assert quartic["damping_rate"] == pytest.approx(c, rel=1e-12)
    for k, de in enumerate(DES):
        p = quartic["p_trans"][k + 1]
        f = _brute_fraction(c, de, 4000, seed=11 + k)
        se = math.sqrt(p * (1 - p) / 4000)
        print(f"dE {de}: program {p:.6f}, brute force {f:.5f} ({(f - p) / se:+.2f} se)")
        assert 0 < p < quartic["p_trans_conservative"][k + 1]
        assert abs(f - p) <= 4 * se, (de, f, p, se)
    assert quartic["p_trans"][0] == 0 and quartic["dE_threshold_lo"] > 0.02
    assert _brute_fraction(c, 0.02, 2000, seed=3) == 0


def test_the_formula_gives_the_built_ins_numbers(tmp_path, quartic):
    """The same model written as a formula (its own generated code, its own parameter table) gives
    the built-in's damping rate, and its region's areas to 1e-7 (two integrations of the same
    trajectories, each to 1e-12)."""
    got, _ = _run(tmp_path, "f",
                  "&run scenes = 'transition' /\n"
                  "&model system = 'expression', hamiltonian = '(px^2 + py^2)/2 - x^2/2 + x^4/4 + y^2/2 "
                  f"+ {EPS}*(x - y)^2/2', damping_ratio = {ZETA} /\n"
                  "&orbits saddle_near = 0, 0 /\n"
                  "&section kind = 'plane', index = 1, value = -1, direction = 1 /\n"
                  f"&transition de = 0.02, {', '.join(map(str, DES))} /\n")
    assert got["damping_rate"] == pytest.approx(quartic["damping_rate"], rel=1e-12)
    np.testing.assert_allclose(got["A_region"][1:], quartic["A_region"][1:], rtol=1e-7)
    assert got["p_trans"][0] == 0


def test_a_model_that_is_not_natural_has_no_damping(tmp_path):
    """The CR3BP's momenta are not velocities (H has y px - x py): -c p would be no friction.
    It has no damping_ratio, and the reader says so."""
    (tmp_path / "c.nml").write_text("&run scenes = 'transition' /\n&model system = 'cr3bp', damping_ratio = 0.01 /\n")
    r = run_tubes(["c.nml"], tmp_path)
    assert r.returncode == 1 and "damping_ratio is not a parameter of system 'cr3bp'" in r.stderr


def test_a_model_without_a_well_has_no_damping_ratio(tmp_path):
    """c = 2 zeta omega_1 needs a well: a pure saddle (no minimum) with damping_ratio is refused
    before any scene runs (exit 1, no output file), naming the file and the variable."""
    (tmp_path / "w.nml").write_text(
        "&run scenes = 'transition' /\n"
        "&model system = 'expression', hamiltonian = '(px^2 + py^2)/2 - x^2/2 + y^2/2', damping_ratio = 0.01 /\n"
        "&orbits saddle_near = 0, 0 /\n&section kind = 'plane', index = 1, value = -0.5, direction = 1 /\n"
        "&transition de = 0.1 /\n")
    r = run_tubes(["w.nml", "-o", "w.h5"], tmp_path)
    assert r.returncode == 1 and "w.nml: &model damping_ratio: the model has no well" in r.stderr
    assert "p_trans" not in r.stdout and not (tmp_path / "w.h5").exists()
