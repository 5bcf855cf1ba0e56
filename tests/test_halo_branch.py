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
import numpy as np
import pytest

from _helpers import SPATIAL_CR3BP, run_orbits
from test_axial import axial_start, recorrect, velocity_form, vertical_start

HALO_DE = [0.0069950, 0.0070, 0.0070048, 0.0070132]
AXIAL_DE = [0.08348, 0.08349, 0.0835]
FIT_RTOL = 2e-3   # each amplitude^2 off the fitted line, relative to it (the O((dE - dE_b)^2) term ~1e-4)


def run(tmp_path, name, fam, des):
    return run_orbits(tmp_path, name, SPATIAL_CR3BP, f"saddle = 'L1', family = '{fam}', de = {', '.join(map(repr, des))}")


def line_fit(de, a2):
    """a2 = c (dE - dE_b) by least squares: c, dE_b and each point's relative misfit."""
    c, c0 = np.polyfit(de, a2, 1)
    de_b = -c0 / c
    return c, de_b, np.abs(a2 - c * (de - de_b)) / np.abs(a2)


def agrees_with_scipy(o, des, start, name, amp, j):
    """scipy's corrector at the program's energy (recorrect from start) on each orbit k of o (at
    des[k]): it converges (residual 1e-12) to an orbit that closes over its period (1e-9), whose
    amplitude u[j] is the program's amp[k] (named name; 1e-6 relative) and whose period is the
    program's (1e-10 relative)."""
    for k in range(len(des)):
        _, u, t, closure, res = recorrect(start, o, k)
        print(f"  dE = {des[k]}: program {name} = {amp[k]:.10f}, T = {o['period'][k]:.12f}; scipy {name} = "
              f"{u[j]:.10f}, T = {t:.12f}, closure {closure:.1e}")
        assert res < 1e-12 and closure < 1e-9
        assert u[j] == pytest.approx(amp[k], rel=1e-6)
        assert t == pytest.approx(o["period"][k], rel=1e-10)


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
    agrees_with_scipy(o, HALO_DE, vertical_start, "z0", z0, 1)


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
    agrees_with_scipy(o, AXIAL_DE, axial_start, "vz0", vz0, 2)
