"""The vertical and axial families of the spatial Earth–Moon CR3BP at L1 by name (issue 38; docs/orbits.md,
"Branch switching"): `&orbits family = 'vertical'` (the centre mode out of the plane, symmetric single
shooting) and `'axial'` (the branch off the planar Lyapunov family's branch point whose tangent is odd
under the reversor, followed by the general multiple-shooting arc to its first fold), against
independent correctors written here with scipy (velocity form (x, y, z, vx, vy, vz); the program's
state only their guess):

- axial: the orbit through (x0, 0, 0, 0, vy0, vz0) symmetric about the x axis, (x, y, z) ->
  (x, -y, -z), t -> -t: at the half period tau, y = z = vx = 0 again; the energy fixed. Unknowns (x0,
  vy0, vz0, tau), four equations, Newton on a central-difference Jacobian.
- vertical: the orbit through (x0, 0, z0, 0, vy0, 0) symmetric about the xz plane: at tau, y = vx =
  vz = 0 (tau the second crossing of y = 0 of the figure eight: the half period is an unknown, not an
  event); unknowns (x0, z0, vy0, tau).

Asserted: periods and states to 1e-10, the scipy orbits' closure over a full period below 1e-10; the
axial family's two ends at the two branch points (its first step leaves the planar family's branch
point upwards in energy: an energy just below it is not on the branch; it stops at its first fold,
within 2e-9 of the vertical family's branch point, which the monitor locates along 'vertical');
'axial' has a positive tilt (mean of y z over the orbit); 'branch:1' off the vertical family gives the
same orbits (the general branch switch from the other end) and, asked for energies off the family,
stops where its arc closes into a loop instead of running its 2000 steps; the names refused where they
mean nothing. Literature for orientation only (Doedel et al. 2007, IJBC 17, 2625): the axial family A1
joins L1's planar Lyapunov family to its vertical family."""
import numpy as np
import pytest

from _helpers import SPATIAL_CR3BP, newton, run_orbits
from conftest import run_tubes
from cr3bp_velocity import energy, flow

DE_AXIAL = [0.0834, 0.085, 0.09, 0.095, 0.1]


def velocity_form(q):
    """The program's canonical state (x, y, z, px, py, pz) -> (x, y, z, vx, vy, vz)."""
    x, y, z, px, py, pz = q
    return np.array([x, y, z, px + y, py - x, pz])


def correct(start, odd, u, e):
    """Newton on the symmetric orbit: start(u[:-1]) the state at t = 0, u[-1] the half period; the
    components odd of the state vanish at the half period and H = e. Returns u, the period, the
    closure over a full period and the final residual."""
    def f(u):
        s = flow(start(u[:-1]), u[-1])
        return np.array([*s[odd], energy(start(u[:-1])) - e])

    u = newton(f, u, 20)
    s0 = start(u[:-1])
    return u, 2 * u[-1], np.max(np.abs(flow(s0, 2 * u[-1]) - s0)), np.max(np.abs(f(u)))


def axial_start(v):
    return np.array([v[0], 0, 0, 0, v[1], v[2]])


def vertical_start(v):
    return np.array([v[0], 0, v[1], 0, v[2], 0])


# each symmetric start: the components of the state that vanish at the half period (odd) and those
# that are unknowns at t = 0 (free: start's arguments)
SYMMETRY = {axial_start: ([1, 2, 3], [0, 4, 5]), vertical_start: ([1, 3, 5], [0, 2, 4])}


def recorrect(start, o, k):
    """The program's orbit k of o (its state0, period and energy) corrected again by `correct` from
    start (axial_start or vertical_start) at the orbit's energy, the program's state only the guess.
    Returns the velocity form s of the program's state0, then correct's u, period, closure and
    residual."""
    odd, free = SYMMETRY[start]
    s = velocity_form(o["state0"][k])
    return (s, *correct(start, odd, [*s[free], o["period"][k] / 2], o["energy"][k]))


def run(tmp_path, name, fam, des, extra=""):
    def more(f):
        g = f["orbits"]
        b = g["bifurcations"]
        return {"bif": {k: b[k][()] for k in ("kind", "dE")},
                "yz": [np.mean(g[f"orbit_{k:03d}"]["state"][:-1, 1] * g[f"orbit_{k:03d}"]["state"][:-1, 2])
                       if g["converged"][k] else np.nan for k in range(len(des))]}

    return run_orbits(tmp_path, name, SPATIAL_CR3BP,
                      f"saddle = 'L1', family = '{fam}', de = {', '.join(map(repr, des))}{extra}", more=more)


@pytest.fixture(scope="module")
def families(tmp_path_factory):
    d = tmp_path_factory.mktemp("axial")
    return {"axial": run(d, "a", "axial", DE_AXIAL), "vertical": run(d, "v", "vertical", [0.01, 0.05, 0.1]),
            "planar": run(d, "p", "lyapunov", [0.05, 0.1])}


