"""&orbits periods for the families that start away from the saddle (issue 38; docs/orbits.md,
"Orbits by Jacobi constant or period"): a halo family ('halo_north', 'halo_south'), the axial family
and a guess's family, their T(dE) probed along their own continuation and the period solved by Brent
on T(dE) (src/workflow/tubes_orbit_parameter.f90, period_de_away). Each orbit the program finds is
corrected again here by an independent scipy corrector at that orbit's energy (the program's state
only its guess): the symmetric half-period corrector of tests/test_axial.py for the CR3BP (velocity
form, Newton on a central-difference Jacobian, DOP853 at rtol = atol = 1e-13), the 1-DOF quadrature
and the Newton least-squares corrector of tests/test_guess.py for Henon-Heiles' y-axis family. The
period scipy gives must be the one asked for to 1e-10 (relative). 'branch:K' by period is refused
(exit 1, naming &orbits periods and why). The figures of docs/orbits.md are printed by
`.venv/bin/python -m pytest -s -m slow tests/test_periods.py`."""
import numpy as np
import pytest

from _helpers import SPATIAL_CR3BP, run_orbits
from test_axial import axial_start, recorrect, vertical_start
from test_guess import E_SAD, correct as correct_hh, yaxis_period


def run(tmp_path, name, model, orbits):
    return run_orbits(tmp_path, name, model, orbits, timeout=900)


@pytest.mark.slow   # ~30 s: the L1 halo family probed from below its branch point to its fold
@pytest.mark.parametrize("saddle,fam,ts,again", [("L1", "halo_north", [2.745, 2.75], True),
                                                 ("L2", "halo_south", [3.40], False)])
def test_halo_by_period_against_scipy(tmp_path, saddle, fam, ts, again):
    """The halo orbits of the asked periods; at L1 the period rises from the branch point's 2.74299
    to ~2.78 and falls again towards the fold: 2.745 and 2.75 are met twice, the crossing nearest the
    branch point is taken and the other is said on stderr (exit 0)."""
    r, o = run(tmp_path, "h", SPATIAL_CR3BP, f"saddle = '{saddle}', family = '{fam}', "
                                       f"periods = {', '.join(map(repr, ts))}")
    assert r.returncode == 0, r.stderr
    assert o["attrs"]["parameter"] == "periods" and o["attrs"]["family_name"] == fam
    assert np.all(o["converged"] == 1)
    assert ("more than one orbit of the family has this period" in r.stderr) == again, r.stderr
    for k, t_star in enumerate(ts):
        _, u, t, closure, res = recorrect(vertical_start, o, k)
        print(f"{saddle} {fam} by period {t_star}: dE = {o['dE'][k]:.13g}, program T - T* = "
              f"{o['period'][k] - t_star:.1e}, scipy at the program's energy T = {t:.13f} "
              f"((T - T*)/T* = {(t - t_star) / t_star:.1e}), |z0| = {abs(u[1]):.7f}, closure {closure:.1e}")
        assert res < 1e-12 and closure < 1e-10
        assert abs(u[1]) > 1e-3                      # out of the plane: a halo orbit, not the planar one
        assert t == pytest.approx(t_star, rel=1e-10)


@pytest.mark.slow   # the axial family's probes: each a planar family, its monitor and an arc
def test_axial_by_period_against_scipy(tmp_path):
    t_star = 4.0
    r, o = run(tmp_path, "a", SPATIAL_CR3BP, f"saddle = 'L1', family = 'axial', periods = {t_star}")
    assert r.returncode == 0, r.stderr
    assert o["converged"][0] == 1
    _, u, t, closure, res = recorrect(axial_start, o, 0)
    print(f"axial by period {t_star}: dE = {o['dE'][0]:.13g}, program T - T* = {o['period'][0] - t_star:.1e}, "
          f"scipy T = {t:.13f} ((T - T*)/T* = {(t - t_star) / t_star:.1e}), vz0 = {u[2]:.10f}, "
          f"closure {closure:.1e}")
    assert res < 1e-12 and closure < 1e-10 and abs(u[2]) > 1e-3
    assert t == pytest.approx(t_star, rel=1e-10)


