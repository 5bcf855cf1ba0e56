"""The flux scene (src/transport/tubes_flux.f90, docs/theory.md "Flux in N degrees of freedom"), through the
executable, against independent references: the closed form of a separable 3-DOF saddle, a 2-D
quadrature where a coupled 3-DOF model keeps {q1 = p1 = 0} invariant, and in 2 DOF the Lyapunov
orbit's action (the orbits scene, another computation). Sampled values within 4 standard errors."""
import math
import os
import subprocess
import textwrap

import h5py
import numpy as np
import pytest
from scipy import integrate

from conftest import TIMEOUT_SCALE, TUBES

SIGMAS = 4


@pytest.fixture(scope="module")
def cache(model_cache):
    return model_cache          # the tests' shared model cache (conftest.py)


def run(tmp, text, cache):
    path = os.path.join(tmp, "f.nml")
    with open(path, "w") as f:
        f.write(textwrap.dedent(text))
    p = subprocess.run([str(TUBES), path], cwd=tmp, capture_output=True, text=True, timeout=300 * TIMEOUT_SCALE,
                       env=dict(os.environ, OMP_NUM_THREADS="2", TUBES_CACHE_DIR=cache))
    return p


def flux_of(tmp):
    with h5py.File(os.path.join(tmp, "f.h5")) as f:
        g = f["flux"]
        out = {k: g[k][()] for k in g if isinstance(g[k], h5py.Dataset)}
        if "orbits" in f:
            out["action"] = f["orbits/action"][()]
        return out


def test_separable_three_dof_saddle(tmp_path, cache):
    """H = |p|^2/2 - q1^2/2 + w2^2 q2^2/2 + w3^2 q3^2/2: f = 2 pi^2 E^2 / (w2 w3) exactly."""
    tmp = str(tmp_path)
    p = run(tmp, """
        &run scenes = 'equilibria', 'flux', output = 'f.h5' /
        &model system = 'expression', hamiltonian = '(p1^2 + p2^2 + p3^2)/2 - q1^2/2 + w2^2*q2^2/2 + w3^2*q3^2/2',
          coordinates = 'q1', 'q2', 'q3', momenta = 'p1', 'p2', 'p3', constants = 'w2 = 1.3', 'w3 = 2.1' /
        &equilibria box = 1.0, n_grid = 5 /
        &flux de = 0.01, 0.2, n_samples = 20000, seed = 3 /
        """, cache)
    assert p.returncode == 0, p.stdout + p.stderr
    f = flux_of(tmp)
    exact = 2 * math.pi**2 * f["dE"] ** 2 / (1.3 * 2.1)
    assert np.allclose(f["flux_leading_order"], exact, rtol=1e-12)
    assert np.all(np.abs(f["flux_sampled"] - exact) < SIGMAS * f["flux_sampled_err"]), (f, exact)
    assert np.all(f["flux_sampled_err"] < 0.03 * exact)
    assert f["n_recrossing"].tolist() == [0, 0] and f["n_undecided"].tolist() == [0, 0]


