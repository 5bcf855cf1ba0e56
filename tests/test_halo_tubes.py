"""Tubes of halo orbits (issue 38; docs/tubes.md, "Tubes of halo orbits"): the stable and unstable
manifolds of the Earth–Moon L1 northern halo orbit at dE = 0.01, cut by the Moon's plane
x = 1 - mu, checked against values computed here with scipy from the program's orbit state alone:

- the monodromy matrix recomputed by solve_ivp with the variational equations (the Jacobian written
  here), its eigenvectors for the stable and unstable multipliers; each checked seed rebuilt from
  them (the orbit at phase tau, Phi(tau) v, stepped off by eps along it towards the plane) and
  integrated by scipy to the plane: it lands on the program's cut point (so the program's step-off
  is along the eigenvector, the program's /tubes/<kind>_000/floquet_vector is scipy's to 1e-10 in
  angle, and a step-off 1 % longer lands 100 times farther off than the bound);
- a cut point integrated back to its seed (by its flight time) approaches the orbit: its distance
  to the orbit at the same phase falls by the multiplier mu_u (mu_s for the stable tube) over the
  last period, and ends at the step-off eps |v| / |v_q|;
- every cut point's Jacobi constant equals the orbit's to 1e-10, and it lies on the plane crossed
  in the section's direction;
- the loop integral of p . dq over the cut (periodic splines written here) and the orbit's action
  (integrated here by scipy) agree with the program's area (Poincare-Cartan: the cut's p . dq is
  the orbit's action, docs/tubes.md "Area = action").

The planar Lyapunov orbit through the same code: the spatial model's planar family (family = 2) and
the planar model (2 DOF, the region-based section) give the same cut to 1e-8 (not bit for bit: the
spatial integration carries z, pz = 0, which changes DOP853's error norm and so its steps; the 2-DOF
path itself is unchanged, input/paper.nml bit for bit). Requests that make no sense are refused."""
import h5py
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.interpolate import CubicSpline
from scipy.optimize import brentq

from conftest import run_tubes

MU = 0.01215058560962404
PLANE = 1 - MU                     # the Moon's plane x = 1 - mu
TOL = dict(method="DOP853", rtol=1e-13, atol=1e-13)


def grad_u(q):
    """dU/dq of U = -(1 - mu)/r1 - mu/r2 and its Hessian (written here, canonical rotating frame)."""
    g, h = np.zeros(3), np.zeros((3, 3))
    for m, c in ((1 - MU, np.array([-MU, 0, 0])), (MU, np.array([1 - MU, 0, 0]))):
        d = q - c
        r = np.linalg.norm(d)
        g += m * d / r**3
        h += m * (np.eye(3) / r**3 - 3 * np.outer(d, d) / r**5)
    return g, h


def rhs(t, s):
    """Hamilton's equations of H = |p|^2/2 + y px - x py + U (the program's state (q, p))."""
    x, y, z, px, py, pz = s[:6]
    g, _ = grad_u(np.array([x, y, z]))
    return np.array([px + y, py - x, pz, py - g[0], -px - g[1], -g[2]])


def jac(s):
    _, h = grad_u(np.asarray(s[:3]))
    a = np.zeros((6, 6))
    a[0, 3] = a[1, 4] = a[2, 5] = 1
    a[0, 1], a[1, 0] = 1, -1
    a[3, 4], a[4, 3] = 1, -1
    a[3:, :3] = -h
    return a


def rhs_var(t, w):
    s, phi = w[:6], w[6:].reshape(6, 6)
    return np.concatenate([rhs(t, s), (jac(s) @ phi).ravel()])


def rhs_action(t, w):
    f = rhs(t, w[:6])
    return np.append(f, w[3:6] @ f[:3])            # p . dq/dt


def energy(s):
    x, y, z, px, py, pz = s
    r1 = np.sqrt((x + MU) ** 2 + y * y + z * z)
    r2 = np.sqrt((x - 1 + MU) ** 2 + y * y + z * z)
    return (px * px + py * py + pz * pz) / 2 + y * px - x * py - (1 - MU) / r1 - MU / r2


