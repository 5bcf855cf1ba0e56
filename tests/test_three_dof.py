"""Three degrees of freedom (issue 15, first steps), through the executable: the N - 1 Lyapunov
families of a saddle x centre x centre (&orbits family), and the spatial restricted three-body
problem written as a formula: L1's lambda and its planar and vertical frequencies against the
linear theory, and each family's period as its amplitude goes to 0."""
import math
import os
import subprocess
import textwrap

import h5py
import numpy as np
import pytest
from scipy.optimize import brentq

from conftest import TIMEOUT_SCALE, TUBES

MU = 0.01215058560962404
SPATIAL = ("(px^2 + py^2 + pz^2)/2 + y*px - x*py - (1 - mu)/sqrt((x + mu)^2 + y^2 + z^2) "
           "- mu/sqrt((x - 1 + mu)^2 + y^2 + z^2)")


@pytest.fixture(scope="module")
def cache(model_cache):
    return model_cache          # the tests' shared model cache (conftest.py)


def run(tmp, name, text, cache):
    path = os.path.join(tmp, name)
    with open(path, "w") as f:
        f.write(textwrap.dedent(text))
    p = subprocess.run([str(TUBES), path], cwd=tmp, capture_output=True, text=True, timeout=300 * TIMEOUT_SCALE,
                       env=dict(os.environ, OMP_NUM_THREADS="1", TUBES_CACHE_DIR=cache))
    assert p.returncode == 0, p.stdout + p.stderr
    return h5py.File(os.path.join(tmp, name.replace(".nml", ".h5")), "r")


def l1_linear_theory():
    """L1 of the CR3BP, c2 = (1 - mu)/r1^3 + mu/r2^3, and lambda, omega_planar, omega_vertical
    (Szebehely 1967; Koon, Lo, Marsden and Ross 2011, ch. 2 and 6)."""
    def dx(x):
        return x - (1 - MU) * (x + MU) / abs(x + MU) ** 3 - MU * (x - 1 + MU) / abs(x - 1 + MU) ** 3
    x = brentq(dx, 0.5, 1 - MU - 1e-3, xtol=1e-15)
    c2 = (1 - MU) / abs(x + MU) ** 3 + MU / abs(x - 1 + MU) ** 3
    root = math.sqrt(9 * c2**2 - 8 * c2)
    return x, math.sqrt((c2 - 2 + root) / 2), math.sqrt((2 - c2 + root) / 2), math.sqrt(c2)


def test_both_lyapunov_families_of_a_separable_saddle(tmp_path, cache):
    tmp = str(tmp_path)
    for fam, w in ((1, 1.3), (2, 2.1)):
        f = run(tmp, f"s{fam}.nml", f"""
            &run scenes = 'orbits', output = 's{fam}.h5' /
            &model system = 'expression', hamiltonian = '(p1^2 + p2^2 + p3^2)/2 - q1^2/2 + 1.3^2*q2^2/2 + 2.1^2*q3^2/2',
              coordinates = 'q1', 'q2', 'q3', momenta = 'p1', 'p2', 'p3' /
            &equilibria box = 1.0, n_grid = 5 /
            &orbits de = 0.01, 0.1, family = {fam} /
            """, cache)
        assert np.allclose(f["orbits/period"][()], 2 * math.pi / w, rtol=1e-12)
        assert np.allclose(f["orbits/action"][()], 2 * math.pi / w * f["orbits/dE"][()], rtol=1e-12)
        assert f["orbits/state0"].shape == (2, 6) and int(f["orbits"].attrs["family"]) == fam


