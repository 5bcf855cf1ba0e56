"""Ensembles in lanes against heyoka's batch mode and tubes' own one-at-a-time integrator (issue 36).

64 distinct starts near the dE = 1500 trajectory (at rest, x and y moved by up to 0.1 cm from
(4, 12.614863819914357) cm, a fixed seed; the first start is that one, unmoved, so that its error
is known: make bench's ensemble row, bench_integrators.py), 10 s each, one thread, rtol = atol = tol. Per tol,
interleaved round by round (the machine's speed drifts within a minute), best of `rounds`:
  tubes lanes     tubes.ensemble(method='taylor', threads=1), the lanes' driver built for this
                  processor (its widest: x86-64-v4 with AVX-512; docs/integrators-taylor.md)
  lanes x86-64    the same with the driver's build for any x86-64 (TUBES_LANES_DRIVER=x86-64:
                  SSE2), on x86-64 processors only
  tubes alone     a kept tubes.Integrator('taylor'), the starts one after another
  heyoka batch    taylor_adaptive_batch at hy.recommended_simd_size(), 64/width batches
  heyoka scalar   a kept taylor_adaptive, the starts one after another
Prints the times per trajectory and the ratios lanes / heyoka batch, alone / lanes and the
driver's own gain (lanes / lanes x86-64) of the same rounds. Usage: python bench/bench_lanes.py [rounds]"""
import os
import pathlib
import platform
import sys
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "python"))
sys.path.insert(0, str(ROOT / "bench"))
import tubes  # noqa: E402
from bench_integrators import X0, T_END, M, heyoka_system  # noqa: E402

NB = 64
TOLS = (1e-6, 1e-8, 1e-10)


def starts(nb=NB, seed=36):
    rng = np.random.default_rng(seed)
    s = np.tile(X0, (nb, 1))
    s[1:, :2] += rng.uniform(-0.1, 0.1, size=(nb - 1, 2))
    return s


def measure(tol, rounds=7):
    """Best time per trajectory of each family over `rounds` interleaved rounds, and each family's
    final states (64, 4)."""
    import heyoka as hy
    st = starts()
    bw = hy.recommended_simd_size()

    def ens_with(driver):
        def ens():
            if driver:
                os.environ["TUBES_LANES_DRIVER"] = driver
            else:
                os.environ.pop("TUBES_LANES_DRIVER", None)
            return tubes.ensemble(st, T_END, model=M, method="taylor", rtol=tol, atol=tol, threads=1)["state"]
        return ens
    ens = ens_with(None)
    ens()                                                     # kernels built/loaded: not timed
    it = tubes.Integrator(M, method="taylor", rtol=tol, atol=tol)
    tb = hy.taylor_adaptive_batch(heyoka_system(), np.ascontiguousarray(st[:bw].T), tol=tol)
    ta = hy.taylor_adaptive(heyoka_system(), st[0].copy(), tol=tol)

    def alone():
        return np.array([it.propagate(s, T_END)[0] for s in st])

    def batch():
        out = np.empty_like(st)
        for b in range(0, NB, bw):
            tb.set_time(0.0)
            tb.state[:] = st[b:b + bw].T
            tb.propagate_until(T_END)
            out[b:b + bw] = tb.state.T
        return out

    def scalar():
        out = np.empty_like(st)
        for i, s in enumerate(st):
            ta.time = 0.0
            ta.state[:] = s
            ta.propagate_until(T_END)
            out[i] = ta.state
        return out
    fns = {"tubes lanes": ens, "tubes alone": alone, "heyoka batch": batch, "heyoka scalar": scalar}
    if platform.machine() == "x86_64":
        fns["lanes x86-64"] = ens_with("x86-64")
    best = {k: np.inf for k in fns}
    res = {}
    for _ in range(rounds):
        for k, f in fns.items():
            t0 = time.perf_counter()
            res[k] = f()
            best[k] = min(best[k], time.perf_counter() - t0)
    os.environ.pop("TUBES_LANES_DRIVER", None)
    for k in ("tubes lanes", "lanes x86-64"):
        assert k not in res or np.array_equal(res[k], res["tubes alone"]), f"{k} differ from the lone integrator"
    return {k: v / NB for k, v in best.items()}, res


def main():
    import heyoka as hy
    rounds = int(sys.argv[1]) if len(sys.argv) > 1 else 7
    print(f"64 distinct starts, 10 s, one thread, best of {rounds} interleaved rounds; "
          f"heyoka batch width {hy.recommended_simd_size()}")
    print("| tol | tubes lanes [ms] | tubes alone [ms] | heyoka batch [ms] | heyoka scalar [ms] | "
          "lanes / heyoka batch | alone / lanes | heyoka scalar / batch | lanes / lanes x86-64 | "
          "max |tubes - heyoka| |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for tol in TOLS:
        b, res = measure(tol, rounds)
        dev = np.max(np.abs(res["tubes lanes"] - res["heyoka batch"]))
        gain = f"{b['tubes lanes'] / b['lanes x86-64']:.2f}" if "lanes x86-64" in b else "-"
        print(f"| {tol:.0e} | {b['tubes lanes'] * 1e3:.4f} | {b['tubes alone'] * 1e3:.4f} | "
              f"{b['heyoka batch'] * 1e3:.4f} | {b['heyoka scalar'] * 1e3:.4f} | "
              f"{b['tubes lanes'] / b['heyoka batch']:.2f} | {b['tubes alone'] / b['tubes lanes']:.2f} | "
              f"{b['heyoka scalar'] / b['heyoka batch']:.2f} | {gain} | {dev:.1e} |", flush=True)

if __name__ == "__main__":
    main()