def flow_stm(x0, t):
    w = solve_ivp(rhs_var, (0, t), np.concatenate([x0, np.eye(6).ravel()]), **TOL).y[:, -1]
    return w[:6], w[6:].reshape(6, 6)


def x_l1():
    f = lambda x: x - (1 - MU) * (x + MU) / abs(x + MU) ** 3 - MU * (x - 1 + MU) / abs(x - 1 + MU) ** 3
    return brentq(f, 0.5, 1 - MU - 1e-3, xtol=1e-15)


def nml(name, kind, direction, extra="", family="'halo_north'", spatial=".true.", de=0.01, t_max=20):
    return (f"&run scenes = 'orbits', 'tubes', output = '{name}.h5' /\n"
            f"&model system = 'cr3bp', spatial = {spatial} /\n"
            f"&orbits saddle = 'L1', de = {de}, family = {family} /\n"
            f"&section kind = 'plane', index = 1, value = {PLANE!r}, direction = {direction} /\n"
            f"&tubes de = {de}, kind = '{kind}', t_max = {t_max}{extra} /\n")


def run_cut(tmp, name, kind, direction, **kw):
    (tmp / f"{name}.nml").write_text(nml(name, kind, direction, **kw))
    r = run_tubes([f"{name}.nml"], cwd=tmp, timeout=300, threads=2)
    assert r.returncode == 0, r.stderr
    with h5py.File(tmp / f"{name}.h5") as f:
        g = f[f"tubes/{kind}_000"]
        out = {k: g[k][()] for k in ("tau", "time", "state", "section", "r", "p_r", "floquet_vector")}
        out.update({k: g.attrs[k] for k in g.attrs})
        o = f["orbits"]
        out.update(orbit_state0=o["state0"][0], orbit_period=o["period"][0], orbit_energy=o["energy"][0],
                   orbit_action=o["action"][0], stdout=r.stdout, path=tmp / f"{name}.h5")
    return out


@pytest.fixture(scope="module")
def cuts(tmp_path_factory):
    """The L1 northern halo orbit's unstable tube (crossing the plane with dx/dt > 0) and stable
    tube (dx/dt < 0) at dE = 0.01, and scipy's monodromy of the orbit the program wrote."""
    tmp = tmp_path_factory.mktemp("halo_tubes")
    u = run_cut(tmp, "u", "unstable", 1)
    s = run_cut(tmp, "s", "stable", -1)
    x0, per = u["orbit_state0"], u["orbit_period"]
    assert per == s["period"] == u["period"]
    xt, m = flow_stm(x0, per)
    assert np.max(np.abs(xt - x0)) < 1e-9           # the program's orbit closes under scipy's flow
    w, v = np.linalg.eig(m)
    real = np.abs(w.imag) == 0
    iu = np.argmax(np.where(real, np.abs(w), -np.inf))
    i_s = np.argmin(np.where(real, np.abs(w), np.inf))
    return {"unstable": u, "stable": s, "x0": x0, "T": per, "mono": m,
            "mu": {"unstable": w[iu].real, "stable": w[i_s].real},
            "v": {"unstable": v[:, iu].real, "stable": v[:, i_s].real}, "xL": x_l1()}


def seed_of(c, kind, tau):
    """The seed at phase tau rebuilt from scipy's eigenvector (towards the plane from L1), and the
    orbit's state there and the transported eigenvector."""
    cut = c[kind]
    xo, phi = flow_stm(c["x0"], tau) if tau > 0 else (c["x0"], np.eye(6))
    v0 = c["v"][kind].copy()
    sigma = np.sign(v0[0] * (PLANE - c["xL"]))
    v = phi @ v0
    return xo + sigma * cut["eps"] * v / np.linalg.norm(v[:3]), xo, v


