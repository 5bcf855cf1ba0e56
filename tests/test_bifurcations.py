"""Bifurcation monitoring along a family (issue 38; docs/orbits.md, "Bifurcations").

The halo bifurcations of the planar Lyapunov families of the spatial Earth-Moon CR3BP at L1 and L2,
as the orbits scene locates them (/orbits/bifurcations), against an independent computation written
here with scipy: the problem in velocity form (x, y, z, vx, vy, vz) with its own L points (the
quintic's roots), a symmetric planar Lyapunov corrector (vx = 0 at the half-period crossing of
y = 0), and the vertical variational equation d2(dz)/dt2 = -c(t) dz along the orbit, whose 2x2
monodromy's half trace is the vertical pair's stability index nu_v: the halo branch point is the
orbit where nu_v = 1 (brentq in the orbit's x0). Measured: L1 C = 3.174351954154 against
3.174351954078 (7.6e-11), period 2.742994069173 against ...9462 (2.9e-10); L2 C = 3.152118903100
against ...3101 (7e-13), period 3.415530893165 (6e-13). Asserted: 5e-10 in C, 2e-9 in the period (the
program's bracket is 1e-11 dE; the index's accuracy, ~1e-10 beside the planar pair's ~1e3, sets it).
Literature for orientation only: C ~ 3.1743 (L1), 3.1521 (L2).

Also: the per-orbit indices /orbits/floquet_index against the same variational equations (the
planar pair from the 4x4 planar monodromy, the vertical from the 2x2 block), and the Hénon–Heiles
and De Leon–Berne Lyapunov families, which have no index crossing in their range (none reported:
their index grows from cosh(lambda T) at dE -> 0)."""
import h5py
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from conftest import run_tubes

MU = 0.01215058560962404
TOL = dict(method="DOP853", rtol=1e-13, atol=1e-13)


def rhs(t, s):
    """The planar CR3BP in velocity form, the vertical variation (dz, dvz) and the planar one (4x4)."""
    x, y, vx, vy = s[:4]
    r1 = np.hypot(x + MU, y)
    r2 = np.hypot(x - 1 + MU, y)
    a1, a2 = (1 - MU) / r1**3, MU / r2**3
    ax = x - a1 * (x + MU) - a2 * (x - 1 + MU) + 2 * vy
    ay = y - a1 * y - a2 * y - 2 * vx
    c = a1 + a2
    out = [vx, vy, ax, ay]
    dz = s[4:8].reshape(2, 2)        # columns: the vertical STM
    out += list((np.array([[0, 1], [-c, 0]]) @ dz).ravel())
    if len(s) > 8:
        # planar variational: Hessian of the effective potential
        b1, b2 = 3 * (1 - MU) / r1**5, 3 * MU / r2**5
        uxx = 1 - a1 - a2 + b1 * (x + MU) ** 2 + b2 * (x - 1 + MU) ** 2
        uyy = 1 - a1 - a2 + b1 * y**2 + b2 * y**2
        uxy = b1 * (x + MU) * y + b2 * (x - 1 + MU) * y
        a = np.array([[0, 0, 1, 0], [0, 0, 0, 1], [uxx, uxy, 0, 2], [uxy, uyy, -2, 0]])
        out += list((a @ s[8:].reshape(4, 4)).ravel())
    return out


def energy(x, y, vx, vy):
    r1, r2 = np.hypot(x + MU, y), np.hypot(x - 1 + MU, y)
    return (vx**2 + vy**2) / 2 - (x**2 + y**2) / 2 - (1 - MU) / r1 - MU / r2


def half_crossing(x0, vy0):
    """Flow (x0, 0, 0, vy0) with the vertical STM to the next crossing of y = 0."""
    ev = lambda t, s: s[1]
    ev.terminal, ev.direction = True, -np.sign(vy0)
    s0 = [x0, 0, 0, vy0, 1, 0, 0, 1]
    r = solve_ivp(rhs, (0, 20), s0, events=ev, **TOL)
    assert r.status == 1
    return r.t_events[0][0], r.y_events[0][0]