@pytest.mark.slow   # ~12 s: the guess's family probed both ways from the guess's energy
def test_guess_by_period_against_scipy(tmp_path):
    """Henon-Heiles' y-axis family through the guess (0, 0, 0, 0.4), period 6.9: T = 6.5 lies below
    the guess's energy, 7.0 above it; scipy's quadrature and its corrector at the program's energy."""
    ts = [6.5, 7.0]
    r, o = run(tmp_path, "g", "&model system = 'henon_heiles' /\n",
               f"saddle = 'S2', guess = 0, 0, 0, 0.4, period = 6.9, periods = {ts[0]}, {ts[1]}")
    assert r.returncode == 0, r.stderr
    assert o["attrs"]["family_name"] == "guess" and np.all(o["converged"] == 1)
    for k, t_star in enumerate(ts):
        e = o["energy"][k]
        tq = yaxis_period(e)
        _, tc, closure = correct_hh(o["state0"][k], o["period"][k], e)
        print(f"guess family by period {t_star}: E = {e:.15f} (dE = {e - E_SAD:.12g}), quadrature T = {tq:.13f} "
              f"({(tq - t_star) / t_star:.1e}), corrector T = {tc:.13f} ({(tc - t_star) / t_star:.1e}), "
              f"closure {closure:.1e}")
        assert closure < 1e-10
        assert tq == pytest.approx(t_star, rel=1e-10)   # the quadrature's own error ~1e-12 (test_guess.py)
        assert tc == pytest.approx(t_star, rel=1e-10)


@pytest.mark.slow
def test_python_takes_the_same_path(tmp_path):
    """orbit_family(periods=..., family='halo_south') is the program's scene: the same dE, bit for bit."""
    import tubes
    _, o = run(tmp_path, "p", SPATIAL_CR3BP, "saddle = 'L2', family = 'halo_south', periods = 3.40")
    t = tubes.orbit_family(tubes.Model("cr3bp", spatial=True), saddle="L2", family="halo_south", periods=[3.40])
    assert t["family_name"] == "halo_south"
    np.testing.assert_array_equal(t["dE"], o["dE"])


def test_branch_by_period_refused(tmp_path):
    r, o = run(tmp_path, "b", "&model system = 'henon_heiles' /\n",
               "saddle = 'S2', guess = 0, 0, 0, 0.4, period = 6.9, family = 'branch:1', periods = 15.6")
    assert r.returncode == 1, r.stderr
    assert "&orbits: periods: not for family = 'branch:1'" in r.stderr
    assert "counts the parent family's bifurcations between the requested energies" in r.stderr
    import tubes
    with pytest.raises(ValueError, match="not for family = 'branch:1'"):
        tubes.orbit_family(tubes.Model("henon_heiles"), saddle="S2", guess=[0, 0, 0, 0.4], period=6.9,
                           family="branch:1", periods=[15.6])


@pytest.mark.slow   # ~15 s: the L2 halo family probed to its ends
def test_period_not_reached(tmp_path):
    """A period the family's probes do not take: said with the probed range (exit 4; Python EPASTEND)."""
    r, _ = run(tmp_path, "n", SPATIAL_CR3BP, "saddle = 'L2', family = 'halo_south', periods = 5.0")
    assert r.returncode == 4, r.stderr
    assert "&orbits periods(1) = 5: not reached: the L2 family's orbits probed along its continuation" in r.stderr
    import tubes
    with pytest.raises(tubes.TubesError, match="not reached") as e:
        tubes.orbit_family(tubes.Model("cr3bp", spatial=True), saddle="L2", family="halo_south", periods=[5.0])
    assert e.value.code == tubes.EPASTEND
