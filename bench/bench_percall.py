"""The cost of one tubes.integrate() call above the same integration by a kept tubes.Integrator
(issue 36: at most 20 us; make bench). tubes.integrate keeps an integrator per model, method and
options (the model and its Taylor kernel made once) and restarts it at t = 0; what remains is the
Python layer's checks and arrays and the sampling observer. Interleaved rounds, best of 7 per
case, one thread; the dE = 1500 start of the ball (docs/benchmarks.md, "Work-precision"). The
section between the bench_percall markers of docs/benchmarks.md is rewritten."""
import datetime
import platform
import sys
import time

import numpy as np

sys.path.insert(0, str(__import__("pathlib").Path(__file__).resolve().parent.parent / "python"))
import tubes  # noqa: E402
from benchdoc import write_section  # noqa: E402

Z0 = np.array([4.0, 12.614863819914357, 0.0, 0.0])
CALLS = 200


def best(f, rounds):
    return min(rounds) * 1e6 / CALLS


def main():
    m = tubes.Model()
    rows = []
    for method in ("taylor", "dop853"):
        for tol in (1e-6, 1e-10):
            it = tubes.Integrator(m, method=method, rtol=tol, atol=tol)
            for t_end in (1e-3, 10.0):
                a = tubes.integrate(Z0, t_end, model=m, method=method, rtol=tol, atol=tol)
                x, _ = it.propagate(Z0, t_end)
                assert np.array_equal(a["state"][-1], x)            # the same integration
                ti, tp = [], []
                for _ in range(7):                                  # interleaved
                    t0 = time.perf_counter()
                    for _ in range(CALLS):
                        tubes.integrate(Z0, t_end, model=m, method=method, rtol=tol, atol=tol)
                    ti.append(time.perf_counter() - t0)
                    t0 = time.perf_counter()
                    for _ in range(CALLS):
                        it.propagate(Z0, t_end)
                    tp.append(time.perf_counter() - t0)
                i, p = best(None, ti), best(None, tp)
                rows.append((method, tol, t_end, a["nsteps"], i, p, i - p))
                print(f"bench_percall: {method} tol {tol:.0e} t_end {t_end:g}: integrate {i:.1f} us, "
                      f"Integrator {p:.1f} us, above {i - p:.1f} us", flush=True)
            it.close()
    lines = ["<!-- bench_percall begin -->", "## One call of tubes.integrate (bench/bench_percall.py)", "",
             f"Measured {datetime.date.today()} on {platform.node()} ({platform.processor() or platform.machine()}), "
             "one thread; interleaved rounds of 200 calls, best of 7. The same integration (the same final "
             "state, checked) by tubes.integrate() and by a kept tubes.Integrator's propagate(); integrate() "
             "also samples its start and end and evaluates their energies. Target (issue 36): at most 20 us "
             "above. Met for short integrations (the call's own cost); a long one also pays the sampler, "
             "called after every step (tens of ns a step) and interpolating the end (DOP853: its 3 "
             "dense-output stages), which propagate() does not: integrate()'s end sample is the "
             "interpolant's, the same bits as the step's end here (checked) but not in general "
             "(DOP853's x_old + (x_new - x_old)).", "",
             "| method | tol | t_end [s] | steps | integrate [us] | Integrator [us] | above [us] |",
             "| --- | --- | --- | --- | --- | --- | --- |"]
    lines += [f"| {r[0]} | {r[1]:.0e} | {r[2]:g} | {r[3]} | {r[4]:.1f} | {r[5]:.1f} | {r[6]:.1f} |" for r in rows]
    lines += ["<!-- bench_percall end -->"]
    write_section("bench_percall", lines)


if __name__ == "__main__":
    main()