@pytest.mark.slow   # the three runs of the fixture: ~7 s on 2 cores
def test_axial_against_scipy(families):
    r, a = families["axial"]
    # 0.0834 is below the planar family's branch point (not on the branch), 0.1 above the vertical's
    assert r.returncode == 4, r.stdout + r.stderr
    assert list(a["converged"]) == [0, 1, 1, 1, 0]
    assert a["attrs"]["family_name"] == "axial" and "a fold" in a["attrs"]["family_end_reason"]
    for k in (1, 2, 3):
        s, u, t, closure, res = recorrect(axial_start, a, k)
        assert np.max(np.abs(s[[1, 2, 3]])) < 1e-10       # the program's orbit starts on the x axis, vx = 0
        print(f"axial dE = {DE_AXIAL[k]}: T {a['period'][k]:.12f} vs scipy {t:.12f} ({a['period'][k] - t:.1e}); "
              f"x0 {s[0] - u[0]:.1e}, vy0 {s[4] - u[1]:.1e}, vz0 {s[5] - u[2]:.1e}; scipy closure {closure:.1e}; "
              f"vz0 {s[5]:.10f}")
        assert res < 1e-12 and closure < 1e-10
        assert a["period"][k] == pytest.approx(t, abs=1e-10)
        np.testing.assert_allclose(s[[0, 4, 5]], u[:3], rtol=0, atol=1e-10)
        assert abs(s[5]) > 0.1                             # out of the plane
        assert a["yz"][k] > 0                              # the naming: positive tilt


@pytest.mark.slow   # the three runs of the fixture: ~7 s on 2 cores
def test_axial_ends_at_the_two_branch_points(families):
    _, a = families["axial"]
    rv, v = families["vertical"]
    rp, p = families["planar"]
    assert rv.returncode == 0 and rp.returncode == 0, rv.stderr + rp.stderr
    assert v["attrs"]["family_name"] == "vertical" and p["attrs"]["family_name"] == "lyapunov"
    bv = v["bif"]["dE"][v["bif"]["kind"] == 1]
    bp = p["bif"]["dE"][p["bif"]["kind"] == 1]
    assert len(bv) == 1 and len(bp) == 1
    # the start: the planar family's branch point (0.0834 just below it is not on the branch, 0.085 is)
    assert DE_AXIAL[0] < bp[0] < DE_AXIAL[1]
    # the end: the branch's first fold, where it meets the vertical family
    fold = a["bif"]["dE"][a["bif"]["kind"] == 4]
    print(f"planar branch point dE {bp[0]:.13f}, vertical {bv[0]:.13f}, axial fold {fold[0]:.13f} "
          f"({fold[0] - bv[0]:.1e}), family_end_dE {a['attrs']['family_end_dE']:.13f}")
    assert len(fold) == 1 and fold[0] == pytest.approx(bv[0], abs=2e-9)
    assert a["attrs"]["family_end_dE"] == pytest.approx(bv[0], abs=2e-9)


@pytest.mark.slow   # the three runs of the fixture: ~7 s on 2 cores
def test_vertical_against_scipy(families):
    _, v = families["vertical"]
    assert np.all(v["converged"] == 1)
    for k, de in enumerate([0.01, 0.05, 0.1]):
        s, u, t, closure, res = recorrect(vertical_start, v, k)
        assert np.max(np.abs(s[[1, 3, 5]])) == 0           # on the xz plane, vx = vz = 0
        print(f"vertical dE = {de}: T {v['period'][k]:.12f} vs scipy {t:.12f} ({v['period'][k] - t:.1e}); "
              f"x0 {s[0] - u[0]:.1e}, z0 {s[2] - u[1]:.1e}, vy0 {s[4] - u[2]:.1e}; scipy closure {closure:.1e}")
        assert res < 1e-12 and closure < 1e-10
        assert v["period"][k] == pytest.approx(t, abs=1e-10)
        np.testing.assert_allclose(s[[0, 2, 4]], u[:3], rtol=0, atol=1e-10)
        assert abs(s[2]) > 0.01                            # out of the plane
    # the same family as by number (family 1 in the spatial CR3BP: omega_v < omega_p)
    assert v["attrs"]["family"] == -3


@pytest.mark.slow   # ~5 s: two period searches along the vertical family
def test_vertical_by_period_against_scipy(tmp_path):
    """&orbits family = 'vertical', periods = ...: the program's orbit at the dE it finds, corrected
    again by scipy at that orbit's energy (the symmetric corrector above, the program's state only
    its guess), has the period asked for (1e-10); 'lyapunov' (the planar family by name) is found by
    period as family 2 is (the same dE)."""
    ts = [3.0, 3.2]
    r, o = run_orbits(tmp_path, "vp", SPATIAL_CR3BP, f"saddle = 'L1', family = 'vertical', periods = {ts[0]}, {ts[1]}")
    assert r.returncode == 0, r.stderr
    for k, t_star in enumerate(ts):
        _, u, t, closure, res = recorrect(vertical_start, o, k)
        print(f"vertical by period {t_star}: scipy at the program's energy {t:.13f} ({t - t_star:.1e}); "
              f"closure {closure:.1e}")
        assert res < 1e-12 and closure < 1e-10
        assert t == pytest.approx(t_star, abs=1e-10)
    des = []
    for fam in ("'lyapunov'", "2"):
        r, o = run_orbits(tmp_path, "pp", SPATIAL_CR3BP, f"saddle = 'L1', family = {fam}, periods = 2.75")
        assert r.returncode == 0
        des.append(o["dE"][0])
    assert des[0] == des[1]


