"""Branch switching onto the halo families of the Earth–Moon CR3BP (issue 38; docs/orbits.md,
"Branch switching"): `&orbits family = 'halo_north'` / `'halo_south'` at L1 and L2, against an
independent symmetric corrector written here with scipy (velocity form (x, y, z, vx, vy, vz), the
orbit through (x0, 0, z0, 0, vy0, 0) with y = vx = vz = 0 at the half-period crossing of y = 0 and
the energy fixed; Newton on a finite-difference Jacobian; the program's state0 only as the guess).
Measured: the periods agree to 3e-13 .. 4e-12, x0 and z0 to 6e-12, the scipy orbits close to 2e-12.
Asserted: the period, x0 and z0 to 1e-10, the scipy orbit's closure over a full period below 1e-10
(and the program's orbit satisfies scipy's conditions to 1e-12), the north and south families mirror images (z0 -> -z0, the same period to 1e-12), north's
larger excursion in z positive (south's negative: the conventional naming), and the halo orbits
out of the plane (|z0| growing with dE) on the planar family's side of the branch point
(dE above the branch point the bifurcation monitor locates)."""
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from _helpers import SPATIAL_CR3BP, newton, run_orbits
from conftest import run_tubes
from cr3bp_velocity import MU, TOL, energy, rhs


def half(u):
    """(x0, z0, vy0) -> the state at the next crossing of y = 0 and its time."""
    ev = lambda t, s: s[1]
    ev.terminal, ev.direction = True, -np.sign(u[2])
    r = solve_ivp(rhs, (0, 20), [u[0], 0, u[1], 0, u[2], 0], events=ev, **TOL)
    assert r.status == 1
    return r.t_events[0][0], r.y_events[0][0]


def correct(u, e):
    """The symmetric orbit of energy e near u = (x0, z0, vy0): vx = vz = 0 at the half period, and
    H = e (the crossing time is the event's, so three conditions in three unknowns)."""
    def f(u):
        _, s = half(u)
        return np.array([s[3], s[5], energy([u[0], 0, u[1], 0, u[2], 0]) - e])

    u = newton(f, u, 30)
    th, _ = half(u)
    s0 = [u[0], 0, u[1], 0, u[2], 0]
    end = solve_ivp(rhs, (0, 2 * th), s0, **TOL).y[:, -1]
    return u, 2 * th, np.max(np.abs(end - s0)), np.max(np.abs(f(u)))


def run(tmp_path, saddle, fam, des, name):
    def more(f):
        z = [f["orbits"][f"orbit_{k:03d}"]["state"][:, 2] for k in range(len(des))]
        return {"zmax": np.array([v.max() for v in z]), "zmin": np.array([v.min() for v in z])}

    r, out = run_orbits(tmp_path, name, SPATIAL_CR3BP,
                        f"saddle = '{saddle}', family = '{fam}', de = {', '.join(map(repr, des))}", more=more)
    assert r.returncode == 0, r.stderr
    assert f"{saddle} {fam} family" in r.stdout
    assert out["attrs"]["family_name"] == fam
    return out


@pytest.mark.parametrize("saddle,des,de_branch", [("L1", [0.008, 0.01, 0.015], 0.0069945818),
                                                   ("L2", [0.011, 0.015, 0.02], 0.0100207789)])
def test_halo_against_scipy(tmp_path, saddle, des, de_branch):
    n = run(tmp_path, saddle, "halo_north", des, "n")
    s = run(tmp_path, saddle, "halo_south", des, "s")
    assert np.all(n["converged"] == 1) and np.all(s["converged"] == 1)
    assert min(des) > de_branch
    # north: the larger excursion in z is positive (the extremes are the two xz-plane crossings)
    assert np.all(n["zmax"] > -n["zmin"]) and np.all(s["zmin"] < -s["zmax"])
    assert np.all(np.diff(n["zmax"]) > 0) and n["zmax"][0] > 0.01         # out of the plane, growing
    z = n["state0"][:, 2]
    np.testing.assert_allclose(s["state0"][:, 2], -z, rtol=1e-9)           # the mirror image
    np.testing.assert_allclose(s["period"], n["period"], rtol=1e-12)
    for k in range(len(des)):
        x0, z0, py0 = n["state0"][k, [0, 2, 4]]
        u, t, closure, res = correct([x0, z0, py0 - x0], n["energy"][k])   # vy = py - x
        print(f"{saddle} dE = {des[k]}: T {n['period'][k]:.12f} vs scipy {t:.12f} ({n['period'][k] - t:.1e}); "
              f"x0 {x0 - u[0]:.1e}, z0 {z0 - u[1]:.1e}; scipy closure {closure:.1e}")
        assert res < 1e-12 and closure < 1e-10
        assert n["period"][k] == pytest.approx(t, abs=1e-10)
        assert x0 == pytest.approx(u[0], abs=1e-10) and z0 == pytest.approx(u[1], abs=1e-10)


def test_halo_refused_where_it_makes_no_sense(tmp_path):
    (tmp_path / "a.nml").write_text("&run scenes = 'orbits' /\n&model system = 'cr3bp' /\n"
                                    "&orbits family = 'halo_north', de = 0.01 /\n")
    r = run_tubes(["a.nml"], cwd=tmp_path)
    assert r.returncode != 0 and "needs 3 degrees of freedom" in r.stderr
    (tmp_path / "b.nml").write_text("&run scenes = 'orbits' /\n&model system = 'cr3bp', spatial = .true. /\n"
                                    "&orbits family = 'halo_east', de = 0.01 /\n")
    r = run_tubes(["b.nml"], cwd=tmp_path)
    assert r.returncode != 0 and "family: the name is not one of the families" in r.stderr
    (tmp_path / "c.nml").write_text("&run scenes = 'orbits' /\n&model system = 'cr3bp', spatial = .true. /\n"
                                    "&orbits family = 'halo_south', method = 'multiple', de = 0.01 /\n")
    r = run_tubes(["c.nml"], cwd=tmp_path)
    assert r.returncode != 0 and "method = 'multiple' is not supported" in r.stderr


def test_halo_below_the_branch_point(tmp_path):
    """All requested energies below the L1 branch point (dE ~ 0.006995): no halo orbit there."""
    r, _ = run_orbits(tmp_path, "c", SPATIAL_CR3BP, "family = 'halo_north', de = 0.002, 0.004", timeout=120)
    assert r.returncode == 4, r.stdout + r.stderr
    assert "no branch point below the largest dE" in r.stdout + r.stderr
