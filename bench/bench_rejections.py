"""Step rejections of DOP853 (issue 16: 'find out why first'). Prints, for the rolling ball released
from rest (input/paper.nml's trajectory and lower releases) and for Henon-Heiles, the accepted and
rejected steps of tubes' DOP853 over T seconds, and for the ball the same count by scipy's DOP853
(Hairer's method with other controller constants: safety 0.9, factors 0.2..10) on the same
right-hand side (tubes.vector_field) over a shorter span. Usage: .venv/bin/python
bench/bench_rejections.py [T] (default 1000 s; scipy runs T/5). Results: docs/integrators.md."""
import sys
import time

import numpy as np
from scipy.integrate import solve_ivp

import tubes

T = float(sys.argv[1]) if len(sys.argv) > 1 else 1000.0
TOLS = (1e-6, 1e-8, 1e-10, 1e-12)


def frac(acc, rej):
    return rej / (acc + rej)


def row(name, x0, model, e_sad):
    for tol in TOLS:
        r = tubes.integrate(x0, T, dt_out=T, model=model, method="dop853", rtol=tol, atol=tol)
        print(f"| {name} | {tubes.energy(x0, model) - e_sad:.6g} | {tol:.0e} | {r['nsteps']} | "
              f"{r['nrejected']} | {frac(r['nsteps'], r['nrejected']):.3f} |")


def main():
    ball = tubes.Model()
    e_s = [e for n, e in zip(tubes.equilibria(ball)["name"], tubes.equilibria(ball)["energy"]) if n == "S12"][0]
    print(f"tubes DOP853 over {T:g} s (rtol = atol = tol); dE above the model's rank-1 saddle")
    print("| model | dE | tol | accepted | rejected | rejected fraction |")
    print("|---|---|---|---|---|---|")
    for y in (12.614863819914357, 11.0, 9.5):
        row("rolling_ball from rest at (4, %.3g)" % y, np.array([4.0, y, 0.0, 0.0]), ball, e_s)
    hh = tubes.Model(system="henon_heiles")
    row("henon_heiles", np.array([0.0, 0.1, 0.35, 0.0]), hh, 1 / 6)
    print(f"\nscipy DOP853 on the same ball right-hand side over {T / 5:g} s")
    print("| tol | accepted | rejected (from nfev) | rejected fraction | s |")
    print("|---|---|---|---|---|")
    x0 = np.array([4.0, 12.614863819914357, 0.0, 0.0])
    for tol in TOLS:
        t0 = time.time()
        s = solve_ivp(lambda t, x: tubes.vector_field(x, ball), (0, T / 5), x0, method="DOP853",
                      rtol=tol, atol=tol)
        acc = len(s.t) - 1
        rej = (s.nfev - 1 - 12 * acc) // 11      # 12 evaluations per accepted step, 11 per rejected
        print(f"| {tol:.0e} | {acc} | {rej} | {frac(acc, rej):.3f} | {time.time() - t0:.1f} |")


if __name__ == "__main__":
    main()
