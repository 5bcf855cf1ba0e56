"""Orbits from a guess and the period-doubled family (issue 38; docs/orbits.md, "Orbits from a
guess" and "Period doubling and the doubled family"), on Henon-Heiles' y-axis family: the orbits
x = px = 0 whose motion in y is the 1-DOF oscillation y'' = -y + y^2, started from the guess
(0, 0, 0, 0.4) with period 6.9 (the program's state and period are only guesses for the checks).

Independent references written here:
- the period of the y-axis orbit at energy E, the 1-DOF quadrature T(E) = 2 int dy / sqrt(2(E - V(y)))
  between the turning points (scipy.integrate.quad with the substitution y = c + r sin(theta));
- the period-doubling energy: the y-axis orbit's full 4x4 monodromy by solve_ivp with the
  variational equations (DOP853, rtol = atol = 1e-12), tr M = 2 + 2 nu with the trivial pair's 2,
  brentq for nu = -1 (tr M = 0);
- the doubled orbit at E = 0.14 (past the period doubling at E ~ 0.13529): a Newton corrector of
  its own (x(T) = x0, H(x0) = E, a phase condition; the STM by solve_ivp, least squares), started
  from the program's state0 and period.
Measured (2026-11-29): the guess family's periods against the quadrature to <= 3e-13; the period
doubling's energy 0.1352859193 against brentq to 2e-12; the doubled orbit's period at E = 0.14
15.611282213 against the scipy corrector to 1e-11, closures 5e-13 (program) and < 1e-12 (scipy).
Asserted: 1e-10, 1e-9, 1e-9 and closure < 1e-10 (the scipy orbit's, and the program's)."""
import h5py
import numpy as np
import pytest
from scipy.integrate import quad, solve_ivp
from scipy.optimize import brentq

from _helpers import newton
from conftest import run_tubes

E_SAD = 1.0 / 6.0           # Henon-Heiles' saddles: dE = E - 1/6
TOL = dict(method="DOP853", rtol=1e-12, atol=1e-12)
ENERGIES = [0.10, 0.12, 0.14, 0.1466666666666667]


def rhs(t, z):
    x, y, px, py = z[:4]
    f = [px, py, -x - 2 * x * y, -y - x * x + y * y]
    if len(z) == 4:
        return f
    phi = z[4:].reshape(4, 4)
    jac = np.array([[0, 0, 1, 0], [0, 0, 0, 1], [-1 - 2 * y, -2 * x, 0, 0], [-2 * x, -1 + 2 * y, 0, 0]])
    return np.concatenate([f, (jac @ phi).ravel()])


def energy(z):
    x, y, px, py = z
    return (px * px + py * py) / 2 + (x * x + y * y) / 2 + x * x * y - y**3 / 3


def flow_stm(z0, t):
    r = solve_ivp(rhs, (0, t), np.concatenate([z0, np.eye(4).ravel()]), **TOL)
    return r.y[:4, -1], r.y[4:, -1].reshape(4, 4)


def yaxis_period(e):
    """The 1-DOF quadrature: V(y) = y^2/2 - y^3/3 = e between the turning points a < 0 < b < 1."""
    roots = np.sort(np.roots([-1 / 3, 1 / 2, 0, -e]).real)
    a, b = roots[0], roots[1]
    c, r = (a + b) / 2, (b - a) / 2
    # y = c + r sin(th): dy = r cos(th) dth, e - V(y) = r cos(th)^2 (...): integrand smooth
    g = lambda th: r * np.cos(th) / np.sqrt(2 * max(e - (lambda y: y * y / 2 - y**3 / 3)(c + r * np.sin(th)),
                                                    1e-300))
    val, _ = quad(g, -np.pi / 2, np.pi / 2, epsabs=1e-15, epsrel=1e-13, limit=200)
    return 2 * val


def yaxis_trace(e):
    """tr M of the y-axis orbit of energy e (start y = 0, py = sqrt(2e))."""
    z0 = np.array([0, 0, 0, np.sqrt(2 * e)])
    _, m = flow_stm(z0, yaxis_period(e))
    return np.trace(m)


def correct(z0, t, e):
    """Newton (least squares) on x(T) = x0, H(x0) = e, (x0 - zg) . f(zg) = 0 from (z0, t)."""
    z0, zg = np.array(z0, float), np.array(z0, float)
    fg = np.array(rhs(0, zg))
    for _ in range(30):
        zt, m = flow_stm(z0, t)
        r = np.concatenate([zt - z0, [energy(z0) - e, (z0 - zg) @ fg]])
        if np.max(np.abs(r)) < 1e-13:
            break
        x, y, px, py = z0
        grad = np.array([x + 2 * x * y, y + x * x - y * y, px, py])
        a = np.zeros((6, 5))
        a[:4, :4] = m - np.eye(4)
        a[:4, 4] = rhs(0, zt)
        a[4, :4] = grad
        a[5, :4] = fg
        d = np.linalg.lstsq(a, -r, rcond=None)[0]
        z0, t = z0 + d[:4], t + d[4]
    zt, _ = flow_stm(z0, t)
    return z0, t, np.max(np.abs(zt - z0))