def lyapunov(x0, vy_guess):
    """The symmetric planar Lyapunov orbit through (x0, 0): vy0 with vx = 0 at the half period."""
    f = lambda vy: half_crossing(x0, vy)[1][2]
    vy = vy_guess
    for _ in range(30):              # secant on vx(T/2)
        h = 1e-7 * max(1, abs(vy))
        fa, fb = f(vy), f(vy + h)
        step = fa * h / (fb - fa)
        vy -= step
        if abs(step) < 1e-14:
            break
    return vy


def vertical_monodromy(x0, vy0):
    """Period, energy, the 2x2 vertical monodromy (of (z, vz)) and the closure of the orbit."""
    th, _ = half_crossing(x0, vy0)
    r = solve_ivp(rhs, (0, 2 * th), [x0, 0, 0, vy0, 1, 0, 0, 1], **TOL)
    closure = np.max(np.abs(r.y[:4, -1] - [x0, 0, 0, vy0]))
    return 2 * th, energy(x0, 0, 0, vy0), r.y[4:8, -1].reshape(2, 2), closure


def vertical_index(x0, vy0):
    """Period, energy and nu_v = tr(M_v)/2 of the orbit (full period: the 2x2 vertical monodromy)."""
    t, e, mv, closure = vertical_monodromy(x0, vy0)
    return t, e, np.trace(mv) / 2, closure


def collinear(k):
    """x of L1 (k = 1) or L2 (k = 2): the root of the x-axis force."""
    f = lambda x: x - (1 - MU) * (x + MU) / abs(x + MU) ** 3 - MU * (x - 1 + MU) / abs(x - 1 + MU) ** 3
    return brentq(f, 0.5, 1 - MU - 1e-3) if k == 1 else brentq(f, 1 - MU + 1e-3, 1.5)


def scene(tmp_path, saddle, des):
    (tmp_path / "o.nml").write_text(
        f"&run scenes = 'orbits', output = 'o.h5' /\n&model system = 'cr3bp', spatial = .true. /\n"
        f"&orbits saddle = '{saddle}', family = 2, de = {', '.join(map(repr, des))} /\n")
    r = run_tubes(["o.nml"], cwd=tmp_path, timeout=300)
    assert r.returncode == 0, r.stderr
    with h5py.File(tmp_path / "o.h5") as f:
        g = f["orbits"]
        return {k: g[k][()] for k in ("dE", "energy", "period", "state0", "floquet_index", "floquet_index_imag",
                                      "monodromy")}, {k: g["bifurcations"][k][()] for k in g["bifurcations"]}, \
            r.stdout


@pytest.mark.parametrize("saddle,des,c_lit", [("L1", [0.004, 0.006, 0.008], 3.1743),
                                               ("L2", [0.008, 0.0095, 0.011], 3.1521)])
def test_halo_branch_point_against_scipy(tmp_path, saddle, des, c_lit):
    o, b, out = scene(tmp_path, saddle, des)
    assert list(b["kind"]) == [1] and b["converged"][0] == 1, b          # one branch point
    k = b["after"][0]
    assert o["floquet_index"][k, 1] < 1 < o["floquet_index"][k + 1, 1]
    assert b["bracket"][0] <= 1e-11 * b["dE"][0]
    assert "branch_point" in out
    # the independent orbit at nu_v = 1, bracketed by the program's two orbits' x0 (only a bracket:
    # the orbits there are the scipy corrector's own)
    xa, xb = o["state0"][k, 0], o["state0"][k + 1, 0]
    vya, vyb = o["state0"][k, 4] - xa, o["state0"][k + 1, 4] - xb        # py = vy + x
    assert abs(collinear(1 if saddle == "L1" else 2) - xa) < 0.1
    cache = {}

    def g(x0):
        vy = lyapunov(x0, vya + (vyb - vya) * (x0 - xa) / (xb - xa))   # the guess: the chord
        t, e, nu, clo = vertical_index(x0, vy)
        cache["res"] = (t, e, nu, clo)
        return nu - 1

    x_b = brentq(g, xa, xb, xtol=1e-13, rtol=1e-14)
    g(x_b)
    t, e, nu, clo = cache["res"]
    assert clo < 1e-10 and abs(nu - 1) < 1e-9
    c_prog, c_ref = -2 * b["energy"][0], -2 * e
    print(f"{saddle}: C program {c_prog:.12f}, scipy {c_ref:.12f} (diff {c_prog - c_ref:.2e}); "
          f"T {b['period'][0]:.12f} vs {t:.12f} (diff {b['period'][0] - t:.2e})")
    assert c_prog == pytest.approx(c_ref, abs=5e-10)
    assert b["period"][0] == pytest.approx(t, abs=2e-9)
    assert b["floquet_index"][0, 1] == pytest.approx(1, abs=1e-8)
    assert c_prog == pytest.approx(c_lit, abs=1e-4)                       # orientation only
    # the branch's tangent: the monodromy's eigenvector for +1 off the flow direction, here the
    # kernel of the vertical block's M_v - I (z, pz = vz), with no planar component
    x0 = x_b
    vy = lyapunov(x0, vya + (vyb - vya) * (x0 - xa) / (xb - xa))
    mv = vertical_monodromy(x0, vy)[2]
    ker = np.linalg.svd(mv - np.eye(2))[2][-1]
    tan = b["tangent"][0]
    assert np.linalg.norm(tan) == pytest.approx(1, abs=1e-12)
    assert np.max(np.abs(tan[[0, 1, 3, 4]])) < 1e-6
    assert abs(abs(np.dot(tan[[2, 5]], ker)) - 1) < 1e-8, (tan, ker)
    assert b["state0"][0][0] == pytest.approx(x0, abs=1e-8)