def test_spatial_cr3bp_l1(tmp_path, cache):
    x1, lam, wp, wv = l1_linear_theory()
    tmp = str(tmp_path)
    periods = {}
    for fam in (1, 2):
        f = run(tmp, f"c{fam}.nml", f"""
            &run scenes = 'equilibria', 'orbits', output = 'c{fam}.h5' /
            &model system = 'expression', hamiltonian = '{SPATIAL}', coordinates = 'x', 'y', 'z',
              constants = 'mu = {MU!r}' /
            &equilibria box = 1.5, 1.5, 0.3, n_grid = 31 /
            &orbits saddle_near = 0.84, 0.0, 0.0, de = 1e-8, 1e-4, family = {fam} /
            """, cache)
        k = int(np.argmin(np.abs(f["equilibria/state"][:, 0] - x1) + np.abs(f["equilibria/state"][:, 1])))
        assert abs(f["equilibria/state"][k, 0] - x1) < 1e-12
        assert abs(f["equilibria/lambda"][k] - lam) < 1e-10 * lam
        # ascending: the vertical frequency is the lower at Earth-Moon L1
        assert np.allclose(f["equilibria/omegas"][k], [wv, wp], rtol=1e-10)
        z_amp = abs(f["orbits/state0"][0, 2])
        periods[fam] = f["orbits/period"][()]
        if fam == 1:
            assert z_amp > 1e-5          # the vertical family leaves the plane
        else:
            assert z_amp == 0            # the planar family stays in it
    # the period tends to 2 pi / omega as the amplitude goes to 0 (dE = 1e-8: amplitude ~ 1e-4)
    assert abs(periods[1][0] - 2 * math.pi / wv) < 1e-7 * 2 * math.pi / wv
    assert abs(periods[2][0] - 2 * math.pi / wp) < 1e-7 * 2 * math.pi / wp
    # and moves away from it as dE grows: an actual family, not the linear orbit repeated
    assert abs(periods[1][1] - 2 * math.pi / wv) > 1e-5


def test_the_built_in_spatial_cr3bp(tmp_path, cache):
    """&model system = 'cr3bp', spatial = .true. (the library's cr3bp_spatial, written in Fortran)
    against the same problem written as a formula (SymPy's derivatives) and the linear theory:
    L1's state, lambda and both frequencies, and both families' periods and energies, to 1e-10
    (actions to 1e-12 absolute);
    /model names cr3bp_spatial (tubes.Model.of rebuilds it); spatial on another system is refused."""
    x1, lam, wp, wv = l1_linear_theory()
    tmp = str(tmp_path)
    rest = """
        &equilibria box = 1.5, 1.5, 0.3, n_grid = 31 /
        &orbits saddle_near = 0.84, 0.0, 0.0, de = 1e-6, 1e-3, family = {fam} /
        """
    for fam in (1, 2):
        b = run(tmp, f"b{fam}.nml", f"&run scenes = 'equilibria', 'orbits', output = 'b{fam}.h5' /\n"
                f"&model system = 'cr3bp', spatial = .true. /\n" + rest.format(fam=fam), cache)
        e = run(tmp, f"e{fam}.nml", f"&run scenes = 'equilibria', 'orbits', output = 'e{fam}.h5' /\n"
                f"&model system = 'expression', hamiltonian = '{SPATIAL}', coordinates = 'x', 'y', 'z', "
                f"constants = 'mu = {MU!r}' /\n" + rest.format(fam=fam), cache)
        k = int(np.argmin(np.abs(b["equilibria/state"][:, 0] - x1) + np.abs(b["equilibria/state"][:, 1])))
        assert abs(b["equilibria/state"][k, 0] - x1) < 1e-12
        assert abs(b["equilibria/lambda"][k] / lam - 1) < 1e-10
        assert np.allclose(b["equilibria/omegas"][k], [wv, wp], rtol=1e-10)
        for key in ("period", "energy"):
            np.testing.assert_allclose(b[f"orbits/{key}"][()], e[f"orbits/{key}"][()], rtol=1e-10, atol=1e-14)
        # the action of an orbit of amplitude ~1e-3 carries the corrector's tolerance (1e-11 in the state)
        np.testing.assert_allclose(b["orbits/action"][()], e["orbits/action"][()], rtol=0, atol=1e-12)
        assert b["model"].attrs["system"] == "cr3bp_spatial" and int(b["model"].attrs["ndof"]) == 3
    with open(os.path.join(tmp, "bad.nml"), "w") as f:
        f.write("&model system = 'henon_heiles', spatial = .true. /\n")
    p = subprocess.run([str(TUBES), "bad.nml"], cwd=tmp, capture_output=True, text=True, timeout=60)
    assert p.returncode == 1 and "spatial is not a parameter of system 'henon_heiles'" in p.stderr, p.stderr