def to_plane(x, t_span, direction):
    ev = lambda t, s: s[0] - PLANE
    ev.terminal, ev.direction = True, direction * np.sign(t_span)   # (scipy's is along the integration)
    r = solve_ivp(rhs, (0, t_span), x, events=ev, **TOL)
    assert r.status == 1, "no crossing of the plane"
    return r.t_events[0][0], r.y_events[0][0]


@pytest.mark.parametrize("kind", ["unstable", "stable"])
def test_points_on_plane_and_energy(cuts, kind):
    cut = cuts[kind]
    st = cut["state"]
    assert st.shape[1] == 6 and cut["converged"] == 1 and cut["family"] == -1
    assert np.max(np.abs(st[:, 0] - PLANE)) < 1e-12                       # on the plane
    dxdt = st[:, 3] + st[:, 1]                                             # dx/dt = px + y
    assert np.all(np.sign(dxdt) == cut["section_direction"])
    e_orbit = energy(cuts["x0"])
    assert e_orbit == pytest.approx(cut["orbit_energy"], abs=1e-12)
    c_err = np.max(np.abs(-2 * np.array([energy(s) for s in st]) - (-2 * e_orbit)))
    print(f"{kind}: {len(st)} points, max |C - C_orbit| = {c_err:.1e}")
    assert c_err < 1e-10
    # the section's coordinates are the pairs (y, py), (z, pz) of the states
    assert cut["axes"] == "q2 p2 q3 p3"
    np.testing.assert_array_equal(cut["section"], st[:, [1, 4, 2, 5]])
    np.testing.assert_array_equal(cut["r"], st[:, 1])
    assert np.all(np.sign(cut["time"]) == (1 if kind == "unstable" else -1))


def loop_action(tau, sec, period):
    """The loop integral of p . dq over the closed cut, on periodic cubic splines in tau (Gauss-
    Legendre, 5 points per interval)."""
    t = np.append(tau, period)
    xg, wg = np.polynomial.legendre.leggauss(5)
    total = 0.0
    for a in (0, 2):
        q = CubicSpline(t, np.append(sec[:, a], sec[0, a]), bc_type="periodic")
        p = CubicSpline(t, np.append(sec[:, a + 1], sec[0, a + 1]), bc_type="periodic")
        mid, half = (t[1:] + t[:-1]) / 2, (t[1:] - t[:-1]) / 2
        s = mid[:, None] + half[:, None] * xg[None, :]
        total += np.sum(half[:, None] * wg[None, :] * p(s) * q(s, 1))
    return total


@pytest.mark.parametrize("kind", ["unstable", "stable"])
def test_area_is_the_orbit_action(cuts, kind):
    cut = cuts[kind]
    w = solve_ivp(rhs_action, (0, cuts["T"]), np.append(cuts["x0"], 0.0), **TOL).y[:, -1]
    # the integral of (p - p_L) . dq over one period (scipy), p_L = (0, x_L, 0) the saddle's momentum:
    # the same over a closed orbit, but the integrated one closes only to ~1e-10, which p . dq weighs
    # with |p| ~ 1 (docs/output.md, /orbits/action)
    action = w[6] - cuts["xL"] * (w[1] - cuts["x0"][1])
    loop = abs(loop_action(cut["tau"], cut["section"], cuts["T"]))
    print(f"{kind}: program area {cut['area']:.13g}, loop integral here {loop:.13g}, orbit action (scipy) "
          f"{action:.13g}, program's action {cut['action']:.13g}")
    assert cut["action"] == pytest.approx(action, rel=1e-10)
    assert loop == pytest.approx(cut["area"], rel=1e-9)
    assert cut["area"] == pytest.approx(action, rel=1e-9)
    assert cut["area_eps_change"] < 1e-10 * cut["area"]