def test_floquet_indices_against_the_variational_equations(tmp_path):
    o, b, _ = scene(tmp_path, "L1", [0.002, 0.01])
    for k in range(2):
        x0, vy0 = o["state0"][k, 0], o["state0"][k, 4] - o["state0"][k, 0]
        r = solve_ivp(rhs, (0, o["period"][k]), [x0, 0, 0, vy0, 1, 0, 0, 1, *np.eye(4).ravel()], **TOL)
        nu_v = np.trace(r.y[4:8, -1].reshape(2, 2)) / 2
        nu_p = (np.trace(r.y[8:, -1].reshape(4, 4)) - 2) / 2               # the planar pair and the trivial one
        assert o["floquet_index"][k, 0] == pytest.approx(nu_p, rel=1e-8)
        assert o["floquet_index"][k, 1] == pytest.approx(nu_v, abs=1e-9)
        assert np.all(o["floquet_index_imag"][k] == 0)


@pytest.mark.parametrize("model,des", [
    ("henon_heiles", [0.001, 0.01, 0.1, 0.5, 1.0, 2.0, 5.0, 10.0]),
    ("de_leon_berne", [0.01, 0.3, 1.0, 3.0, 6.0, 8.0, 9.0, 9.6, 9.9, 9.95])])
def test_no_period_doubling_in_range(tmp_path, model, des):
    """The saddles' Lyapunov families of Hénon–Heiles (to dE = 10) and De Leon–Berne (to its end,
    dE ~ 9.9916, where the period grows without bound) keep one hyperbolic pair whose index grows
    monotonically from cosh(lambda T_po) (18.83 and 7.11): no crossing of +1 or -1, none reported.
    The index is the 2 DOF (tr M - 2)/2, also (mu_u + mu_s)/2."""
    (tmp_path / "o.nml").write_text(f"&run scenes = 'orbits', output = 'o.h5' /\n&model system = '{model}' /\n"
                                    f"&orbits de = {', '.join(map(repr, des))} /\n")
    r = run_tubes(["o.nml"], cwd=tmp_path, timeout=300)
    assert r.returncode == 0, r.stderr
    assert "bifurcations: none" in r.stdout
    with h5py.File(tmp_path / "o.h5") as f:
        g = f["orbits"]
        nu = g["floquet_index"][:, 0]
        assert g["bifurcations/kind"].shape == (0,)
        m = g["monodromy"][()]
        np.testing.assert_allclose(nu, (np.trace(m, axis1=1, axis2=2) - 2) / 2, rtol=1e-12)
        np.testing.assert_allclose(nu, g["stability_index"][()], rtol=1e-8)   # the trivial pair is 1 to ~1e-7
    assert np.all(np.diff(nu) > 0) and nu[0] > 7
