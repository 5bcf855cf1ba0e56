"""Every integration method through the public boundaries: Python (measured order against the
real128 reference) and the executable (the fixed-step rule)."""
import numpy as np
import pytest

import tubes
from conftest import run_tubes

X0 = [4.0, 12.614863819914357, 0.0, 0.0]
ORDER = {"rk4": 4, "tao2": 2, "tao4": 4, "tao6": 6, "gauss4": 4, "gauss6": 6, "gauss8": 8}


@pytest.fixture(scope="module")
def reference():
    """The real128 reference (tol 1e-24: error ~1e-25 at t = 0.5 s, docs/events.md)."""
    return tubes.reference_solution(X0, 0.5, tol=1e-24)


def test_dop853_against_reference(reference):
    """DOP853 at tolerance tol: over 0.5 s the global error stays within ~1e2 tol (error growth
    of the flow over 0.5 s is ~e^(lambda t) ~ 1e2 with lambda ~ 9/s at worst)."""
    for tol in (1e-8, 1e-11, 1e-14):
        x = tubes.integrate(X0, 0.5, rtol=tol, atol=tol)["state"][-1]
        assert np.abs(x - reference).max() / np.abs(reference).max() < 1e2 * tol


@pytest.mark.parametrize("method", sorted(ORDER))
def test_order_through_python(method, reference):
    """Error at t = 0.5 s for h and h/2: the ratio is 2^p. h chosen in the asymptotic range and
    above the roundoff floor (gauss8 needs larger steps; tao needs 2 omega h <= 0.4)."""
    h = {"gauss8": 1 / 32, "gauss6": 1 / 64, "tao6": 1 / 512, "tao4": 1 / 512}.get(method, 1 / 256)
    errs = []
    for hh in (h, h / 2):
        tr = tubes.trajectory(X0, 0.5, dt_out=0.5, method=method, h=hh)
        errs.append(np.abs(tr["state"][-1] - reference).max())
    order = np.log2(errs[0] / errs[1])
    assert abs(order - ORDER[method]) <= 0.5, (method, errs, order)


def test_fixed_step_rules(tmp_path, tubes_exe):
    with pytest.raises(ValueError):
        tubes.trajectory(X0, 1.0, method="rk4")               # no h
    (tmp_path / "f.nml").write_text("&run scenes='trajectory' /\n&integrator method='gauss4' /\n")
    r = run_tubes(["f.nml"], tmp_path)
    assert r.returncode == 1 and "is fixed-step: it needs h > 0" in r.stderr
    (tmp_path / "g.nml").write_text("&run scenes='trajectory' /\n&integrator method='gauss4', h=0.01, "
                                    "solver='picard' /\n")
    r = run_tubes(["g.nml"], tmp_path)
    assert r.returncode == 1 and "solver = 'picard'" in r.stderr


def test_gauss_counts_iterations(tmp_path):
    tr = tubes.trajectory(X0, 0.2, dt_out=0.1, method="gauss6", h=0.01, solver="fixed_point")
    assert tr["niter"] >= tr["nsteps"] > 0


@pytest.mark.parametrize("method", ["dop853", "gsl_rk8pd", "gsl_rk4imp", "cvode_adams", "arkode_erk8", "taylor"])
def test_variable_step_methods_against_reference(method, reference):
    """Each variable-step method reaches the real128 reference at its tolerance: the global
    error over 0.5 s is at most the local tolerance times the flow's growth (~e^(9/s * 0.5 s)
    ~ 1e2) times the number of steps' accumulation (~10): 1e3 tol; and it shrinks with tol."""
    errs = []
    for tol in (1e-8, 1e-11):
        x = tubes.integrate(X0, 0.5, method=method, rtol=tol, atol=tol)["state"][-1]
        errs.append(np.abs(x - reference).max() / np.abs(reference).max())
        assert errs[-1] < 1e3 * tol, (method, tol, errs[-1])
    assert errs[1] < errs[0] / 30


def test_blow_up_is_reported():
    """Beyond their stability edge (docs/stability.md) fixed-step methods blow up; the model
    refuses states a million cm away, so the blow-up is an error, not finite nonsense."""
    for method, h in [("tao2", 1 / 64), ("rk4", 0.5)]:
        with pytest.raises(tubes.TubesError) as err:
            tubes.integrate(X0, 10.0, dt_out=0.01, method=method, h=h)
        assert err.value.code == tubes.EMODEL
        part = err.value.partial                      # the samples up to the blow-up are kept
        assert part is not None and len(part["t"]) >= 1 and part["t"][-1] < 10.0
