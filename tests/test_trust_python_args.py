"""Issue 39: the Python API's numeric arguments are checked in one place (tubes._args), so that no
bad value is accepted silently or ends in an unrelated error (a step-size underflow, a NaN
conversion, a comparison between a float and a str). Each refusal is a ValueError or TypeError
that names the function, the argument and the value given, and says what is allowed."""
import functools
import re

import numpy as np
import pytest

import tubes

X0 = [1.0, 0.5, 0.0, 0.0]          # a state of the ball (cm, cm/s): any will do, none is integrated
M = tubes.Model()
NAN, INF = float("nan"), float("inf")


def refused(call, who, name, value):
    """call() raises ValueError/TypeError naming who, name and the value given, with 'allowed'."""
    with pytest.raises((ValueError, TypeError)) as e:
        call()
    msg = str(e.value)
    assert msg.startswith(f"{who}: {name} = {value!r} "), msg
    assert "allowed" in msg, msg
    return msg


# ---- the cases of issue 39, one test each (each accepted, or refused with another message, before)

def test_max_crossings_negative():
    refused(lambda: tubes.integrate(X0, 0.1, section="x", max_crossings=-1), "integrate", "max_crossings", -1)


def test_max_crossings_zero():
    refused(lambda: tubes.integrate(X0, 0.1, section="x", max_crossings=0), "integrate", "max_crossings", 0)


def test_model_parameter_bool():
    msg = refused(lambda: tubes.Model(g=True), "Model", "g", True)
    assert "not a real number" in msg


def test_model_parameter_string():
    refused(lambda: tubes.Model(g="981"), "Model", "g", "981")


def test_ensemble_threads_negative():
    refused(lambda: tubes.ensemble([X0], 0.1, threads=-3), "ensemble", "threads", -3)


def test_omega_bind_nan():
    refused(lambda: tubes.integrate(X0, 0.1, method="tao2", h=0.01, omega_bind=NAN), "integrate", "omega_bind", NAN)


def test_omega_bind_negative():
    refused(lambda: tubes.integrate(X0, 0.1, method="tao2", h=0.01, omega_bind=-1.0),
            "integrate", "omega_bind", -1.0)


def test_reference_solution_t_end_infinite():
    msg = refused(lambda: tubes.reference_solution(X0, INF, tol=1e-20), "reference_solution", "t_end", INF)
    assert "finite" in msg


def test_integrate_t_end_infinite():
    refused(lambda: tubes.integrate(X0, INF), "integrate", "t_end", INF)


# ---- the sweep: each public numeric argument with each kind of bad value

def _p(f, *a, **kw):
    return functools.partial(f, *a, **kw)


_INTEG = [("integrate", _p(tubes.integrate, X0, t_end=0.1, section="x")),
          ("ensemble", _p(tubes.ensemble, [X0], t_end=0.1))]
SWEEP = []   # (who, call taking the bad value as keyword `name`, name, bad values)
for who, f in _INTEG:
    SWEEP += [(who, f, "t_end", [True, "1", NAN, INF, -1.0]),
              (who, f, "rtol", [True, "1e-10", NAN, 0.0, 1.0]),
              (who, f, "atol", [True, NAN, INF, 0.0, -1e-9]),
              (who, f, "h", [True, NAN, INF, -0.1]),
              (who, f, "max_steps", [True, 2.5, "10", NAN, 0, -1]),
              (who, f, "omega_bind", [True, NAN, INF, -1.0]),
              (who, f, "max_iter", [True, 2.5, -1])]