def test_coupled_three_dof_against_quadrature(tmp_path, cache):
    """Quartic couplings that keep {q1 = p1 = 0} invariant: the NHIM is {q1 = p1 = 0, H = E} and
    the flux is 2 pi times the integral of E - V(0, q2, q3) over {V <= E} (p2, p3 integrated in
    closed form), by scipy's dblquad."""
    w2, w3, c, d, de = 1.0, 1.7, 2.0, 0.5, 0.3
    tmp = str(tmp_path)
    p = run(tmp, f"""
        &run scenes = 'flux', output = 'f.h5' /
        &model system = 'expression',
          hamiltonian = '(p1^2 + p2^2 + p3^2)/2 - q1^2/2 + q1^4/4 + w2^2*q2^2/2 + w3^2*q3^2/2 + c*q2^2*q3^2 + d*q1^2*q2^2',
          coordinates = 'q1', 'q2', 'q3', momenta = 'p1', 'p2', 'p3',
          constants = 'w2 = {w2}', 'w3 = {w3}', 'c = {c}', 'd = {d}' /
        &equilibria box = 1.5, n_grid = 7 /
        &orbits saddle_near = 0, 0, 0 /
        &flux de = {de}, n_samples = 20000, seed = 5, t_max = 40 /
        """, cache)
    assert p.returncode == 0, p.stdout + p.stderr
    f = flux_of(tmp)

    # at fixed q2, V = a + b q3^2: the q3 integral of E - V is (4/3) (E - a)^(3/2) / sqrt(b)
    q2max = math.sqrt(2 * de) / w2
    ref, _ = integrate.quad(lambda q2: 4 / 3 * max(de - w2**2 * q2**2 / 2, 0.0) ** 1.5
                            / math.sqrt(w3**2 / 2 + c * q2**2), -q2max, q2max, epsabs=1e-14, epsrel=1e-12)
    ref *= 2 * math.pi
    assert abs(f["flux_sampled"][0] - ref) < SIGMAS * f["flux_sampled_err"][0], (f, ref)
    # the quartic coupling lowers the flux below the leading order (a real check of the sampling)
    assert ref < 0.95 * f["flux_leading_order"][0]


@pytest.mark.parametrize("model,rest", [
    ("&model system = 'henon_heiles' /", "&orbits saddle_near = 0.0, 1.0, de = 0.001, 0.03 /\n"
                                         "&flux de = 0.001, 0.03, n_samples = 8000 /"),
    ("&model system = 'rolling_ball' /", "&orbits de = 10, 400, 700 /\n&flux de = 10, 400, 700, n_samples = 8000 /"),
])
def test_two_dof_flux_is_the_orbit_action(tmp_path, cache, model, rest):
    """In 2 DOF the flux through the bottleneck is the Lyapunov orbit's action (Green's theorem on
    the tube's cut, computed by the orbits scene): the sampled flux agrees within 4 sigma, also
    at the ball's dE = 400 where it is 4 % above the leading order."""
    tmp = str(tmp_path)
    p = run(tmp, f"&run scenes = 'orbits', 'flux', output = 'f.h5' /\n{model}\n{rest}\n", cache)
    assert p.returncode == 0, p.stdout + p.stderr
    f = flux_of(tmp)
    assert np.all(np.abs(f["flux_sampled"] - f["action"]) < SIGMAS * f["flux_sampled_err"]), f


def test_gyroscopic_built_in_cr3bp_is_sampled(tmp_path, cache):
    """The built-in planar CR3BP (gyroscopic, no formula: no normal form) is sampled as H quadratic
    in the momenta, its past followed backwards: the flux is the Lyapunov orbit's action (the
    orbits scene, shooting) within 4 standard errors. At dE = 0.01 a slab of gate 0.01 is
    narrower than the Lyapunov orbit reaches along x (0.013): refused (exit 2, naming the gate)."""
    tmp = str(tmp_path)
    p = run(tmp, """
        &run scenes = 'flux', output = 'f.h5' /
        &model system = 'cr3bp' /
        &flux de = 0.01, n_samples = 200, gate = 0.01 /
        """, cache)
    assert p.returncode == 2 and "raise gate (&flux" in p.stderr, p.stderr
    p = run(tmp, """
        &run scenes = 'orbits', 'flux', output = 'f.h5' /
        &model system = 'cr3bp' /
        &orbits de = 0.001, 0.01 /
        &flux de = 0.001, 0.01, n_samples = 20000, gate = 0.1 /
        """, cache)
    assert p.returncode == 0, p.stdout + p.stderr
    f = flux_of(tmp)
    assert np.all(np.abs(f["flux_sampled"] - f["action"]) < SIGMAS * f["flux_sampled_err"]), (f["flux_sampled"],
                                                                                            f["action"])
    assert np.all(f["flux_sampled_err"] < 0.02 * f["action"])


