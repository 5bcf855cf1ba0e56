"""Orbits asked for by Jacobi constant or by period (issue 38; docs/orbits.md, "Orbits by Jacobi
constant or period"; &orbits jacobi, periods).

(a) By C (Earth-Moon CR3BP, L1): the orbit at C is the orbit at dE = -C/2 - E_L1, with E_L1 the
    program's /saddle energy (the same bits) and, independently, -Omega(x_L1) of the effective
    potential Omega = (x^2 + y^2)/2 + (1 - mu)/r1 + mu/r2 at the L1 found here by brentq (1e-12);
    C_L1 = 2 Omega(x_L1) against the literature's 3.18834.
(b) By period: the program's period equals the requested one to 1e-10, and the orbit agrees with a
    corrector written here with scipy at the program's energy (CR3BP L1: the symmetric orbit through
    (x0, 0) with vy0 from the energy, x0 by brentq on vx at the half period; Henon-Heiles' saddle
    family: the brake orbit by Newton on (q0, T/2) with p(T/2) = 0, V(q0) = E).
(c) Bad input, the CLI (exit 1; a period not reached: exit 4) and Python (ValueError, TubesError)."""
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

import tubes
from _helpers import run_orbits
from conftest import run_tubes

MU = 0.01215058560962404
TOL = dict(method="DOP853", rtol=1e-13, atol=1e-13)
CR3BP = f"&model system = 'cr3bp', mu = {MU!r} /\n"


def scene(tmp_path, model, orbits, name="o"):
    return run_orbits(tmp_path, name, model, orbits, scenes="'equilibria', 'orbits'",
                      more=lambda f: {"E_e": f["saddle"].attrs["energy"]})


def omega_eff(x, y=0.0):
    r1, r2 = np.hypot(x + MU, y), np.hypot(x - 1 + MU, y)
    return (x**2 + y**2) / 2 + (1 - MU) / r1 + MU / r2


def x_l1():
    f = lambda x: x - (1 - MU) * (x + MU) / abs(x + MU) ** 3 - MU * (x - 1 + MU) / abs(x - 1 + MU) ** 3
    return brentq(f, 0.5, 1 - MU - 1e-3, xtol=1e-15, rtol=1e-15)


