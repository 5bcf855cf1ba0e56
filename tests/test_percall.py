"""Issue 36, per-call cost: tubes.integrate keeps an integrator per model, method and options
(the model and its Taylor kernel made once: ~60 us a call before, ~15 us now, bench/bench_percall.py)
and restarts it at t = 0. Its results must be the bits of a new integrator's (the core's
`trajectory`, which makes everything anew): for the kept methods, with sections, for many starts
in any order, for two models side by side, after a failed call, and from two threads."""
import threading

import numpy as np
import pytest
import tubes
from tubes import METHODS, _lib

Z0 = np.array([4.0, 12.614863819914357, 0.0, 0.0])
STARTS = [Z0 + np.array([0.01 * k, -0.02 * k, 0.3 * k, -0.1 * k]) for k in range(6)]
KEYS = ("t", "state", "energy")


def fresh(model, z, t_end, method, tol, dt_out=None, kind=0, level=0.0, direction=0, mc=1):
    """The integration by a new integrator (the core's trajectory, no kept state)."""
    dt = t_end if dt_out is None else dt_out
    nmax = int(np.floor(t_end / dt * (1 + 1e-12))) + 2
    code = tubes._method(METHODS[method], model, tol)
    stat, n, t, st, en, nc, ct, cx, cd, cnt = _lib().trajectory(
        model.name, model.params(), np.asarray(z, float), float(t_end), float(dt), code, tol, tol, 0.0,
        10_000_000, 0.0, 1, 0, kind, level, direction, 0, mc, nmax)
    return {"t": t[:n], "state": st[:, :n].T, "energy": en[:n], "stat": stat, "ct": ct[:nc], "cx": cx[:, :nc].T,
            "counters": cnt}


def same(a, b):
    for k in KEYS:
        assert np.array_equal(a[k], b[k]), k


@pytest.mark.parametrize("method", ["taylor", "dop853", "auto"])
def test_kept_integrations_are_new_integrations_bit_for_bit(method):
    m = tubes.Model()
    for tol in (1e-6, 1e-10):
        for z in STARTS + STARTS[::-1]:
            r = tubes.integrate(z, 2.0, dt_out=0.25, model=m, method=method, rtol=tol, atol=tol)
            f = fresh(m, z, 2.0, method, tol, dt_out=0.25)
            same(r, f)
            assert [r["nfev"], r["nsteps"], r["nrejected"], r["niter"]] == list(f["counters"])


def test_kept_integrations_with_a_section_and_two_models():
    ball, hh = tubes.Model(), tubes.Model(system="henon_heiles")
    other = tubes.Model(alpha=0.08)            # the ball with another parameter: its own integrator
    hz = np.array([0.0, 0.1, 0.35, 0.05])
    for _ in range(2):
        for z in STARTS[:3]:
            r = tubes.integrate(z, 3.0, model=ball, method="taylor", rtol=1e-9, atol=1e-9, section="theta",
                                level=45.0, direction=1)
            f = fresh(ball, z, 3.0, "taylor", 1e-9, kind=1, level=np.pi / 4, direction=1, mc=10_000)
            same(r, f)
            assert np.array_equal(r["crossings"]["t"], f["ct"]) and np.array_equal(r["crossings"]["state"], f["cx"])
            r2 = tubes.integrate(z, 3.0, model=other, method="taylor", rtol=1e-9, atol=1e-9)
            same(r2, fresh(other, z, 3.0, "taylor", 1e-9))
            assert not np.array_equal(r2["state"], tubes.integrate(z, 3.0, model=ball, method="taylor", rtol=1e-9,
                                                                    atol=1e-9)["state"])
        rh = tubes.integrate(hz, 20.0, model=hh, method="dop853", rtol=1e-10, atol=1e-10, section="y", direction=1)
        fh = fresh(hh, hz, 20.0, "dop853", 1e-10, kind=3, direction=1, mc=10_000)
        same(rh, fh)
        assert np.array_equal(rh["crossings"]["t"], fh["ct"])


