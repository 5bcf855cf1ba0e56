"""Sections through the public boundaries: U1 crossings from Python against scipy's event
location on the independently written Lagrangian form, the branch split, and the executable."""
import h5py
import numpy as np
from scipy.integrate import solve_ivp

import tubes
from conftest import run_tubes
from test_python import lagrangian_rhs

X0 = [4.0, 12.614863819914357, 0.0, 0.0]


def test_u1_crossings_against_scipy_events():
    """U1 = {y = x, x > 0}. scipy (DOP853 at 1e-12, Lagrangian form, its own event root finder)
    must find the same crossing times; over 20 s the trajectories agree to ~1e-6 (chaotic
    growth of 1e-12 errors, see test_python), so times agree to ~1e-6 / |d(y-x)/dt| ~ 1e-7."""
    r = tubes.integrate(X0, 20.0, section="U1")
    c = r["crossings"]
    assert len(c["t"]) > 10
    # on the ray, and p_theta's sign is the reported orientation
    assert np.allclose(c["state"][:, 0], c["state"][:, 1], atol=1e-9)
    assert np.all(c["state"][:, 0] > 0)
    assert np.array_equal(np.sign(c["p_theta"]), c["direction"])

    def ev(_t, z):
        return z[1] - z[0]
    sol = solve_ivp(lagrangian_rhs, (0, 20.0), X0, method="DOP853", rtol=1e-12, atol=1e-12,
                    events=ev, dense_output=True)
    ts = np.array([t for t, z in zip(sol.t_events[0], sol.y_events[0]) if z[0] > 0])
    assert len(ts) == len(c["t"])
    assert np.abs(ts - c["t"]).max() < 1e-5


def test_u1_branches_partition():
    both = tubes.integrate(X0, 20.0, section="U1")["crossings"]
    minus = tubes.integrate(X0, 20.0, section="U1-")["crossings"]
    plus = tubes.integrate(X0, 20.0, section="U1+")["crossings"]
    assert len(minus["t"]) + len(plus["t"]) == len(both["t"])
    assert np.all(minus["p_theta"] > 0) and np.all(plus["p_theta"] < 0)
    assert np.allclose(np.sort(np.concatenate([minus["t"], plus["t"]])), both["t"], rtol=0, atol=1e-12)


def test_stop_at_first_and_lines():
    r = tubes.integrate(X0, 20.0, dt_out=0.01, section="x", level=0.0, direction=-1, stop_at_first=True)
    c = r["crossings"]
    assert len(c["t"]) == 1 and abs(c["state"][0, 0]) < 1e-12 and c["direction"][0] == -1
    assert r["t"][-1] <= c["t"][0] + 1e-12          # the samples stop at the crossing


def test_reference_solution_from_python():
    """real128 reference vs DOP853 at 1e-14 over 1 s: DOP853's error there is ~1e-12 relative."""
    ref = tubes.reference_solution(X0, 1.0, tol=1e-22)
    x = tubes.integrate(X0, 1.0, rtol=1e-14, atol=1e-14)["state"][-1]
    assert np.abs(x - ref).max() / np.abs(ref).max() < 1e-10


def test_cli_crossings(tmp_path, tubes_exe):
    (tmp_path / "s.nml").write_text("&run scenes = 'trajectory' /\n"
                                    "&trajectory t_end = 20, section = 'U1-' /\n")
    r = run_tubes(["s.nml", "-o", "s.h5"], tmp_path)
    assert r.returncode == 0, r.stderr
    assert "crossings" in r.stdout
    with h5py.File(tmp_path / "s.h5") as f:
        c = f["trajectory/crossings"]
        assert c["t"].shape[0] == c["state"].shape[0] == c["p_theta"].shape[0] > 0
        assert np.all(c["p_theta"][:] > 0) and np.all(c["direction"][:] == 1)
        assert np.allclose(c["r"][:], np.hypot(c["state"][:, 0], c["state"][:, 1]))
    (tmp_path / "b.nml").write_text("&trajectory section = 'U2' /\n")
    r = run_tubes(["b.nml"], tmp_path)
    assert r.returncode == 1 and "section = 'U2'" in r.stderr