def nml(path, family=None, extra=""):
    de = ", ".join(repr(e - E_SAD) for e in ENERGIES)
    fam = f", family = '{family}'" if family else ""
    path.write_text("&run scenes = 'orbits' /\n&model system = 'henon_heiles' /\n"
                    f"&orbits guess = 0, 0, 0, 0.4, period = 6.9, de = {de}{fam}{extra} /\n")


@pytest.fixture(scope="module")
def runs(tmp_path_factory, tubes_exe):
    d = tmp_path_factory.mktemp("guess")
    out = {}
    for name, fam in (("family", None), ("doubled", "branch:1")):
        nml(d / f"{name}.nml", fam)
        r = run_tubes([f"{name}.nml", "-o", f"{name}.h5"], d, timeout=300)
        out[name] = (r, d / f"{name}.h5")
    return out


def test_guess_family_periods(runs):
    r, h5 = runs["family"]
    assert r.returncode == 0, r.stderr
    with h5py.File(h5) as f:
        o = f["orbits"]
        assert o.attrs["family_name"] == "guess"
        assert o.attrs["family_end_reason"] in ("none", b"none")
        assert np.all(o["converged"][:] == 1)
        for k, e in enumerate(ENERGIES):
            assert abs(o["energy"][k] - e) < 1e-14
            s = o["state0"][k]
            assert abs(s[0]) < 1e-12 and abs(s[2]) < 1e-12          # on the y axis
            assert abs(o["period"][k] - yaxis_period(e)) < 1e-10, (e, o["period"][k] - yaxis_period(e))
            assert o["closure"][k] < 1e-10


def test_period_doubling_located(runs):
    r, h5 = runs["family"]
    e_pd = brentq(yaxis_trace, 0.13, 0.14, xtol=1e-14)
    with h5py.File(h5) as f:
        b = f["orbits/bifurcations"]
        kinds = list(b["kind"][:])
        assert kinds == [2], kinds                        # one period doubling between 0.12 and 0.14
        assert b["after"][0] == 1
        assert abs(b["energy"][0] - e_pd) < 1e-9, (b["energy"][0], e_pd)
        assert abs(b["floquet_index"][0, 0] + 1) < 1e-6
        assert abs(b["period"][0] - yaxis_period(e_pd)) < 1e-8
        v = b["tangent"][0]
        assert abs(v[1]) < 1e-8 and abs(v[3]) < 1e-8       # the -1 eigenvector: transverse (x, px)
    assert "period_doubling" in r.stdout


def test_doubled_family(runs):
    r, h5 = runs["doubled"]
    assert r.returncode == 4, r.stderr                   # the energies below the doubling: not on it
    assert "no branch:1 orbit" in r.stderr
    with h5py.File(h5) as f:
        o = f["orbits"]
        assert o.attrs["family_name"] in ("branch:1", b"branch:1")
        conv = o["converged"][:]
        assert list(conv) == [0, 0, 1, 1]                # the doubled family lies above E_pd
        assert 4 not in list(f["orbits/bifurcations/kind"][:])   # no fold (none at the branch's start)
        k = 2
        z0, t = o["state0"][k], o["period"][k]
        assert o["closure"][k] < 1e-10
    zs, ts, clo = correct(z0, t, ENERGIES[k])
    assert clo < 1e-10
    assert abs(ts - t) < 1e-9, (ts, t)
    assert np.max(np.abs(zs - z0)) < 1e-8
    # a new family: twice the parent's period only at the doubling, here 2 % off it, and off the axis
    assert abs(t - 2 * yaxis_period(ENERGIES[k])) > 0.1
    xs = solve_ivp(rhs, (0, t), z0, dense_output=True, **TOL).sol(np.linspace(0, t, 400))
    assert np.max(np.abs(xs[0])) > 1e-2


def test_guess_bad_input(tmp_path, tubes_exe):
    cases = [("guess = 0, 0, 0.4, period = 6.9", "guess has 3 values"),
             ("guess = 0, 0, 0, 0.4, period = -1", "period = -1"),
             ("guess = 0, 0, 0, 0.4", "period = 0"),
             ("period = 6.9", "guess is not set"),
             ("guess = 0.5, 0.3, 0.1, 0.4, period = 2.0", "the guess did not converge")]
    for i, (text, msg) in enumerate(cases):
        (tmp_path / f"b{i}.nml").write_text("&run scenes = 'orbits' /\n&model system = 'henon_heiles' /\n"
                                            f"&orbits {text}, de = -0.06 /\n")
        r = run_tubes([f"b{i}.nml", "-o", f"b{i}.h5"], tmp_path)
        assert r.returncode == 1, (text, r.returncode, r.stderr)
        assert msg in r.stderr, (text, r.stderr)
        assert "guess" in r.stderr or "period" in r.stderr