def test_a_failed_call_leaves_the_kept_integrator_as_new():
    m = tubes.Model()
    with pytest.raises(tubes.TubesError):
        tubes.integrate(Z0, 10.0, model=m, method="taylor", rtol=1e-8, atol=1e-8, max_steps=3)
    r = tubes.integrate(Z0, 10.0, model=m, method="taylor", rtol=1e-8, atol=1e-8, max_steps=3_000_000)
    same(r, fresh_max_steps(m, Z0, 10.0, 1e-8, 3_000_000))


def fresh_max_steps(model, z, t_end, tol, max_steps):
    stat, n, t, st, en, *_ = _lib().trajectory(
        model.name, model.params(), np.asarray(z, float), t_end, t_end, METHODS["taylor"], tol, tol, 0.0, max_steps,
        0.0, 1, 0, 0, 0.0, 0, 0, 1, 3)
    return {"t": t[:n], "state": st[:, :n].T, "energy": en[:n]}


def test_two_threads_get_the_serial_bits():
    m = tubes.Model()
    serial = [tubes.integrate(z, 1.5, dt_out=0.5, model=m, method="taylor", rtol=1e-9, atol=1e-9) for z in STARTS]
    got = {}

    def work(tag, order):
        for i in order:
            got[(tag, i)] = tubes.integrate(STARTS[i], 1.5, dt_out=0.5, model=m, method="taylor", rtol=1e-9,
                                            atol=1e-9)
    ths = [threading.Thread(target=work, args=(0, range(6))), threading.Thread(target=work, args=(1, range(5, -1, -1)))]
    for th in ths:
        th.start()
    for th in ths:
        th.join()
    for (tag, i), r in got.items():
        same(r, serial[i])


def test_kept_argument_checks_refuse_as_before():
    """integrate keeps its checked arguments per values and types (_integrate_args): a value
    refused is refused again, and one of another type is checked afresh (True for an integer, a
    string for a number), whatever was accepted before with an equal value."""
    m = tubes.Model()
    ok = tubes.integrate(Z0, 0.01, model=m, max_steps=10_000, rtol=1e-8, atol=1e-8)
    for kw, err in ((dict(max_steps=True), TypeError), (dict(max_steps="10000"), TypeError),
                    (dict(rtol=2.0), ValueError), (dict(rtol=1), ValueError), (dict(direction=2), ValueError)):
        for _ in range(2):
            with pytest.raises(err):
                tubes.integrate(Z0, 0.01, model=m, **{"max_steps": 10_000, "rtol": 1e-8, "atol": 1e-8, **kw})
    again = tubes.integrate(Z0, 0.01, model=m, max_steps=10_000, rtol=1e-8, atol=1e-8)
    same(ok, again)
    once = tubes.integrate(Z0, 0.01, model=m, max_steps=10_000.0, rtol=1e-8, atol=1e-8)   # as before: accepted
    same(ok, once)


def test_the_core_refuses_a_nan_end_time():
    """The core's trajectory (the C API's and Python's path under tubes.integrate's checks) refuses
    t_end or dt_out = NaN (TUBES_EINPUT, -1) instead of returning the start as the state at t = NaN
    (its 't_end < 0' let a NaN through)."""
    m = tubes.Model()
    for t_end, dt in ((float("nan"), 1.0), (1.0, float("nan"))):
        r = _lib().trajectory(m.name, m.params(), Z0, t_end, dt, METHODS["dop853"], 1e-8, 1e-8, 0.0,
                              10_000_000, 0.0, 1, 0, 0, 0.0, 0, 0, 1, 3)
        assert r[0] == -1, (t_end, dt, r[0])
    r = _lib().trajectory(m.name, m.params(), Z0, 1.0, 1.0, METHODS["dop853"], 1e-8, 1e-8, 0.0,
                          10_000_000, 0.0, 1, 0, 0, 0.0, 0, 0, 1, 3)
    assert r[0] == 0