@pytest.mark.slow
def test_branch_off_the_vertical_family(tmp_path, families):
    """'branch:1' (the general branch switch off family 1, the vertical one, at its first branch point)
    follows the axial family from its other end: the same periods (mirror or not); asked for energies
    off it, its arc closes into a loop (the axial branch and its mirror image) and says so."""
    _, a = families["axial"]
    # the parent's bifurcations are monitored at the same energies: 0.1 brackets the branch point
    r, b = run(tmp_path, "b", "branch:1", [0.085, 0.09, 0.095, 0.1])
    assert r.returncode == 4 and list(b["converged"]) == [1, 1, 1, 0], r.stderr   # 0.1: the other side
    print("branch:1 - axial periods:", b["period"][:3] - a["period"][1:4])
    np.testing.assert_allclose(b["period"][:3], a["period"][1:4], rtol=0, atol=1e-9)
    r, b = run(tmp_path, "c", "branch:1", [0.05, 0.1, 0.15])
    assert r.returncode == 4 and "the arc closed into a loop" in r.stdout
    assert not np.any(b["converged"])
    assert b["attrs"]["family_end_dE"] == pytest.approx(0.0982710948872, abs=2e-9)


def test_names_refused_where_they_mean_nothing(tmp_path):
    (tmp_path / "a.nml").write_text("&run scenes = 'orbits' /\n&model system = 'henon_heiles' /\n"
                                    "&orbits family = 'vertical', de = 0.01 /\n")
    r = run_tubes(["a.nml"], cwd=tmp_path)
    assert r.returncode == 1 and "family = 'vertical' needs 3 degrees of freedom" in r.stderr
    (tmp_path / "b.nml").write_text("&run scenes = 'orbits' /\n&model system = 'cr3bp' /\n"
                                    "&orbits family = 'axial', de = 0.01 /\n")
    r = run_tubes(["b.nml"], cwd=tmp_path)
    assert r.returncode == 1 and "family = 'axial' needs 3 degrees of freedom" in r.stderr
    # 3 DOF whose centre modes mix q2 and q3: no mode out of the plane
    (tmp_path / "c.nml").write_text(
        "&run scenes = 'orbits', output = 'c.h5' /\n&model system = 'expression',\n"
        "  hamiltonian = '(p1^2 + p2^2 + p3^2)/2 - q1^2/2 + q1^4/4 + q2^2/2 + 2*q3^2 + q2*q3',\n"
        "  coordinates = 'q1', 'q2', 'q3', momenta = 'p1', 'p2', 'p3' /\n&equilibria box = 1.2, n_grid = 5 /\n"
        "&orbits saddle_near = 0, 0, 0, family = 'lyapunov', de = 0.01 /\n")
    r = run_tubes(["c.nml"], cwd=tmp_path)
    assert r.returncode == 1 and "no centre mode of the S1 of system 'expression' lies out of the plane" in r.stderr
    # in 2 DOF 'lyapunov' is family 1, bit for bit
    d, e = [run_orbits(tmp_path, name, "&model system = 'henon_heiles' /\n", f"family = {fam}, de = 0.01", timeout=120)
            for name, fam in (("d", "'lyapunov'"), ("e", "1"))]
    assert d[0].returncode == 0 and e[0].returncode == 0
    assert np.array_equal(d[1]["state0"], e[1]["state0"])
    assert d[1]["period"] == e[1]["period"]
    (tmp_path / "f.nml").write_text("&run scenes = 'orbits' /\n&model system = 'cr3bp', spatial = .true. /\n"
                                    "&orbits family = 'axial', guess = 0.9, 0, 0, 0, 0.3, 0.1, period = 4, "
                                    "de = 0.09 /\n")
    r = run_tubes(["f.nml"], cwd=tmp_path)
    assert r.returncode == 1 and "family = 'axial' with a guess" in r.stderr


@pytest.mark.slow
def test_python_orbit_family_by_name(families):
    """orbit_family(family='vertical' | 'axial') goes through the program's reader: the same orbits."""
    import tubes
    m = tubes.Model("cr3bp", spatial=True)
    _, v = families["vertical"]
    r = tubes.orbit_family(m, dE=[0.05], saddle="L1", family="vertical")
    assert r["family_name"] == "vertical" and r["period"][0] == v["period"][1]
    _, a = families["axial"]
    r = tubes.orbit_family(m, dE=[0.09], saddle="L1", family="axial")
    assert r["family_name"] == "axial"
    assert r["period"][0] == pytest.approx(a["period"][2], abs=1e-12)