def test_jacobi_is_the_orbit_at_its_energy(tmp_path):
    cs = [3.18, 3.17]
    r, o = scene(tmp_path, CR3BP, "saddle = 'L1', jacobi = 3.18, 3.17", "c")
    assert r.returncode == 0, r.stderr
    assert "C (Jacobi)" in r.stdout
    e_l1 = -omega_eff(x_l1())                              # independent: the effective potential at L1
    assert abs(2 * omega_eff(x_l1()) - 3.18834) < 5e-6     # the literature's C_L1
    assert abs(o["E_e"] - e_l1) < 1e-13
    des = [float(-c / 2 - o["E_e"]) for c in cs]
    np.testing.assert_allclose(o["dE"], [-c / 2 - e_l1 for c in cs], rtol=0, atol=1e-12)
    np.testing.assert_allclose(o["jacobi"], cs, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(o["requested_jacobi"], cs)
    r2, o2 = scene(tmp_path, CR3BP, "saddle = 'L1', de = " + ", ".join(map(repr, des)), "d")
    assert r2.returncode == 0, r2.stderr
    assert np.max(np.abs(o["state0"] - o2["state0"])) < 1e-12
    np.testing.assert_allclose(o["period"], o2["period"], rtol=1e-12, atol=0)
    # Python: the same orbits
    t = tubes.orbit_family(tubes.Model("cr3bp", mu=MU), saddle="L1", jacobi=cs)
    np.testing.assert_allclose(t["period"], o["period"], rtol=1e-12, atol=0)
    np.testing.assert_allclose(t["jacobi"], cs, rtol=0, atol=1e-12)


def cr3bp_rhs(t, s):
    x, y, vx, vy = s
    r1, r2 = np.hypot(x + MU, y), np.hypot(x - 1 + MU, y)
    a1, a2 = (1 - MU) / r1**3, MU / r2**3
    return [vx, vy, x - a1 * (x + MU) - a2 * (x - 1 + MU) + 2 * vy, y - a1 * y - a2 * y - 2 * vx]


def cr3bp_orbit_at_energy(e, x_guess, vy_sign):
    """The symmetric Lyapunov orbit of energy e through (x0, 0) perpendicular to y = 0: vy0 from e,
    x0 by brentq on vx at the next crossing of y = 0; returns x0, vy0, the period and the closure."""
    def half(x0):
        vy0 = vy_sign * np.sqrt(2 * (e + omega_eff(x0)))
        ev = lambda t, s: s[1]
        ev.terminal, ev.direction = True, -vy_sign
        r = solve_ivp(cr3bp_rhs, (0, 20), [x0, 0, 0, vy0], events=ev, **TOL)
        return vy0, r.t_events[0][0], r.y_events[0][0]
    x0 = brentq(lambda x: half(x)[2][2], x_guess - 1e-4, x_guess + 1e-4, xtol=1e-15, rtol=1e-15)
    vy0, th, _ = half(x0)
    r = solve_ivp(cr3bp_rhs, (0, 2 * th), [x0, 0, 0, vy0], **TOL)
    return x0, vy0, 2 * th, np.max(np.abs(r.y[:, -1] - [x0, 0, 0, vy0]))


def test_periods_cr3bp_against_scipy(tmp_path):
    ts = [2.72, 2.75]
    r, o = scene(tmp_path, CR3BP, "saddle = 'L1', periods = 2.72, 2.75", "p")
    assert r.returncode == 0, r.stderr
    np.testing.assert_allclose(o["period"], ts, rtol=1e-10, atol=0)
    np.testing.assert_array_equal(o["requested_period"], ts)
    for k, t in enumerate(ts):
        x0p, py0 = o["state0"][k, 0], o["state0"][k, 3]
        vy_p = py0 - x0p                                     # py = vy + x
        x0, vy0, per, clo = cr3bp_orbit_at_energy(o["energy"][k], x0p, np.sign(vy_p))
        assert clo < 1e-10
        assert abs(per - t) < 1e-9 * t, (per, t)             # scipy's orbit at the program's energy
        assert abs(x0 - x0p) < 1e-9 and abs(vy0 - vy_p) < 1e-9
    t = tubes.orbit_family(tubes.Model("cr3bp", mu=MU), saddle="L1", periods=ts)
    np.testing.assert_array_equal(t["dE"], o["dE"])          # the same Fortran
    assert t["parameter"] == "periods"


def hh_rhs(t, z):
    x, y, px, py = z
    return [px, py, -x - 2 * x * y, -y - x**2 + y**2]


def hh_v(q):
    x, y = q
    return (x**2 + y**2) / 2 + x**2 * y - y**3 / 3


def test_periods_henon_heiles_against_scipy(tmp_path):
    """A 2-DOF natural model: the saddle S2 = (0, 1)'s Lyapunov family, whose period falls from
    T_po = 2 pi / sqrt(3) as dE grows; the orbit at T = 3.5 against a scipy brake-orbit corrector."""
    r, o = scene(tmp_path, "&model system = 'henon_heiles' /\n", "periods = 3.5", "h")
    assert r.returncode == 0, r.stderr
    assert abs(o["period"][0] - 3.5) < 1e-10 * 3.5
    e = o["energy"][0]
    assert abs(o["E_e"] - 1 / 6) < 1e-15

    def resid(u):                                            # u = (x0, y0, T/2): p(T/2) = 0, V(q0) = E
        s = solve_ivp(hh_rhs, (0, u[2]), [u[0], u[1], 0, 0], **TOL)
        return np.array([s.y[2, -1], s.y[3, -1], hh_v(u[:2]) - e])
    u = np.array([o["state0"][0, 0] + 1e-6, o["state0"][0, 1] - 1e-6, 3.5 / 2 * (1 + 1e-6)])
    for _ in range(12):                                      # Newton, finite-difference Jacobian
        f = resid(u)
        jac = np.column_stack([(resid(u + h) - f) / 1e-7 for h in np.eye(3) * 1e-7])
        du = np.linalg.solve(jac, -f)
        u += du
        if np.max(np.abs(du)) < 1e-13:
            break
    assert np.max(np.abs(resid(u))) < 1e-11
    assert abs(2 * u[2] - 3.5) < 1e-9, 2 * u[2]
    assert np.max(np.abs(u[:2] - o["state0"][0, :2])) < 1e-9
    t = tubes.orbit_family(tubes.Model("henon_heiles"), periods=[3.5])
    np.testing.assert_array_equal(t["dE"], o["dE"])
    assert "jacobi" not in t


@pytest.mark.parametrize("model,orbits,code,says", [
    (CR3BP, "saddle = 'L1', de = 0.01, jacobi = 3.17", 1, "de and jacobi are both given"),
    (CR3BP, "saddle = 'L1', jacobi = 3.17, periods = 2.72", 1, "jacobi and periods are both given"),
    ("&model system = 'henon_heiles' /\n", "jacobi = 0.1", 1, "has no Jacobi constant"),
    (CR3BP, "saddle = 'L1', jacobi = 3.19", 1, "is not below the saddle L1's C = 3.18834111"),
    (CR3BP, "saddle = 'L1', jacobi = 3.17, 3.18", 1, "strictly decreasing"),
    (CR3BP, "saddle = 'L1', periods = -1", 1, "periods(1)"),
    # slow (~6 s alone, 15 s beside make quick's other worker): the whole family is searched
    pytest.param(CR3BP, "saddle = 'L1', periods = 2.6", 4, "periods(1) = 2.6: not reached", marks=pytest.mark.slow),
])
def test_bad_input_cli(tmp_path, model, orbits, code, says):
    r, _ = scene(tmp_path, model, orbits, "b")
    assert r.returncode == code, (r.returncode, r.stderr)
    assert says in r.stderr, r.stderr


def test_scan_refuses_jacobi(tmp_path):
    """The scan scene follows the orbits at &scan de (else &orbits de): jacobi alone is refused."""
    (tmp_path / "s.nml").write_text("&run scenes = 'scan', output = 's.h5' /\n" + CR3BP +
                                    "&orbits saddle = 'L1', jacobi = 3.17 /\n&scan parameter = 'mu', to = 0.02, n = 2 /\n")
    r = run_tubes(["s.nml"], cwd=tmp_path, timeout=60)
    assert r.returncode == 1 and "the scan scene follows the orbits at &orbits de only" in r.stderr, r.stderr


def test_bad_input_python():
    m = tubes.Model("cr3bp", mu=MU)
    with pytest.raises(ValueError, match="dE and jacobi are both given"):
        tubes.orbit_family(m, saddle="L1", dE=[0.01], jacobi=[3.17])
    with pytest.raises(ValueError, match="jacobi and periods are both given"):
        tubes.orbit_family(m, saddle="L1", jacobi=[3.17], periods=[2.72])
    with pytest.raises(ValueError, match="has no Jacobi constant"):
        tubes.orbit_family(tubes.Model("henon_heiles"), jacobi=[0.1])
    with pytest.raises(ValueError, match="is not below the saddle L1's C"):
        tubes.orbit_family(m, saddle="L1", jacobi=[3.19])
    with pytest.raises(tubes.TubesError, match="not reached") as e:
        tubes.orbit_family(m, saddle="L1", periods=[2.6])
    assert e.value.code == tubes.EPASTEND


def figures():
    """The figures of docs/orbits.md ("Orbits by Jacobi constant or period"), printed:
    .venv/bin/python tests/test_orbit_parameter.py (from the tree's root, with the program built)."""
    import pathlib
    import sys
    import tempfile
    T = sys.modules[__name__]
    tmp = pathlib.Path(tempfile.mkdtemp())
    r, o = T.scene(tmp, T.CR3BP, "saddle = 'L1', jacobi = 3.18, 3.17", "c")
    xl = T.x_l1(); el = -T.omega_eff(xl)
    print("C_L1 program", -2*o["E_e"], "scipy", 2*T.omega_eff(xl), "diff", -2*o["E_e"] - 2*T.omega_eff(xl))
    print("dE program", o["dE"], "minus -C/2-E_L1(scipy)", o["dE"] - np.array([-3.18/2 - el, -3.17/2 - el]))
    des = [float(-c / 2 - o["E_e"]) for c in (3.18, 3.17)]
    r2, o2 = T.scene(tmp, T.CR3BP, "saddle = 'L1', de = " + ", ".join(map(repr, des)), "d")
    print("by C vs by dE: state0", np.max(np.abs(o["state0"] - o2["state0"])), "period", o["period"] - o2["period"], "periods", o["period"])
    r, o = T.scene(tmp, T.CR3BP, "saddle = 'L1', periods = 2.72, 2.75", "p")
    for k, t in enumerate([2.72, 2.75]):
        x0p = o["state0"][k, 0]; vyp = o["state0"][k, 3] - x0p
        x0, vy0, per, clo = T.cr3bp_orbit_at_energy(o["energy"][k], x0p, np.sign(vyp))
        print(f"CR3BP T={t}: dE {o['dE'][k]:.15g} program T - T* {o['period'][k]-t:.2g}, scipy T - T* {per-t:.2g}, x0 diff {x0-x0p:.2g}, vy0 diff {vy0-vyp:.2g}, scipy closure {clo:.2g}")
    r, o = T.scene(tmp, "&model system = 'henon_heiles' /\n", "periods = 3.5, 3.0", "h")
    for k, tt in enumerate([3.5, 3.0]):
        e = o["energy"][k]
        def resid(u):
            s = solve_ivp(T.hh_rhs, (0, u[2]), [u[0], u[1], 0, 0], **T.TOL)
            return np.array([s.y[2, -1], s.y[3, -1], T.hh_v(u[:2]) - e])
        u = np.array([o["state0"][k, 0] + 1e-6, o["state0"][k, 1] - 1e-6, tt / 2 * (1 + 1e-6)])
        for _ in range(12):
            f = resid(u)
            jac = np.column_stack([(resid(u + h) - f) / 1e-7 for h in np.eye(3) * 1e-7])
            du = np.linalg.solve(jac, -f); u += du
            if np.max(np.abs(du)) < 1e-13: break
        print(f"HH T={tt}: dE {o['dE'][k]:.15g} program T - T* {o['period'][k]-tt:.2g} scipy T - T* {2*u[2]-tt:.2g} q0 diff {np.max(np.abs(u[:2]-o['state0'][k,:2])):.2g} resid {np.max(np.abs(resid(u))):.2g}")
    r, o = T.scene(tmp, "", "periods = 0.76, 0.8", "b")
    print("ball", o["dE"], o["period"] - [0.76, 0.8])


if __name__ == "__main__":
    figures()