@pytest.mark.parametrize("kind", ["unstable", "stable"])
def test_seeds_along_the_monodromy_eigenvector(cuts, kind):
    cut = cuts[kind]
    mu = cuts["mu"][kind]
    assert (mu > 1000) if kind == "unstable" else (0 < mu < 1e-3)
    n = len(cut["tau"])
    worst = 0.0
    for i in np.linspace(0, n - 1, 5).astype(int):
        tau, tc = cut["tau"][i], cut["time"][i]
        seed, _, _ = seed_of(cuts, kind, tau)
        t, x = to_plane(seed, 1.5 * tc, cut["section_direction"])
        err = np.max(np.abs(x - cut["state"][i]))
        worst = max(worst, err)
        print(f"{kind} tau = {tau:.6f}: crossing time {t:.10f} (program {tc:.10f}), state off by {err:.1e}")
        assert t == pytest.approx(tc, abs=1e-6)
        assert err < 1e-6
    # the program's step-off direction at x0 (/tubes/<kind>_000/floquet_vector) is scipy's
    # eigenvector (up to sign), and its branch the one towards the plane
    v_prog, v_here = cut["floquet_vector"], cuts["v"][kind] / np.linalg.norm(cuts["v"][kind])
    cos = abs(v_prog @ v_here)
    print(f"{kind}: |cos| between the program's Floquet vector and scipy's = 1 - {1 - cos:.1e}; worst "
          f"crossing {worst:.1e}")
    assert np.linalg.norm(v_prog) == pytest.approx(1, abs=1e-14) and 1 - cos < 1e-10
    assert cut["sigma"] == np.sign(v_prog[0] * (PLANE - cuts["xL"]))
    # the check can fail: a step-off 1 % longer (or a wrong branch) lands far off the program's point
    seed, xo, _ = seed_of(cuts, kind, 0.0)
    _, x = to_plane(xo + 1.01 * (seed - xo), 1.5 * cut["time"][0], cut["section_direction"])
    assert np.max(np.abs(x - cut["state"][0])) > 1e-4