def test_too_short_t_max_is_a_failure(tmp_path, cache):
    p = run(str(tmp_path), """
        &run scenes = 'flux', output = 'f.h5' /
        &model system = 'henon_heiles' /
        &flux de = 0.01, n_samples = 500, t_max = 0.01 /
        """, cache)
    assert p.returncode == 2 and "raise &flux t_max" in p.stderr, p.stderr


def test_python_flux_and_families(tmp_path, monkeypatch):
    """tubes.flux and tubes.orbit_family(family=...) reach the same computations from Python."""
    monkeypatch.setenv("TUBES_CACHE_DIR", str(tmp_path / "cache"))
    import tubes
    hh = tubes.Model(system="henon_heiles")
    f = tubes.flux(hh, [0.001, 0.02], saddle_near=(0, 1), n_samples=6000, seed=4)
    act = tubes.orbit_family(hh, [0.001, 0.02], saddle_near=(0, 1))["action"]
    assert np.all(np.abs(f["flux_sampled"] - act) < SIGMAS * f["flux_sampled_err"]), (f, act)
    assert np.allclose(f["flux_leading_order"], 2 * math.pi / math.sqrt(3) * np.array([0.001, 0.02]), rtol=1e-12)
    m = tubes.Model(system="expression", hamiltonian="(p1^2 + p2^2 + p3^2)/2 - q1^2/2 + 1.3^2*q2^2/2 + 2.1^2*q3^2/2",
                    coordinates=("q1", "q2", "q3"), momenta=("p1", "p2", "p3"))
    assert np.allclose(tubes.orbit_family(m, [0.01], family=2)["period"], 2 * math.pi / 2.1, rtol=1e-12)
    with pytest.raises(ValueError, match="family = 3 is out of range"):
        tubes.orbit_family(m, [0.01], family=3)


def test_a_hamiltonian_not_quadratic_in_the_momenta_is_not_sampled(tmp_path, cache):
    """H = sqrt(1 + |p|^2) + V(q): the dividing surface's momenta are no ellipsoid, so the sampler
    refuses; without &flux order nothing can be computed: exit 2 with the reason."""
    p = run(str(tmp_path), """
        &run scenes = 'flux', output = 'f.h5' /
        &model system = 'expression', hamiltonian = 'sqrt(1 + px^2 + py^2) - x^2/2 + x^4/4 + y^2',
          coordinates = 'x', 'y', momenta = 'px', 'py' /
        &equilibria box = 1.0 /
        &orbits saddle_near = 0, 0 /
        &flux de = 0.01, n_samples = 200 /
        """, cache)
    assert p.returncode == 2 and "not quadratic in the momenta" in p.stderr and "give &flux order" in p.stderr, p.stderr


def test_past_the_bottleneck_the_flux_is_refused(tmp_path, cache):
    """The ball's S12 bottleneck is one up to the central maximum R1, 777.06 (cm/s)^2 above the
    saddle (R1's E - S12's E from the equilibria: the closed-form check is the two energies), where
    the Lyapunov family ends too. Above it the dividing surface's {V <= E} runs over R1 into the
    opposite neck, and its 'flux' (1228 at dE = 800, exit 0, before) is not the bottleneck's: NaN,
    status 'past the end', exit 4 (partial); below it the flux stands."""
    p = run(str(tmp_path), """
        &run scenes = 'equilibria', 'flux', output = 'f.h5' /
        &flux de = 700, 770, 785, 800, n_samples = 200 /
        """, cache)
    assert p.returncode == 4 and "dE = 785 is past the bottleneck of S12" in p.stderr, p.stderr
    with h5py.File(os.path.join(str(tmp_path), "f.h5")) as f:
        names = [n.decode() for n in f["equilibria/name"][:]]
        e = f["equilibria/energy"][:]
        top = e[names.index("R1")] - e[names.index("S12")]
    assert 770 < top < 785
    fl = flux_of(str(tmp_path))
    assert list(fl["status"]) == [0, 0, -10, -10]
    assert np.all(np.isfinite(fl["flux_sampled"][:2])) and np.all(np.isnan(fl["flux_sampled"][2:]))