SWEEP += [("integrate", _INTEG[0][1], "max_crossings", [True, 2.5, "10", NAN, 0, -5]),
          ("integrate", _INTEG[0][1], "direction", [True, 0.5, 2, -2, "1"]),
          ("integrate", _INTEG[0][1], "level", [True, NAN, INF, "0"]),
          ("integrate", _INTEG[0][1], "dt_out", [True, NAN, INF, 0.0, -0.01]),
          ("integrate", _INTEG[0][1], "stop_at_first", [1, "yes"]),
          ("ensemble", _INTEG[1][1], "threads", [True, 2.5, -3, "4"]),
          ("Integrator", _p(tubes.Integrator, M), "max_steps", [2.5, 0]),
          ("Integrator", _p(tubes.Integrator, M), "omega_bind", [NAN, -1.0]),
          ("Integrator.propagate", _p(tubes.Integrator(M).propagate, X0), "t_end", [True, NAN, INF, -1.0]),
          ("reference_solution", _p(tubes.reference_solution, X0), "t_end", [True, NAN, INF, -1.0]),
          ("reference_solution", _p(tubes.reference_solution, X0, 1.0), "tol", [True, NAN, 0.0, -1e-20]),
          ("Model", tubes.Model, "alpha", [True, "0.07", NAN, INF, None]),
          ("section_boundary", _p(tubes.section_boundary, M), "dE", [True, "1"]),   # NaN, inf, < 0 were refused before
          ("section_boundary", _p(tubes.section_boundary, M), "m", [True, "400"]),
          ("section_boundary", _p(tubes.section_boundary, M), "n_grid", [True, 2.5, -1, 1]),
          ("equilibria", _p(tubes.equilibria, M), "n_grid", [True, 2.5, -1, 1, 2002]),
          ("section_boundary", _p(tubes.section_boundary, M, dE=1.0), "box", [True, NAN, -2.0, "3"]),
          ("monte_carlo", _p(tubes.monte_carlo, M), "dE", [True, "100", NAN, INF]),
          ("transition", _p(tubes.transition, M), "dE", [True, "100", NAN]),
          ("orbit_family", _p(tubes.orbit_family, M), "dE", [True, "1", NAN]),
          ("normal_form_map", _p(tubes.normal_form_map, M, [X0]), "order", [True, 2.5, "8"]),
          ("differentiate('spectral')", _p(tubes.differentiate, np.arange(32.0)), "dt", [True, NAN, INF, 0.0, -0.1]),
          ("differentiate('spectral')", _p(tubes.differentiate, np.arange(32.0), 0.1), "rolloff", [NAN, -0.1, 2.0]),
          ("differentiate('spectral')", _p(tubes.differentiate, np.arange(32.0), 0.1), "end_order", [2.5, -1, True]),
          ("differentiate('savgol')", _p(tubes.differentiate, np.arange(32.0), 0.1, method="savgol"), "window",
           [2.5, 0, True]),
          ("differentiate('savgol')", _p(tubes.differentiate, np.arange(32.0), 0.1, method="savgol"), "order",
           [2.5, -1, True])]

CASES = [(who, f, name, v) for who, f, name, vs in SWEEP for v in vs]


@pytest.mark.parametrize("who, call, name, value", CASES,
                         ids=[f"{w}-{n}={v!r}" for w, _, n, v in CASES])
def test_sweep(who, call, name, value):
    msg = refused(lambda: call(**{name: value}), who, name, value)
    # a bool is said to be no number, not 'out of range' (True is not 1 here)
    if isinstance(value, (bool, str)):
        assert re.search(r"is not (a real number|an integer|True or False)", msg), msg


@pytest.mark.parametrize("call, who, name", [(lambda: tubes.energy(["a", 1, 2, 3]), "energy", "state"),
                                             (lambda: tubes.energies([[True] * 4]), "energies", "states"),
                                             (lambda: tubes.integrate(["0"] * 4, 1.0), "integrate", "state0")])
def test_state_arrays_of_non_numbers(call, who, name):
    with pytest.raises(TypeError, match=rf"^{re.escape(who)}: {name} must be an array of real numbers"):
        call()


def test_saddle_near_of_bools():
    """saddle_near=[True, 0] was read as (1, 0)."""
    with pytest.raises(TypeError, match=r"^transition: saddle_near\[0\] = True is not a real number"):
        tubes.transition(M, dE=[1.0], saddle_near=[True, 0.0])


def test_monte_carlo_check_flag():
    """check='no' was taken as True (a non-empty string)."""
    refused(lambda: tubes.monte_carlo(M, dE=100.0, n_samples=10, check="no"), "monte_carlo", "check", "no")


@pytest.mark.parametrize("key, value", [("index", 0.5), ("index", 7), ("direction", 0.5), ("value", NAN)])
def test_section_boundary_plane_section(key, value):
    """A plane section's index 0.5 was read as 0 (int()), 7 and NaN ended in 'invalid input'."""
    sec = dict({"kind": "plane", "index": 0, "value": 0.0, "direction": 1}, **{key: value})
    refused(lambda: tubes.section_boundary(M, dE=1.0, section=sec), "section_boundary", f"section['{key}']", value)


def test_max_iter_and_omega_bind_take_the_file_s_ranges():
    """&integrator max_iter is 0 .. 1000 and omega_bind > 0 in the input file (their annotations in
    src/workflow/tubes_config.f90); Python refuses what the file refuses, with the reader's words,
    and keeps its own 0 for omega_bind (Tao's default, the file's 200)."""
    msg = refused(lambda: tubes.integrate(X0, 0.1, method="gauss4", h=0.01, max_iter=1001),
                  "integrate", "max_iter", 1001)
    assert "0 .. 1000" in msg, msg
    refused(lambda: tubes.Integrator(tubes.Model(), method="gauss4", h=0.01, max_iter=-1), "Integrator", "max_iter", -1)
    assert tubes.integrate(X0, 0.1, method="tao2", h=0.01, omega_bind=0)["status"] == 0
    a = tubes.integrate(X0, 0.1, method="tao2", h=0.01, omega_bind=0)
    b = tubes.integrate(X0, 0.1, method="tao2", h=0.01, omega_bind=200.0)
    assert np.array_equal(a["state"], b["state"])