@pytest.mark.parametrize("kind", ["unstable", "stable"])
def test_cut_points_approach_the_orbit(cuts, kind):
    """A cut point flown back to its seed: its distance to the orbit at the same phase, one period
    before the seed and at the seed, has the ratio mu (the Floquet multiplier), and ends at eps
    |v| / |v_q|."""
    cut = cuts[kind]
    mu, per = cuts["mu"][kind], cuts["T"]
    for i in (0, len(cut["tau"]) // 3):
        tau, tc = cut["tau"][i], cut["time"][i]
        _, xo, v = seed_of(cuts, kind, tau)
        # from the cut point back to the seed, through the state one period after (before) the seed
        sgn = np.sign(tc)
        ts = [-tc + sgn * per, -tc]
        r = solve_ivp(rhs, (0, -tc), cut["state"][i], t_eval=ts, **TOL)
        d_per, d_seed = (np.linalg.norm(r.y[:, k] - xo) for k in range(2))
        want = cut["eps"] * np.linalg.norm(v) / np.linalg.norm(v[:3])
        ratio = d_per / d_seed
        mu_u = mu if kind == "unstable" else 1 / mu
        print(f"{kind} tau = {tau:.5f}: distance {d_per:.3e} one period from the seed, {d_seed:.4e} at the seed "
              f"(eps |v|/|v_q| = {want:.4e}); ratio {ratio:.2f}, mu_u = {mu_u:.2f}")
        assert d_seed == pytest.approx(want, rel=2e-2)
        assert ratio == pytest.approx(mu_u, rel=2e-2)


def test_planar_lyapunov_same_cut_both_paths(tmp_path):
    """The planar L1 Lyapunov orbit's stable tube at dE = 0.005: the spatial model's planar family
    (family = 2, the N-DOF path) against the planar model (2 DOF, the section's region path)."""
    three = run_cut(tmp_path, "p3", "stable", -1, family=2, de=0.005)
    two_nml = nml("p2", "stable", -1, family=1, spatial=".false.", de=0.005)
    (tmp_path / "p2.nml").write_text(two_nml)
    r = run_tubes(["p2.nml"], cwd=tmp_path, timeout=300, threads=2)
    assert r.returncode == 0, r.stderr
    with h5py.File(tmp_path / "p2.h5") as f:
        g = f["tubes/stable_000"]
        two = {k: g[k][()] for k in ("tau", "state")}
        two.update(area=g.attrs["area"], period=g.attrs["period"])
    assert np.max(np.abs(three["state"][:, [2, 5]])) < 1e-15                  # stays planar
    assert three["period"] == pytest.approx(two["period"], rel=1e-12)
    assert three["area"] == pytest.approx(two["area"], rel=1e-10)
    # the same curve: the 2-DOF points against the spatial cut interpolated at their phases
    t3 = np.append(three["tau"], three["period"])
    d = 0.0
    for a3, a2 in ((1, 1), (4, 3)):
        sp = CubicSpline(t3, np.append(three["state"][:, a3], three["state"][0, a3]), bc_type="periodic")
        d = max(d, np.max(np.abs(sp(two["tau"]) - two["state"][:, a2])))
    print(f"planar Lyapunov: area 3-DOF {three['area']:.14g}, 2-DOF {two['area']:.14g}; points differ by {d:.1e}")
    assert d < 1e-7


def test_refusals(tmp_path):
    # a plane the tube does not reach in the allowed time: the cut fails, said with t_max, exit 4
    (tmp_path / "a.nml").write_text(nml("a", "unstable", 1, t_max=1))
    r = run_tubes(["a.nml"], cwd=tmp_path, timeout=300)
    assert r.returncode == 4, r.stderr
    assert "does not reach it" in r.stderr and "t_max = 1" in r.stderr
    # halo orbits (and their tubes) in a 2-DOF model: refused before any work
    (tmp_path / "b.nml").write_text(nml("b", "stable", -1, spatial=".false."))
    r = run_tubes(["b.nml"], cwd=tmp_path, timeout=60)
    assert r.returncode == 1 and "needs 3 degrees of freedom" in r.stderr
    assert not (tmp_path / "b.h5").exists()
    # the scenes on a section's region stay 2-DOF
    (tmp_path / "c.nml").write_text(nml("c", "stable", -1).replace("'orbits', 'tubes'", "'tubes', 'transition'"))
    r = run_tubes(["c.nml"], cwd=tmp_path, timeout=60)
    assert r.returncode == 1 and "'transition' works on the region of a Poincare section" in r.stderr
    # a halo tube below the halo branch point (L1: dE = 0.00699): no orbit, said, exit 4
    (tmp_path / "e.nml").write_text(nml("e", "stable", -1, de=0.005).replace("'orbits', 'tubes'", "'tubes'"))
    r = run_tubes(["e.nml"], cwd=tmp_path, timeout=120)
    assert r.returncode == 4 and "no orbit of the halo_north family" in r.stderr and "below the branch point" in r.stderr
    # the plane y = 0 through the saddle: no side for the tube to go to
    (tmp_path / "d.nml").write_text(nml("d", "stable", -1).replace(f"index = 1, value = {PLANE!r}",
                                                                   "index = 2, value = 0"))
    r = run_tubes(["d.nml"], cwd=tmp_path, timeout=120)
    assert r.returncode == 4 and "passes through the saddle" in r.stderr


def test_stable_cut_is_the_mirror_of_the_unstable(cuts):
    """The CR3BP's time-reversal symmetry R: (x, y, z, px, py, pz, t) -> (x, -y, z, -px, py, -pz, -t)
    maps the halo orbit (symmetric: x0 on R's fixed set, R x(tau) = x(-tau)) onto itself and its
    unstable manifold onto its stable one: the stable cut is R of the unstable cut (crossing the
    plane the other way), the two computed independently by the program. As curves: each stable
    point's distance to R(unstable cut) (periodic splines, the phase T - tau moved along the curve
    by one Gauss-Newton step). Measured: 3e-10. Point by point at T - tau they differ by up to 4e-5,
    the phase's parametrisation: the stable eigenvector carried forward by the STM over up to a
    period picks up ~1e-12 mu_u^2 ~ 5e-6 of the unstable one (which integrating the seed backwards
    then damps), and the seed's distance along the manifold, so its flight time, moves by as much
    (the two cuts' flight times differ by 6e-6), a shift along the curve, not off it."""
    u, s, per = cuts["unstable"], cuts["stable"], cuts["T"]
    ru = u["state"] * np.array([1, -1, 1, -1, 1, -1])
    sp = CubicSpline(np.append(u["tau"], per), np.vstack([ru, ru[:1]]), bc_type="periodic", axis=0)
    tm = (per - s["tau"]) % per
    for _ in range(2):
        d, t1 = sp(tm) - s["state"], sp(tm, 1)
        tm = tm - np.sum(d * t1, axis=1) / np.sum(t1 * t1, axis=1)
    dist = np.max(np.abs(sp(tm) - s["state"]))
    shift = np.max(np.abs(tm - (per - s["tau"]) % per))
    print(f"stable cut against R(unstable cut): {dist:.1e} off the curve (phase shift up to {shift:.1e})")
    assert dist < 1e-7
    assert np.all(np.sign(s["state"][:, 3] + s["state"][:, 1]) == -np.sign(u["state"][:, 3] + u["state"][:, 1]))


def test_gallery_halo_tubes(tmp_path):
    """docs/examples/halo_tubes.py as a user runs it: its figure is written; every cut's loop action
    is its orbit's to 1e-9 and its points' Jacobi constant the orbit's to 1e-10."""
    import os
    import re
    import subprocess
    from conftest import ROOT
    env = dict(os.environ, OMP_NUM_THREADS="2", PYTHONPATH=str(ROOT / "python"), MPLBACKEND="Agg")
    r = subprocess.run([str(ROOT / ".venv" / "bin" / "python"), str(ROOT / "docs" / "examples" / "halo_tubes.py"),
                        str(tmp_path)], cwd=tmp_path, capture_output=True, text=True, timeout=300, env=env)
    assert r.returncode == 0, r.stdout + r.stderr
    assert (tmp_path / "halo_tubes.png").stat().st_size > 0
    rows = re.findall(r"^(L[12]) +(\S+) +(stable|unstable) +(\d+) +(\S+) +(\S+) +(\S+) +(\S+) +(\S+)", r.stdout, re.M)
    assert len(rows) == 4, r.stdout
    for row in rows:
        area, action, dc = float(row[4]), float(row[5]), float(row[8])
        assert abs(area / action - 1) < 1e-9 and dc < 1e-10


def test_outputs_documented(cuts):
    """Every dataset and attribute of the 3-DOF /tubes and /section is in docs/output.md."""
    from conftest import ROOT
    doc = (ROOT / "docs" / "output.md").read_text()
    names = []
    with h5py.File(cuts["unstable"]["path"]) as f:
        for grp in (f["section"], f["tubes/unstable_000"]):
            names += list(grp.attrs) + list(grp.keys())
    for n in set(names):
        assert f"`{n}`" in doc, f"{n} missing from docs/output.md"


def test_python_tube_cut_is_the_scene(cuts):
    """tubes.Model.tube_cut on the spatial CR3BP with family='halo_north' and the same plane gives
    the scene's cut bit for bit (the same code: tubes_study cut_at)."""
    import tubes
    m = tubes.Model(system="cr3bp_spatial")
    c = m.tube_cut(0.01, kind="unstable", family="halo_north", check_eps=False, t_max=20,
                   section=dict(kind="plane", index=1, value=PLANE, direction=1))
    u = cuts["unstable"]
    for k in ("state", "section", "tau", "time", "floquet_vector"):
        np.testing.assert_array_equal(c[k], u[k])
    assert c["area"] == u["area"] and c["axes"] == u["axes"] and c["sigma"] == u["sigma"] and c["family"] == -1
    with pytest.raises(ValueError, match="cuts the manifolds with a plane: set kind = .plane."):
        m.tube_cut(0.01, section=dict(kind="ray"))
