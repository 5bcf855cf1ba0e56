"""The Taylor method's map (docs/stability.md, section 5; make bench): accuracy, energy and events
against the tolerance on the rolling ball at three energies, and where its steps shrink (the
CR3BP near the Moon). Measured through the public Python API; the tables between the
bench_taylor markers of docs/stability.md are rewritten.

1. For dE = 100, 1500, 4000 (the starts of docs/stability.md) and tol = 1e-3 .. 1e-15: the order,
   the steps over 10 s, the error at t = 2 s against the real128 reference (tol 1e-26), the energy
   error over 10 s, and any failure.
2. Section U1 (both branches) over 5 s: the crossings the Taylor method finds at each tolerance
   against DOP853's at tol 1e-13 (both agree to better than 1e-6 over these 5 s at dE = 100 and
   1500, so the lists are comparable one to one): missed and spurious crossings, the largest time
   difference, and the crossings that fell within 0.05 s of another in the same Taylor step.
3. The planar CR3BP (Earth-Moon) on an orbit passing the Moon: step size against distance to the
   Moon (the series' radius of convergence is the distance to the singularity 1/r2).
"""
import datetime
import pathlib
import re
import sys
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "python"))
import tubes  # noqa: E402

STARTS = {100: 10.293276274312342, 1500: 12.614863819914357, 4000: 15.301686351694903}
TOLS = [1e-3, 1e-5, 1e-7, 1e-9, 1e-11, 1e-13, 1e-15]
M = tubes.Model()


def part1():
    rows = []
    for de, y in STARTS.items():
        x0 = np.array([4.0, y, 0.0, 0.0])
        ref = np.asarray(tubes.reference_solution(x0, 2.0, tol=1e-26))
        e0 = tubes.energy(x0, M)
        for tol in TOLS:
            try:
                a = tubes.integrate(x0, 2.0, model=M, method="taylor", rtol=tol, atol=tol)
                err = np.abs(a["state"][-1] - ref).max() / np.abs(ref).max()
                b = tubes.trajectory(x0, 10.0, dt_out=0.02, model=M, method="taylor", rtol=tol, atol=tol)
                de_max = np.abs(b["energy"] / e0 - 1).max()
                rows.append((de, tol, b["nsteps"], err, de_max, ""))
            except tubes.TubesError as exc:
                rows.append((de, tol, 0, np.nan, np.nan, f"status {exc.code}"))
            print(f"part 1: dE {de} tol {tol:.0e}: {rows[-1]}", flush=True)
    return rows


def part2():
    rows = []
    for de in (100, 1500):
        x0 = np.array([4.0, STARTS[de], 0.0, 0.0])
        ref = tubes.integrate(x0, 5.0, model=M, method="dop853", rtol=1e-13, atol=1e-13, section="U1")["crossings"]
        for tol in TOLS:
            c = tubes.integrate(x0, 5.0, model=M, method="taylor", rtol=tol, atol=tol, section="U1")["crossings"]
            tr, tt = list(ref["t"]), list(c["t"])
            used, dmax, missed = set(), 0.0, 0
            for t in tr:
                j = int(np.argmin(np.abs(np.asarray(tt) - t))) if tt else -1
                if j >= 0 and abs(tt[j] - t) < 0.05 and j not in used:
                    used.add(j)
                    dmax = max(dmax, abs(tt[j] - t))
                else:
                    missed += 1
            spurious = len(tt) - len(used)
            close = int(np.sum(np.diff(tt) < 0.05)) if len(tt) > 1 else 0
            rows.append((de, tol, len(tr), len(tt), missed, spurious, dmax, close))
            print(f"part 2: dE {de} tol {tol:.0e}: {rows[-1]}", flush=True)
    return rows