def test_python_guess_and_branch_are_the_program_s(runs):
    """Python's orbit_family(guess=, period=) and family='branch:K' call the program's Fortran with
    the settings its reader read: the orbits and the bifurcations are the file's, bit for bit; the
    doubled family's energies below the doubling raise as the program exits 4; bad input raises
    ValueError with the reader's message."""
    import tubes
    m = tubes.Model(system="henon_heiles")
    de = [e - E_SAD for e in ENERGIES]
    kw = {"guess": [0, 0, 0, 0.4], "period": 6.9}
    for name, extra in (("family", {}), ("doubled", {"family": "branch:1"})):
        _, h5 = runs[name]
        t = tubes.orbit_family(m, dE=de, check=name == "family", **kw, **extra)
        with h5py.File(h5) as f:
            o = f["orbits"]
            conv = o["converged"][:] == 1
            assert list(t["converged"]) == list(conv)
            for k in ("energy", "period", "action", "state0", "closure"):
                assert np.array_equal(np.asarray(t[k])[conv], o[k][:][conv]), k
            assert t["family_name"] == (o.attrs["family_name"].decode() if isinstance(o.attrs["family_name"], bytes)
                                        else o.attrs["family_name"])
            b = f["orbits/bifurcations"]
            assert list(t["bifurcations"]["kind"]) == list(b["kind"][:])
            assert np.array_equal(t["bifurcations"]["energy"], b["energy"][:])
    with pytest.raises(tubes.TubesError):
        tubes.orbit_family(m, dE=de, family="branch:1", **kw)
    with pytest.raises(ValueError, match="guess has 3 values"):
        tubes.orbit_family(m, dE=de, guess=[0, 0, 0.4], period=6.9)
    with pytest.raises(ValueError, match="guess is not set"):
        tubes.orbit_family(m, dE=de, period=6.9)


def test_fold_of_l2_halo_family(tmp_path, tubes_exe):
    """A fold: the Earth-Moon L2 halo family's energy has a maximum (the halo branch stops there,
    docs/orbits.md "Branch switching"). The family through a halo orbit (the program's own
    halo_north orbit at dE = 0.05 as the guess) passes it, reports it as kind 4 and stops when the
    energy has come back to the start's; the fold's energy against scipy: the symmetric halo orbit
    corrected at fixed x0 (test_halo's conditions, its functions), E(x0) maximised by bounded Brent.
    Measured: E_fold -1.507588796943 against scipy's -1.507588796943304 (to ~1e-12; asserted 1e-9);
    x0 there 1.08286764 against 1.08286765; the index of the pair through +1 at the fold 1 - 1e-10
    (asserted 1e-6)."""
    import test_halo as th
    from scipy.optimize import minimize_scalar
    (tmp_path / "h.nml").write_text("&run scenes = 'orbits' /\n&model system = 'cr3bp', spatial = .true. /\n"
                                    "&orbits saddle = 'L2', family = 'halo_north', de = 0.05 /\n")
    r = run_tubes(["h.nml", "-o", "h.h5"], tmp_path)
    assert r.returncode == 0, r.stderr
    with h5py.File(tmp_path / "h.h5") as f:
        s0, t0, e_sad = f["orbits/state0"][0], f["orbits/period"][0], f["orbits/energy"][0] - 0.05
    guess = ", ".join(repr(float(v)) for v in s0)
    (tmp_path / "g.nml").write_text("&run scenes = 'orbits' /\n&model system = 'cr3bp', spatial = .true. /\n"
                                    f"&orbits saddle = 'L2', guess = {guess}, period = {float(t0)!r}, "
                                    "de = 0.05, 0.07, 0.09 /\n")
    r = run_tubes(["g.nml", "-o", "g.h5"], tmp_path)
    assert r.returncode == 4, r.stderr                   # dE = 0.09 is above the fold: not reached
    with h5py.File(tmp_path / "g.h5") as f:
        o, b = f["orbits"], f["orbits/bifurcations"]
        assert list(o["converged"][:]) == [1, 1, 0]
        reason = o.attrs["family_end_reason"]
        assert "returned to the start" in (reason.decode() if isinstance(reason, bytes) else reason)
        folds = [j for j, k in enumerate(b["kind"][:]) if k == 4]
        assert len(folds) == 1
        j = folds[0]
        de_fold, nu = b["dE"][j], b["floquet_index"][j]
        x0 = b["state0"][j]

    def g(u, xx):
        return th.half([xx, u[0], u[1]])[1][[3, 5]]

    def energy_at(xx, u0=(x0[2], x0[4] - x0[0])):   # momentum form: vy = py - x at y = 0
        """E of the symmetric halo orbit through x = xx: (z0, vy0) with vx = vz = 0 at the y = 0
        crossing (x, not z: z turns back near the fold too)."""
        u = newton(lambda u: g(u, xx), u0, 30)
        assert np.max(np.abs(g(u, xx))) < 1e-11
        return th.energy([xx, 0, u[0], 0, u[1], 0])

    res = minimize_scalar(lambda xx: -energy_at(xx), bounds=(x0[0] - 0.01, x0[0] + 0.01), method="bounded",
                          options={"xatol": 1e-7})
    e_fold = -res.fun - e_sad
    assert abs(de_fold - e_fold) < 1e-9, (de_fold, e_fold)
    assert abs(max(nu) - 1) < 1e-6, nu
