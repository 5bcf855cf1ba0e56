"""The halo and axial branches just above their branch points (issue 38; docs/orbits.md, "Branch
switching"): every orbit returned on a branch is on that branch, not the parent (planar Lyapunov)
family's orbit at the same energy, nor the mirror branch's. Before the fix, the corrector at a
requested energy started from the chord between two arc points (linear in energy, while the energy
moves quadratically off a branch point) and returned at L1 the planar orbit for 'halo_north' at
dE = 0.006995 and 0.0070048 (z0 ~ 1e-13), the south halo at 0.007, and the planar orbit for
'axial' at 0.0835 (v_z0 ~ 1e-14), all with exit 0.

Independent references: (1) the normal form of a pitchfork: the branch's out-of-plane amplitude
grows like sqrt(dE - dE_b), so z0^2 (halo) and v_z0^2 (axial) are linear in dE near the branch point
(the next term is O((dE - dE_b)^2), relative ~1e-4 over these energies: measured from the L1 halo's
z0 at dE = 0.00826, 0.7 % off the line at dE - dE_b = 1.3e-3); the line is fitted here to the
program's orbits (its slope and dE_b the fit's own), each orbit within FIT_RTOL of it; (2) the
halo_south orbits are the mirror images z -> -z of the halo_north ones; (3) each orbit corrected
again by the scipy corrector of tests/test_axial.py at the program's energy (the program's state
only its guess): the same |z0| (|v_z0|) and period."""
import h5py
import numpy as np
import pytest

from conftest import run_tubes
from test_axial import axial_start, correct, vertical_start, velocity_form

HALO_DE = [0.0069950, 0.0070, 0.0070048, 0.0070132]
AXIAL_DE = [0.08348, 0.08349, 0.0835]
FIT_RTOL = 2e-3   # each amplitude^2 off the fitted line, relative to it (the O((dE - dE_b)^2) term ~1e-4)


def run(tmp_path, name, fam, des):
    (tmp_path / f"{name}.nml").write_text(
        f"&run scenes = 'orbits', output = '{name}.h5' /\n&model system = 'cr3bp', spatial = .true. /\n"
        f"&orbits saddle = 'L1', family = '{fam}', de = {', '.join(map(repr, des))} /\n")
    r = run_tubes([f"{name}.nml"], cwd=tmp_path, timeout=300)
    with h5py.File(tmp_path / f"{name}.h5") as f:
        g = f["orbits"]
        out = {k: g[k][()] for k in ("dE", "energy", "period", "state0", "converged")}
    return r, out


def line_fit(de, a2):
    """a2 = c (dE - dE_b) by least squares: c, dE_b and each point's relative misfit."""
    c, c0 = np.polyfit(de, a2, 1)
    de_b = -c0 / c
    return c, de_b, np.abs(a2 - c * (de - de_b)) / np.abs(a2)


@pytest.mark.slow   # ~15 s: two halo runs, eight scipy corrections
def test_halo_just_above_its_branch_point(tmp_path):
    r, o = run(tmp_path, "n", "halo_north", HALO_DE)
    assert r.returncode == 0, r.stderr
    assert np.all(o["converged"] == 1)
    z0 = o["state0"][:, 2]
    # north: z0 (at the orbit's start on the x-z plane) negative, its other crossing's z positive and larger
    assert np.all(z0 < -1e-4), z0
    c, de_b, mis = line_fit(o["dE"], z0**2)
    print(f"halo_north: z0 = {z0}, z0^2 = {c:.6f} (dE - {de_b:.10f}), misfit {mis.max():.1e}")
    assert 0.006994 < de_b < HALO_DE[0]
    assert mis.max() < FIT_RTOL
    # the mirror branch
    rs, s = run(tmp_path, "s", "halo_south", HALO_DE)
    assert rs.returncode == 0, rs.stderr
    assert np.all(s["converged"] == 1)
    np.testing.assert_allclose(s["state0"][:, 2], -z0, rtol=1e-7)
    np.testing.assert_allclose(s["period"], o["period"], rtol=1e-12)
    # scipy's corrector at the program's energy
    for k in range(len(HALO_DE)):
        v = velocity_form(o["state0"][k])
        u, t, closure, res = correct(vertical_start, [1, 3, 5], [v[0], v[2], v[4], o["period"][k] / 2],
                                     o["energy"][k])
        print(f"  dE = {HALO_DE[k]}: program z0 = {z0[k]:.10f}, T = {o['period'][k]:.12f}; scipy z0 = {u[1]:.10f}, "
              f"T = {t:.12f}, closure {closure:.1e}")
        assert res < 1e-12 and closure < 1e-9
        assert u[1] == pytest.approx(z0[k], rel=1e-6)
        assert t == pytest.approx(o["period"][k], rel=1e-10)


@pytest.mark.slow   # ~10 s: the planar family, its branch point, the axial arc
def test_axial_just_above_its_branch_point(tmp_path):
    r, o = run(tmp_path, "a", "axial", AXIAL_DE)
    assert r.returncode == 0, r.stderr
    assert np.all(o["converged"] == 1)
    vz0 = velocity_form(o["state0"].T)[5]
    assert np.all(np.abs(vz0) > 1e-3), vz0
    assert np.all(np.sign(vz0) == np.sign(vz0[0]))
    c, de_b, mis = line_fit(o["dE"], vz0**2)
    print(f"axial: vz0 = {vz0}, vz0^2 = {c:.6f} (dE - {de_b:.10f}), misfit {mis.max():.1e}")
    assert 0.0834 < de_b < AXIAL_DE[0]
    assert mis.max() < FIT_RTOL
    for k in range(len(AXIAL_DE)):
        v = velocity_form(o["state0"][k])
        u, t, closure, res = correct(axial_start, [1, 2, 3], [v[0], v[4], v[5], o["period"][k] / 2], o["energy"][k])
        print(f"  dE = {AXIAL_DE[k]}: program vz0 = {vz0[k]:.10f}; scipy vz0 = {u[2]:.10f}, T = {t:.12f}, "
              f"closure {closure:.1e}")
        assert res < 1e-12 and closure < 1e-9
        assert u[2] == pytest.approx(vz0[k], rel=1e-6)
        assert t == pytest.approx(o["period"][k], rel=1e-10)