def part3():
    """A hyperbolic flyby of the Moon from periapsis (on the x axis, r2 = 0.005, about the Moon's
    radius, at 1.6 times the circular speed): the Taylor steps along the outbound leg. The steps
    from one start do not depend on where the run ends (but the last), so the number of steps
    N(T) to reach T gives the mean step over [0.5 T, 1.5 T] as T / (N(1.5 T) - N(0.5 T))."""
    m = tubes.Model(system="cr3bp")
    mu = m.params()[0]
    xm = 1 - mu                                     # the Moon
    d, v = 0.005, 1.6 * np.sqrt(mu / 0.005)
    x0 = np.array([xm + d, 0.0, 0.0, v + xm + d])   # canonical p = (vx - y, vy + x)
    kw = dict(model=m, method="taylor", rtol=1e-12, atol=1e-12)
    tr = tubes.trajectory(x0, 0.5, dt_out=1e-5, **kw)
    t, x = tr["t"], tr["state"]
    r2 = np.hypot(x[:, 0] - xm, x[:, 1])
    rows = []
    for target in (0.006, 0.01, 0.02, 0.05, 0.1, 0.2):
        i = int(np.argmax(r2 >= target))
        if r2[i] < target:
            continue
        ti = t[i]
        n_lo = tubes.integrate(x0, 0.5 * ti, **kw)["nsteps"]
        n_hi = tubes.integrate(x0, 1.5 * ti, **kw)["nsteps"]
        h = ti / max(n_hi - n_lo, 1)
        vel = float(np.hypot(x[i, 2] + x[i, 1], x[i, 3] - x[i, 0]))   # speed in the rotating frame
        rows.append((float(r2[i]), vel, n_hi - n_lo, h, h * vel / r2[i]))
        print(f"part 3: r2 {r2[i]:.3e} speed {vel:.3f} steps {n_hi - n_lo} h {h:.2e} h v / r2 {h*vel/r2[i]:.3f}",
              flush=True)
    return mu, d, rows


def write(p1, p2, p3, elapsed):
    md = ROOT / "docs" / "stability.md"
    text = md.read_text()
    t1 = ["| dE | tol | order | steps in 10 s | error at 2 s (real128) | max energy error over 10 s | failure |",
          "|---|---|---|---|---|---|---|"]
    for de, tol, ns, err, dem, fail in p1:
        order = max(2, int(np.ceil(-np.log(tol) / 2 + 1)))
        t1.append(f"| {de} | {tol:.0e} | {order} | {ns} | {err:.1e} | {dem:.1e} | {fail or '-'} |")
    t2 = ["| dE | tol | DOP853 1e-13 crossings | Taylor crossings | missed | spurious | max time difference [s] | pairs < 0.05 s apart |",
          "|---|---|---|---|---|---|---|---|"]
    for de, tol, nr, nt, mi, sp_, dm, cl in p2:
        t2.append(f"| {de} | {tol:.0e} | {nr} | {nt} | {mi} | {sp_} | {dm:.1e} | {cl} |")
    mu, d, rows = p3
    t3 = [f"CR3BP (Earth-Moon, mu = {mu:.6f}), a hyperbolic flyby of the Moon from periapsis r2 = {d} "
          "(about the Moon's radius) at 1.6 times the circular speed, tol 1e-12; the mean step around "
          "the time T the outbound leg reaches r2 (over [0.5 T, 1.5 T]; v the speed in the rotating frame):", "",
          "| r2 | speed v | steps in [0.5 T, 1.5 T] | mean step h | h v / r2 |", "|---|---|---|---|---|"]
    for r, vel, ns, h, q in rows:
        t3.append(f"| {r:.3g} | {vel:.3f} | {ns} | {h:.2e} | {q:.3f} |")
    block = {"taylor_tol": t1, "taylor_events": t2, "taylor_cr3bp": t3,
             "taylor_machine": [f"{datetime.date.today().isoformat()}; {elapsed:.0f} s"]}
    for k, lines in block.items():
        pat = re.compile(rf"(<!-- bench_{k} begin -->\n).*?(<!-- bench_{k} end -->)", re.S)
        if pat.search(text):
            text = pat.sub(lambda mm: mm.group(1) + "\n".join(lines) + "\n" + mm.group(2), text)
        else:
            print(f"docs/stability.md has no bench_{k} markers: not written", file=sys.stderr)
    md.write_text(text)


def main():
    t0 = time.perf_counter()
    p1 = part1()
    p2 = part2()
    p3 = part3()
    write(p1, p2, p3, time.perf_counter() - t0)
    print("updated docs/stability.md (section 5)")


if __name__ == "__main__":
    main()
