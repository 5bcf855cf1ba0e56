"""The full linear spectrum at every equilibrium (issue 38): /equilibria/frequencies holds the
centre frequencies of each point, ascending (NaN where fewer than N pairs are centres) and
/equilibria/stable marks the points whose pairs are all centres. Checked against closed forms:
the CR3BP's L4/L5 (the characteristic polynomial lambda^4 + lambda^2 + 27/4 mu (1 - mu) = 0 of the
planar problem, and the vertical frequency 1), decoupled harmonic wells, and Hénon–Heiles' well
at the origin (frequencies 1, 1) and its saddles (centre frequency sqrt(3), the Hessian's positive
eigenvalue at (0, 1)); at the saddles the first frequency is also the table's omega (another code
path: linearize)."""
import subprocess

import h5py
import numpy as np
import pytest

from conftest import TUBES


def equilibria(tmp, model):
    (tmp / "e.nml").write_text("&run scenes = 'equilibria', output = 'e.h5' /\n" + model)
    r = subprocess.run([str(TUBES), "e.nml"], cwd=tmp, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    with h5py.File(tmp / "e.h5") as f:
        g = f["equilibria"]
        assert g["frequencies"].attrs["units"] == g["omega"].attrs["units"]   # rad/s, or rad (dimensionless)
        return ({k: g[k][()] for k in ("frequencies", "stable", "omega", "morse_index")},
                [n.decode() if isinstance(n, bytes) else n for n in g["name"][()]], r.stdout)


def l4_frequencies(mu):
    d = np.sqrt(1 - 27 * mu * (1 - mu))
    return np.sqrt([(1 - d) / 2, (1 + d) / 2])


@pytest.mark.parametrize("mu", [0.01215058560962404, 9.5388e-4, 0.03])
@pytest.mark.parametrize("spatial", [False, True])
def test_l4_l5_frequencies_are_the_characteristic_polynomials(tmp_path, mu, spatial):
    t, names, out = equilibria(tmp_path, f"&model system = 'cr3bp', mu = {mu!r}"
                                         + (", spatial = .true." if spatial else "") + " /\n")
    want = np.sort(np.r_[l4_frequencies(mu), [1.0] if spatial else []])
    for p in ("L4", "L5"):
        k = names.index(p)
        assert t["stable"][k] == 1
        np.testing.assert_allclose(t["frequencies"][k], want, rtol=1e-10, err_msg=p)
    for p in ("L1", "L2", "L3"):                               # saddle x centre (x centre): not stable
        k = names.index(p)
        assert t["stable"][k] == 0 and np.isnan(t["frequencies"][k][-1])
        assert t["frequencies"][k][0] == pytest.approx(t["omega"][k], rel=1e-12)
    assert f"{l4_frequencies(mu)[0]:.6f}" in out                # the table's omega column at L4


def test_above_the_routh_value_l4_is_not_stable(tmp_path):
    t, names, _ = equilibria(tmp_path, "&model system = 'cr3bp', mu = 0.1 /\n")   # > 0.0385
    k = names.index("L4")
    assert t["stable"][k] == 0 and np.all(np.isnan(t["frequencies"][k]))   # a complex quartet


def test_harmonic_wells_and_saddles(tmp_path):
    # V = (x^2 - 1)^2 + 2 y^2: wells at x = +-1 with frequencies sqrt(8) (x) and 2 (y); the saddle at
    # the origin has the centre frequency 2 and no second centre
    t, names, _ = equilibria(tmp_path, "&model system = 'expression', hamiltonian = "
                                       "'(px^2 + py^2)/2 + (x^2 - 1)^2 + 2*y^2' /\n&equilibria box = 2 /\n")
    for k, n in enumerate(names):
        if t["morse_index"][k] == 0:
            assert t["stable"][k] == 1
            np.testing.assert_allclose(t["frequencies"][k], [2, np.sqrt(8)], rtol=1e-12)
        else:
            assert t["stable"][k] == 0
            assert t["frequencies"][k][0] == pytest.approx(2, rel=1e-12) and np.isnan(t["frequencies"][k][1])


def test_henon_heiles(tmp_path):
    t, names, _ = equilibria(tmp_path, "&model system = 'henon_heiles' /\n")
    k = names.index("W1")
    assert t["stable"][k] == 1
    np.testing.assert_allclose(t["frequencies"][k], [1, 1], rtol=1e-12)
    for s in ("S1", "S2", "S3"):   # V's Hessian at (0, 1): Vxx = 1 + 2y = 3, Vyy = 1 - 2y = -1
        k = names.index(s)
        assert t["frequencies"][k][0] == pytest.approx(np.sqrt(3), rel=1e-12) and t["stable"][k] == 0


def test_python_gives_the_files_frequencies(tmp_path):
    import tubes
    t, names, _ = equilibria(tmp_path, "&model system = 'cr3bp' /\n")
    eq = tubes.equilibria(tubes.Model(system="cr3bp"))
    assert list(eq["name"]) == names
    np.testing.assert_array_equal(eq["frequencies"], t["frequencies"])
    assert list(eq["stable"]) == [bool(s) for s in t["stable"]]
    np.testing.assert_allclose(eq["frequencies"][names.index("L4")], l4_frequencies(0.01215058560962404), rtol=1e-10)
