"""Stability and failure map of the integration methods (integrators issue, benchmark 3).

Run: .venv/bin/python bench/bench_stability.py [--out DIR] [--jobs N]
Writes docs/stability_{accuracy,gauss,tao,tao_map,events}.png and the tables between the
<!-- bench_stability:NAME begin/end --> markers of docs/stability.md (the prose around them is
kept; the script never creates that file). Only the public Python API of tubes is used. About
2 minutes on the 2 cores (worker processes: --jobs, default 2).

Problem: the rolling ball on the four-well surface, started at rest at (4, y) cm with y chosen so
that E - E_e = dE for dE = 100, 1500, 4000 (cm/s)^2 above the saddle energy E_e (dE = 1500 is the
issue's start (4, 12.614863819914357)).

1. fixed-step methods against h: final-state error at t = 2 s against the real128 reference,
   max energy error over 10 s, and the stability edge (the smallest h at which a 10 s run fails:
   TubesError, a non-finite state or energy, or max |E - E0|/E0 > 1), refined on a fine grid
   (ratio 1.01) with the runs above it that still work (the edge is ragged); the same edge for
   a 100 s run.
2. gauss*: the largest h at which the stage iteration converges (newton and fixed point, default
   max_iter; newton also at max_iter = 1000), explained by the linearised contraction factors of
   both iterations computed along the reference orbit (h A (x) J, J by central differences of
   tubes.vector_field).
3. tao*: error (2 s) and energy error (100 s) against omega_bind at h = 1/1024 s, and a
   stability map over (omega, 2 omega h) from which the edge h against omega is read.
4. section U1 (theta = pi/4, both branches): crossings missed or spurious against a reference
   list, separated into trajectory divergence and event detection (see docs/stability.md).
"""
import argparse
import datetime
import multiprocessing as mp
import os
import pathlib
import platform
import sys
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "python"))
import tubes  # noqa: E402

E_SADDLE = 3304.2423826          # [(cm/s)^2] energy of the saddles S12 ... (tubes.equilibria)
DES = (100.0, 1500.0, 4000.0)    # [(cm/s)^2] energies above the saddle
Y_ISSUE = 12.614863819914357     # [cm] the issue's start (4, Y_ISSUE) at dE = 1500
T_ACC = 2.0                      # [s] accuracy: final-state error at this time
T_STAB = 10.0                    # [s] stability horizon (and energy error)
T_STAB_LONG = 100.0              # [s] longer stability horizon
ACC_LEVEL = 1e-3                 # relative error that counts as "accuracy lost"
BLOWUP = 1.0                     # max |E - E0|/E0 above this counts as a blow-up
REF_TOL = 1e-26                  # real128 reference tolerance (5e-23 relative at 10 s: docs/events.md)
MAX_STEPS = 200_000_000

FIXED = [("rk4", "-"), ("tao2", "-"), ("tao4", "-"), ("tao6", "-"),
         ("gauss4", "newton"), ("gauss4", "fixed_point"), ("gauss6", "newton"),
         ("gauss6", "fixed_point"), ("gauss8", "newton"), ("gauss8", "fixed_point")]
FIXED_NAMES = ("rk4", "tao2", "tao4", "tao6", "gauss4", "gauss6", "gauss8")
# smallest h scanned per method, 2^-k s (below it the error is at roundoff or the run is long)
H_MIN_EXP = {"rk4": 12, "tao2": 13, "tao4": 13, "tao6": 12, "gauss4": 11, "gauss6": 10, "gauss8": 9}


def label(method, solver):
    return method if solver == "-" else f"{method} {'N' if solver == 'newton' else 'FP'}"


def start_point(de):
    """(x, y, 0, 0) at rest with E - E_e = de: x = 4 cm, y from brentq on tubes.energy."""
    from scipy.optimize import brentq
    if de == 1500.0:
        return np.array([4.0, Y_ISSUE, 0.0, 0.0])
    y = brentq(lambda y: tubes.energy([4.0, y, 0.0, 0.0]) - (E_SADDLE + de), 10.0, 25.0,
               xtol=1e-14, rtol=1e-15)
    return np.array([4.0, y, 0.0, 0.0])


def rel_err(x, ref):
    return float(np.max(np.abs(np.asarray(x) - ref)) / np.max(np.abs(ref)))


# ---------------------------------------------------------------------------------------------
# single runs (worker side)

def run_fixed(x0, method, h, solver="-", t_end=T_STAB, omega=0.0, max_iter=0):
    """One fixed-step run to t_end, sampled at step ends (every ~0.02 s): status, max energy
    error, iterations per step. code 0 = ok, TubesError code, or 99 = non-finite/blow-up."""
    kw = dict(method=method, h=h, max_steps=MAX_STEPS, omega_bind=omega, max_iter=max_iter)
    if solver != "-":
        kw["solver"] = solver
    every = max(1, int(round(0.02 / h)))
    try:
        with np.errstate(all="ignore"):
            r = tubes.integrate(x0, t_end, dt_out=h * every, **kw)
    except tubes.TubesError as exc:
        return {"code": exc.code, "de": np.nan, "it": np.nan}
    with np.errstate(all="ignore"):
        de = np.abs(r["energy"] / r["energy"][0] - 1)
    dmax = float(np.max(de)) if np.all(np.isfinite(de)) and np.all(np.isfinite(r["state"])) else np.inf
    code = 0 if dmax <= BLOWUP else 99
    return {"code": code, "de": dmax, "it": r["niter"] / max(r["nsteps"], 1), "final": r["state"][-1]}


def final_state(x0, method, h, solver="-", t_end=T_ACC, omega=0.0):
    kw = dict(method=method, h=h, max_steps=MAX_STEPS, omega_bind=omega)
    if solver != "-":
        kw["solver"] = solver
    try:
        with np.errstate(all="ignore"):
            return tubes.integrate(x0, t_end, **kw)["state"][-1]
    except tubes.TubesError:
        return None


def stable(x0, method, h, solver, t_end, omega=0.0, max_iter=0):
    return run_fixed(x0, method, h, solver, t_end, omega, max_iter)["code"] == 0


def bisect_edge(x0, method, solver, h_ok, h_bad, t_end, omega=0.0, max_iter=0, n=6):
    """Geometric bisection of [h_ok (stable), h_bad (fails)]: returns the final bracket."""
    for _ in range(n):
        hm = np.sqrt(h_ok * h_bad)
        if stable(x0, method, hm, solver, t_end, omega, max_iter):
            h_ok = hm
        else:
            h_bad = hm
    return h_ok, h_bad


# ---------------------------------------------------------------------------------------------
# tasks (one per worker call; all arguments picklable)

def task_reference(args):
    de, t_end, tol = args
    x0 = start_point(de)
    t0 = time.perf_counter()
    return de, t_end, tubes.reference_solution(x0, t_end, tol), time.perf_counter() - t0


def task_scan(args):
    """Part 1: one (energy, method, solver, h): error at T_ACC, 10 s stability run."""
    de, method, solver, h = args
    x0 = start_point(de)
    xf = final_state(x0, method, h, solver)
    st = run_fixed(x0, method, h, solver)
    st.pop("final", None)
    return (de, method, solver, h), {"x2": xf, **st}


def task_edge(args):
    """Part 1/2: the stability edge on a fine grid (ratio 1.01) from 0.59 to 2 times the first
    failing coarse-grid h (10 s runs): the first failure from below (lo, hi bracket), its
    failure code, and the stable steps above it (the edge is ragged); then the first failure
    from below of 100 s runs (grid down to 0.6 lo)."""
    de, method, solver, h_ok, h_bad, max_iter = args
    x0 = start_point(de)
    grid = h_bad * 1.01 ** np.arange(-53, 71)      # 0.59 ... 2 x h_bad (h_ok = 0.84 h_bad)
    res = [run_fixed(x0, method, h, solver, T_STAB, max_iter=max_iter) for h in grid]
    while res[0]["code"] != 0:                  # the edge lies below the fine grid: extend it
        grid = np.concatenate([[grid[0] / 1.01], grid])
        res.insert(0, run_fixed(x0, method, grid[0], solver, T_STAB, max_iter=max_iter))
    ok = np.array([r["code"] == 0 for r in res])
    i = int(np.argmax(~ok)) if (~ok).any() else len(grid)
    above = [(float(grid[k]), res[k]["de"]) for k in range(i, len(grid)) if ok[k]]
    out = {"lo": float(grid[i - 1]), "hi": float(grid[min(i, len(grid) - 1)]),
           "code": res[min(i, len(grid) - 1)]["code"], "above": above, "n_above": len(grid) - i,
           "codes": sorted({res[k]["code"] for k in range(i, len(grid)) if not ok[k]})}
    # 100 s: from a stable step (0.6 lo, lowered by 0.8 until stable) upwards by 1.01 to the
    # first failure (at the latest hi, where the first 10 s already fail)
    h = 0.6 * out["lo"]
    k = 0
    while not stable(x0, method, h, solver, T_STAB_LONG, max_iter=max_iter) and k < 40:
        h *= 0.8
        k += 1
    while h * 1.01 < out["hi"] and stable(x0, method, h * 1.01, solver, T_STAB_LONG, max_iter=max_iter):
        h *= 1.01
    out["lo100"], out["hi100"] = float(h), float(min(h * 1.01, out["hi"]))
    return (de, method, solver, max_iter), out


def task_gauss_scan(args):
    """Part 2: newton with max_iter = 1000, grid scan of the 10 s run."""
    de, method, h, max_iter = args
    x0 = start_point(de)
    st = run_fixed(x0, method, h, "newton", T_STAB, max_iter=max_iter)
    st.pop("final", None)
    return (de, method, h, max_iter), st


def task_tao_omega(args):
    """Part 3: tao at fixed h and omega: error at T_ACC and max energy error over 100 s."""
    de, method, omega, h = args
    x0 = start_point(de)
    xf = final_state(x0, method, h, "-", T_ACC, omega)
    st = run_fixed(x0, method, h, "-", T_STAB_LONG, omega)
    return (de, method, omega), {"x2": xf, "de": st["de"], "code": st["code"]}


THETA = np.concatenate([np.logspace(-3, 0, 31)[:-1], np.arange(1.0, 8.0001, 0.1)])  # 2 omega h
H_MAP = (1e-4, 0.5)    # [s] map cells with h outside this range are not run (cost)


def task_tao_map(args):
    """Part 3: one column (method, omega) of the stability map over theta = 2 omega h (10 s runs):
    max energy error or failure per theta; the blow-up edge (first failing theta from below,
    refined by bisection) and the first theta whose max |E - E0|/E0 exceeds 1e-3."""
    de, method, omega = args
    x0 = start_point(de)
    col = []
    for th in THETA:
        h = th / (2 * omega)
        if not H_MAP[0] <= h <= H_MAP[1]:
            col.append((th, -999, np.nan))
            continue
        r = run_fixed(x0, method, h, "-", T_STAB, omega)
        col.append((th, r["code"], r["de"]))
    run = [c for c in col if c[1] != -999]
    edge = acc = None
    fails = [i for i, c in enumerate(run) if c[1] != 0]
    if fails and fails[0] > 0:
        lo, hi = bisect_edge(x0, method, "-", run[fails[0] - 1][0] / (2 * omega),
                             run[fails[0]][0] / (2 * omega), T_STAB, omega, n=5)
        edge = (lo, hi)
    bad = [i for i, c in enumerate(run) if not c[2] <= ACC_LEVEL]
    if bad and bad[0] > 0:
        acc = run[bad[0]][0] / (2 * omega)
    return (de, method, omega), {"col": col, "edge": edge, "acc": acc, "omega": omega}


# --- part 4: sections ---------------------------------------------------------------------

T_EV = 50.0            # [s] length of the event runs
DT_CMP = 1.0 / 16      # [s] grid on which trajectories are compared with the reference
DELTA = 1e-3           # trajectory agreement threshold (relative state error)
TRUST = 1e-4           # reference trusted while dop853(1e-13) and gauss8 agree to this
TAU = 0.05             # [s] matching tolerance of crossing times (spacing of crossings >= 0.3 s)


def fine_crossings(t, x):
    """Crossings of U1 (ray theta = pi/4, both branches) from dense samples of one trajectory:
    sign changes of g = y - x with x + y > 0, orientation sign(p_theta), linear interpolation."""
    g = x[:, 1] - x[:, 0]
    s = np.nonzero(((g[:-1] < 0) & (g[1:] >= 0)) | ((g[:-1] > 0) & (g[1:] <= 0)))[0]
    w = g[s] / (g[s] - g[s + 1])
    tc = t[s] + w * (t[s + 1] - t[s])
    xc = x[s] + w[:, None] * (x[s + 1] - x[s])
    keep = xc[:, 0] + xc[:, 1] > 0
    pth = xc[:, 0] * xc[:, 3] - xc[:, 1] * xc[:, 2]
    return tc[keep], np.sign(pth[keep]).astype(int), xc[keep]


def match(ta, da, tb, db, tol):
    """Greedy one-to-one matching of crossing lists a and b (times, directions) within tol.
    Returns (index pairs, unmatched a, unmatched b)."""
    used = np.zeros(len(tb), bool)
    pairs, ua = [], []
    for i, (t, d) in enumerate(zip(ta, da)):
        cand = np.nonzero((~used) & (db == d) & (np.abs(tb - t) <= tol))[0]
        if len(cand):
            j = cand[np.argmin(np.abs(tb[cand] - t))]
            used[j] = True
            pairs.append((i, j))
        else:
            ua.append(i)
    return pairs, ua, list(np.nonzero(~used)[0])


def event_run(x0, method, h=0.0, solver="-", tol=1e-12, dt=None):
    kw = dict(method=method, max_steps=MAX_STEPS, section="U1", max_crossings=100_000)
    if method == "dop853":
        kw.update(rtol=tol, atol=tol)
    else:
        kw.update(h=h)
        if solver != "-":
            kw["solver"] = solver
    if dt is None:
        dt = 1.0 / 1024 if method == "dop853" else h / 8
    with np.errstate(all="ignore"):
        return tubes.integrate(x0, T_EV, dt_out=dt, **kw)


def task_event_reference(args):
    """Part 4: the reference list (dop853 1e-13), its cross-check (gauss8 h = 1/512, both
    solvers) and real128 spot checks of the dop853 reference at 10 and 20 s."""
    de, = args
    x0 = start_point(de)
    ref = event_run(x0, "dop853", tol=1e-13, dt=DT_CMP)
    out = {"t": ref["t"], "x": ref["state"], "ct": ref["crossings"]["t"],
           "cd": ref["crossings"]["direction"], "nsteps": ref["nsteps"]}
    # sampling does not change the integration: the same run without samples ends identically
    bare = tubes.integrate(x0, T_EV, method="dop853", rtol=1e-13, atol=1e-13, section="U1",
                           max_crossings=100_000)
    out["bitwise"] = bool(np.array_equal(bare["state"][-1], ref["state"][-1])
                          and np.array_equal(bare["crossings"]["t"], ref["crossings"]["t"]))
    checks = {}
    for solver in ("fixed_point", "newton"):
        g = event_run(x0, "gauss8", h=1.0 / 512, solver=solver, dt=DT_CMP)
        checks[solver] = {"x": g["state"], "ct": g["crossings"]["t"], "cd": g["crossings"]["direction"]}
    out["gauss8"] = checks
    r128 = {}
    for tt in (10.0, 20.0):
        i = int(round(tt / DT_CMP))
        xr = tubes.reference_solution(x0, tt, 1e-20)
        r128[tt] = (rel_err(ref["state"][i], xr), rel_err(checks["fixed_point"]["x"][i], xr))
    out["r128"] = r128
    return de, out


def task_event_setting(args):
    """Part 4: one (energy, method setting): its crossing list and samples (fine: every h/8 or
    1/1024 s), the detector check on its own dense output, and the same list from a run without
    fine samples (the samples must not change the integration)."""
    de, method, h, solver, tol = args
    x0 = start_point(de)
    try:
        r = event_run(x0, method, h, solver, tol)
    except tubes.TubesError as exc:
        return (de, method, h, solver, tol), {"code": exc.code}
    t, x = r["t"], r["state"]
    ct, cd = r["crossings"]["t"], r["crossings"]["direction"]
    ft, fd, fx = fine_crossings(t, x)
    dt = t[1] - t[0]
    pairs, miss, spur = match(ft, fd, ct, cd, 2 * dt)
    coarse = event_run(x0, method, h, solver, tol, dt=T_EV)
    same = bool(np.array_equal(coarse["crossings"]["t"], ct)
                and np.array_equal(coarse["state"][-1], x[-1]))
    # samples on the comparison grid (every max(h, DT_CMP))
    step = int(round(max(h, DT_CMP) / dt))
    return (de, method, h, solver, tol), {
        "code": 0, "ct": ct, "cd": cd, "tg": t[::step], "xg": x[::step], "nsteps": r["nsteps"],
        "det_missed": [(float(ft[i]), tubes.energy(fx[i]), float(fx[i, 0] * fx[i, 3] - fx[i, 1] * fx[i, 2]))
                       for i in miss],
        "det_spurious": [(float(ct[j]), tubes.energy(r["crossings"]["state"][j]), float(r["crossings"]["p_theta"][j]))
                         for j in spur],
        "e0": tubes.energy(x0),
        "det_dt": float(dt), "det_n": len(ft), "same": same,
        "tdiff_fine": float(max((abs(ft[i] - ct[j]) for i, j in pairs), default=0.0))}


# ---------------------------------------------------------------------------------------------
# analysis helpers (main process)

def gauss_tableau(s):
    """Gauss-Legendre A, b, c on [0, 1] (numpy; a_ij = int_0^c_i l_j)."""
    xg, wg = np.polynomial.legendre.leggauss(s)
    c = (xg + 1) / 2
    a = np.zeros((s, s))
    for j in range(s):
        lj = np.poly1d([1.0])
        for k in range(s):
            if k != j:
                lj = lj * np.poly1d([1.0, -c[k]]) / (c[j] - c[k])
        ij = np.polyint(lj)
        a[:, j] = ij(c) - ij(0)
    return a, wg / 2, c


def jacobian_fd(x):
    """Jacobian of tubes.vector_field by central differences (step 1e-6 max(1, |x_j|))."""
    jac = np.empty((4, 4))
    for j in range(4):
        d = 1e-6 * max(1.0, abs(x[j]))
        e = np.zeros(4)
        e[j] = d
        jac[:, j] = (tubes.vector_field(x + e) - tubes.vector_field(x - e)) / (2 * d)
    return jac


def task_orbit_jacobians(args):
    """J along the accurate orbit (dop853 1e-12, 10 s, every 1/512 s)."""
    de, = args
    x0 = start_point(de)
    r = tubes.integrate(x0, T_STAB, dt_out=1.0 / 512, rtol=1e-12, atol=1e-12)
    js = np.array([jacobian_fd(x) for x in r["state"]])
    return de, r["t"], js


def contraction(tgrid, js, s, h):
    """Linearised contraction factors along the orbit for gauss with s stages and step h:
    fixed point rho(h (A (x) I) diag(J(X_i))) and simplified Newton
    rho((I - h A (x) J0)^-1 h (A (x) I) diag(J(X_i) - J0)), one value per step; J at the stage
    times from a cubic spline of the sampled J."""
    from scipy.interpolate import CubicSpline
    a, _, c = gauss_tableau(s)
    spl = CubicSpline(tgrid, js.reshape(len(tgrid), 16), axis=0)
    nst = int(np.floor((tgrid[-1] - 1e-12) / h))
    tn = np.arange(nst) * h
    j0 = spl(tn).reshape(nst, 4, 4)
    ji = np.stack([spl(tn + ci * h).reshape(nst, 4, 4) for ci in c], axis=1)   # (n, s, 4, 4)
    n4 = 4 * s
    ai = np.kron(a, np.eye(4))
    dg = np.zeros((nst, n4, n4))
    dn = np.zeros((nst, n4, n4))
    for i in range(s):
        dg[:, 4 * i:4 * i + 4, 4 * i:4 * i + 4] = ji[:, i]
        dn[:, 4 * i:4 * i + 4, 4 * i:4 * i + 4] = ji[:, i] - j0
    fp = h * np.einsum("ij,njk->nik", ai, dg)
    m = np.eye(n4)[None] - h * np.kron(a, np.ones((4, 4)))[None] * np.tile(j0, (1, s, s))   # I - h A (x) J0
    kn = np.linalg.solve(m, h * np.einsum("ij,njk->nik", ai, dn))
    return (np.abs(np.linalg.eigvals(fp)).max(axis=1), np.abs(np.linalg.eigvals(kn)).max(axis=1))


def crossing_h(hs, vals, level):
    """Largest h below which every val <= level, log-interpolated between the grid points that
    bracket the first exceedance (vals sorted by increasing h; nan/inf count as above). When the
    first exceedance is a failed run (inf), the last good h is returned as a negative number."""
    hs, vals = np.asarray(hs), np.asarray(vals, float)
    bad = ~(vals <= level)
    if not bad.any():
        return np.inf
    k = int(np.argmax(bad))
    if k == 0:
        return 0.0
    if not np.isfinite(vals[k]):
        return -float(hs[k - 1])
    v0, v1 = np.log(max(vals[k - 1], 1e-300)), np.log(vals[k])
    w = (np.log(level) - v0) / (v1 - v0)
    return float(np.exp(np.log(hs[k - 1]) + w * (np.log(hs[k]) - np.log(hs[k - 1]))))


# ---------------------------------------------------------------------------------------------

def run_tasks(pool, fn, tasks, name):
    t0 = time.perf_counter()
    out = []
    n = len(tasks)
    step = max(1, n // 10)
    for i, res in enumerate(pool.imap_unordered(fn, tasks, chunksize=1)):
        out.append(res)
        if (i + 1) % step == 0 or i + 1 == n:
            print(f"  {name}: {i + 1}/{n} ({time.perf_counter() - t0:.1f} s)", flush=True)
    return out


def theta_fwd(th):
    """Map axis: log10(theta) below 1, linear (stretched) above."""
    th = np.asarray(th, float)
    with np.errstate(all="ignore"):
        return np.where(th < 1, np.log10(np.maximum(th, 1e-30)), (th - 1) * 0.6)


def theta_inv(y):
    y = np.asarray(y, float)
    return np.where(y < 0, 10.0 ** np.minimum(y, 0), y / 0.6 + 1)


def ragged(e):
    """Summary of the stable runs above the first failure (fine grid up to 2x)."""
    if not e["above"]:
        return f"none of {e['n_above']}"
    hs = [a[0] for a in e["above"]]
    best = min(a[1] for a in e["above"])
    return (f"{len(hs)} of {e['n_above']}, up to {fmt_h(max(hs))}; their smallest max dE/E {best:.1g}")


def code_name(code):
    return {99: "energy > 1 / non-finite", tubes.ENOCONV: "ENOCONV", tubes.EMODEL: "EMODEL",
            tubes.EMAXSTEPS: "EMAXSTEPS", tubes.ESTEP: "ESTEP"}.get(code, str(code))


def fmt_h(h):
    if not np.isfinite(h):
        return "none"
    if h < 0:
        return f">= {fmt_h(-h)} (up to the failure)"
    if h == 0:
        return "< grid"
    return f"{h * 1e3:.3g} ms" if h < 0.1 else f"{h:.3g} s"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default=str(ROOT / "docs"), help="directory of the PNGs and stability.md")
    ap.add_argument("--jobs", type=int, default=2, help="worker processes (default 2)")
    args = ap.parse_args()
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    t_start = time.perf_counter()
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    pool = mp.get_context("fork").Pool(args.jobs)
    starts = {de: start_point(de) for de in DES}
    for de, x0 in starts.items():
        print(f"start dE = {de:6.0f}: (x, y) = ({x0[0]}, {x0[1]!r}), E - E_e = "
              f"{tubes.energy(x0) - E_SADDLE:.9f}", flush=True)

    # ---- references (real128, t = 2 s)
    print("real128 references to t = 2 s ...", flush=True)
    refs = {}
    for de, _, xr, sec in run_tasks(pool, task_reference, [(de, T_ACC, REF_TOL) for de in DES], "ref"):
        refs[de] = xr
        print(f"  dE = {de:.0f}: {xr}, {sec:.2f} s", flush=True)

    # ---- part 1: scan
    print("part 1: h scan of the fixed-step methods ...", flush=True)
    tasks = []
    for de in DES:
        for method, solver in FIXED:
            for k in range(0, 4 * H_MIN_EXP[method] + 1):
                tasks.append((de, method, solver, 2.0 ** (-k / 4)))
    scan = dict(run_tasks(pool, task_scan, tasks, "scan"))
    hs_of = {m: sorted({k[3] for k in scan if k[1] == m}) for m, _ in FIXED}

    def series(de, method, solver):
        hs = hs_of[method]
        rows = [scan[(de, method, solver, h)] for h in hs]
        err = [rel_err(r["x2"], refs[de]) if r["x2"] is not None and np.all(np.isfinite(r["x2"]))
               else np.inf for r in rows]
        return np.array(hs), rows, np.array(err)

    # first failing grid point (from small h) of each config, then refine
    edge_tasks = []
    for de in DES:
        for method, solver in FIXED:
            hs, rows, _ = series(de, method, solver)
            fail = [i for i, r in enumerate(rows) if r["code"] != 0]
            if fail and fail[0] > 0:
                edge_tasks.append((de, method, solver, hs[fail[0] - 1], hs[fail[0]], 0))
    # part 2 extension: newton with max_iter = 1000 (grid scan then refine)
    g_tasks = [(de, m, 2.0 ** (-k / 4), 1000) for de in DES for m in ("gauss4", "gauss6", "gauss8")
               for k in range(0, 4 * 7 + 1)]
    print("part 2: gauss newton, max_iter = 1000 scan ...", flush=True)
    gscan = dict(run_tasks(pool, task_gauss_scan, g_tasks, "gauss1000"))
    for de in DES:
        for m in ("gauss4", "gauss6", "gauss8"):
            hs = sorted({k[2] for k in gscan if k[1] == m})
            codes = [gscan[(de, m, h, 1000)]["code"] for h in hs]
            fail = [i for i, c in enumerate(codes) if c != 0]
            if fail and fail[0] > 0:
                edge_tasks.append((de, m, "newton", hs[fail[0] - 1], hs[fail[0]], 1000))
    print("part 1/2: refining the stability edges ...", flush=True)
    edges = dict(run_tasks(pool, task_edge, edge_tasks, "edges"))

    # ---- part 2: contraction factors along the orbit
    print("part 2: Jacobians along the reference orbits ...", flush=True)
    orbits = {de: (t, js) for de, t, js in run_tasks(pool, task_orbit_jacobians, [(de,) for de in DES], "orbit J")}
    h_con = 2.0 ** (-np.arange(4 * 7, -1, -1) / 4)       # 1/128 s ... 1 s
    con = {}
    rho_j = {}
    for de in DES:
        tg, js = orbits[de]
        rho_j[de] = np.abs(np.linalg.eigvals(js)).max(axis=1)
        for s in (2, 3, 4):
            for h in h_con:
                fp, nw = contraction(tg, js, s, h)
                con[(de, s, h)] = (fp.max(), nw.max(), np.median(fp), np.median(nw))
    rho_a = {s: float(np.abs(np.linalg.eigvals(gauss_tableau(s)[0])).max()) for s in (2, 3, 4)}
    print("  rho(A) =", {s: round(v, 4) for s, v in rho_a.items()},
          " max rho(J) =", {de: round(float(v.max()), 2) for de, v in rho_j.items()}, flush=True)

    # ---- part 3: tao omega
    print("part 3: Tao omega scan (h = 1/1024 s) ...", flush=True)
    h_tao = 1.0 / 1024
    # 1 ... 8192 /s, the default 200 /s, and 2 omega h = pi, 2 pi at this h
    omegas = np.unique(np.concatenate([2.0 ** (np.arange(0, 27) / 2), [200.0, np.pi / (2 * h_tao), np.pi / h_tao]]))
    tao_om = dict(run_tasks(pool, task_tao_omega, [(de, m, om, h_tao) for de in DES
                                                   for m in ("tao2", "tao4", "tao6") for om in omegas],
                            "tao omega"))
    print("part 3: Tao stability map over (omega, 2 omega h) ...", flush=True)
    om_edge = 2.0 ** np.arange(0, 14)                     # 1 ... 8192 /s
    map_tasks = sorted([(de, m, om) for de in DES for m in ("tao2", "tao4", "tao6") for om in om_edge],
                       key=lambda a: -a[2] * {"tao2": 4, "tao4": 10, "tao6": 28}[a[1]])   # longest first
    tao_ed = dict(run_tasks(pool, task_tao_map, map_tasks, "tao map"))

    # ---- part 4: events
    print("part 4: section U1, reference lists ...", flush=True)
    evref = dict(run_tasks(pool, task_event_reference, [(de,) for de in DES], "event ref"))
    settings = [("dop853", 0.0, "-", tol) for tol in 10.0 ** -np.arange(12, 2, -1)]
    for m, kmin, kmax in (("rk4", 2, 10), ("tao2", 7, 12), ("tao4", 7, 12), ("tao6", 7, 12),
                          ("gauss4", 2, 10), ("gauss6", 2, 10), ("gauss8", 2, 10)):
        for k in range(kmax, kmin - 1, -1):
            settings.append((m, 2.0 ** -k, "fixed_point" if m.startswith("gauss") else "-", 0.0))
    print("part 4: section U1, method settings ...", flush=True)
    ev = dict(run_tasks(pool, task_event_setting, [(de, *s) for de in DES for s in settings], "events"))
    pool.close()
    pool.join()
    elapsed = time.perf_counter() - t_start
    print(f"measurements done in {elapsed:.0f} s; charts and tables ...", flush=True)

    results = dict(starts=starts, refs=refs, scan=scan, series=series, edges=edges, gscan=gscan,
                   con=con, h_con=h_con, rho_a=rho_a, rho_j=rho_j, tao_om=tao_om, omegas=omegas,
                   tao_ed=tao_ed, om_edge=om_edge, evref=evref, ev=ev, settings=settings,
                   elapsed=elapsed, h_tao=h_tao)
    tables = report(results, out)
    write_doc(out, tables, elapsed)
    print(f"total {time.perf_counter() - t_start:.0f} s", flush=True)


# ---------------------------------------------------------------------------------------------
# report

COLORS = {"rk4": "tab:gray", "tao2": "tab:olive", "tao4": "tab:orange", "tao6": "tab:red",
          "gauss4": "tab:blue", "gauss6": "tab:green", "gauss8": "tab:purple", "dop853": "black"}


def report(R, out):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    tables = {}
    series, edges = R["series"], R["edges"]

    # ---------------- part 1 table and chart
    lines = ["| method | dE | h: error(2 s) > 1e-3 | h: max dE/E (10 s) > 1e-3 | stability edge, 10 s | "
             "failure there | above the edge (to 2x): runs without blow-up | edge, 100 s | 2 omega h at the edge |",
             "|---|---|---|---|---|---|---|---|---|"]
    for method, solver in FIXED:
        for de in DES:
            hs, rows, err = series(de, method, solver)
            dmax = np.array([r["de"] if r["code"] == 0 else np.inf for r in rows])
            h_acc, h_en = crossing_h(hs, err, ACC_LEVEL), crossing_h(hs, dmax, ACC_LEVEL)
            e = edges.get((de, method, solver, 0))
            if e:
                code = code_name(e["code"])
                ed = f"{fmt_h(e['lo'])} - {fmt_h(e['hi'])}"
                isl = ragged(e)
                ed100 = f"{fmt_h(e['lo100'])} - {fmt_h(e['hi100'])}"
                om = f"{2 * 200 * e['hi']:.2f}" if method.startswith("tao") else ""
            else:
                ed, code, ed100, om, isl = "none up to 1 s", "", "", "", ""
            lines.append(f"| {label(method, solver)} | {de:.0f} | {fmt_h(h_acc)} | {fmt_h(h_en)} | {ed} | {code} | "
                         f"{isl} | {ed100} | {om} |")
    tables["part1"] = "\n".join(lines)
    lines = ["| dE | eigenvalues of J at the start [1/s] | rho(J(x0)) | max rho(J), 10 s orbit | rk4 edge (10 s) | "
             "edge rho(J(x0)) | edge max rho(J) |", "|---|---|---|---|---|---|---|"]
    for de in DES:
        ev0 = np.linalg.eigvals(jacobian_fd(R["starts"][de]))
        r0, rm = float(np.abs(ev0).max()), float(R["rho_j"][de].max())
        e = edges[(de, "rk4", "-", 0)]
        hm = np.sqrt(e["lo"] * e["hi"])
        lines.append(f"| {de:.0f} | {', '.join(f'{v.real:+.2f}{v.imag:+.2f}i' for v in sorted(ev0, key=lambda v: (v.imag, v.real)))} | "
                     f"{r0:.2f} | {rm:.2f} | {fmt_h(hm)} | {hm * r0:.2f} | {hm * rm:.2f} |")
    tables["part1_rk4"] = "\n".join(lines)

    fig, axs = plt.subplots(2, 3, figsize=(16, 9.5), sharex=True)
    for col, de in enumerate(DES):
        for method, solver in FIXED:
            hs, rows, err = series(de, method, solver)
            ok = np.array([r["code"] == 0 for r in rows])
            dmax = np.array([r["de"] for r in rows])
            ls = "--" if solver == "fixed_point" else "-"
            for row, vals in ((0, err), (1, dmax)):
                ax = axs[row, col]
                v = np.where(ok, np.minimum(vals, 10.0), np.nan)
                ax.loglog(hs, v, ls, color=COLORS[method], lw=1.1, marker=".", ms=3,
                          label=label(method, solver) if (row == 0 and col == 0) else None)
                e = edges.get((de, method, solver, 0))
                if e:
                    ax.plot([e["hi"]], [20.0 if row == 0 else 20.0], marker="v" if solver != "fixed_point" else "X",
                            color=COLORS[method], ms=8, ls="none")
        for row in (0, 1):
            ax = axs[row, col]
            ax.axhline(ACC_LEVEL, color="k", lw=0.6, ls=":")
            ax.axhline(BLOWUP, color="k", lw=0.6, ls="-.") if row == 1 else None
            ax.set_ylim(1e-17, 60)
            ax.grid(True, which="major", lw=0.3)
        axs[0, col].set_title(f"dE = {de:.0f} (cm/s)^2")
        axs[1, col].set_xlabel("step h [s]")
    axs[0, 0].set_ylabel("relative error of the state at t = 2 s")
    axs[1, 0].set_ylabel("max |E - E0|/E0 over 10 s")
    fig.legend(loc="upper center", ncol=10, fontsize=8)
    fig.suptitle("Fixed-step methods: error against h; markers at the top = stability edge "
                 "(v: blow-up / Newton failure, X: fixed-point failure); curves stop where a run fails",
                 y=0.955, fontsize=10)
    fig.tight_layout(rect=(0, 0, 1, 0.94))
    fig.savefig(out / "stability_accuracy.png", dpi=100)
    plt.close(fig)

    # ---------------- part 2 table and chart
    rho_a, rho_j, con, h_con, gscan = R["rho_a"], R["rho_j"], R["con"], R["h_con"], R["gscan"]
    lines = ["| method | dE | max rho(J) [1/s] | fixed point: edge (10 s) | h rho(A) max rho(J) | "
             "contraction (linear, max on orbit) | Newton (10): edge | Newton contraction | "
             "Newton (1000): edge | its contraction | edge 100 s: FP / N(10) / N(1000) |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]

    def con_at(de, s, h, which):
        vals = np.array([con[(de, s, hh)][which] for hh in h_con])
        return float(np.exp(np.interp(np.log(h), np.log(h_con), np.log(vals))))

    for m in ("gauss4", "gauss6", "gauss8"):
        s = int(m[-1]) // 2
        for de in DES:
            rj = float(rho_j[de].max())
            efp = edges.get((de, m, "fixed_point", 0))
            enw = edges.get((de, m, "newton", 0))
            e1k = edges.get((de, m, "newton", 1000))
            cells = [m, f"{de:.0f}", f"{rj:.2f}"]
            for e, which in ((efp, 0), (enw, 1), (e1k, 1)):
                if e:
                    hm = np.sqrt(e["lo"] * e["hi"])
                    cells.append(f"{fmt_h(e['lo'])} - {fmt_h(e['hi'])}" + ("" if e["code"] == tubes.ENOCONV else
                                                                                 f" ({code_name(e['code'])})")
                                 + (f"; ragged to {fmt_h(max(a[0] for a in e['above']))}" if e["above"] else ""))
                    if which == 0:
                        cells.append(f"{hm * rho_a[s] * rj:.2f}")
                    cells.append(f"{con_at(de, s, hm, which):.3g}")
                else:
                    cells += ["none", "", ""] if which == 0 else ["none", ""]
            cells.append(" / ".join(fmt_h(e["hi100"]) if e else "-" for e in (efp, enw, e1k)))
            lines.append("| " + " | ".join(cells) + " |")
    tables["part2"] = "\n".join(lines)
    lines = ["| dE | h | gauss4 N / FP | gauss6 N / FP | gauss8 N / FP |", "|---|---|---|---|---|"]
    for de in DES:
        for h in (2.0 ** -8, 2.0 ** -6, 2.0 ** -5, 2.0 ** -4.5, 2.0 ** -4, 2.0 ** -3, 2.0 ** -2):
            cells = [f"{de:.0f}", f"1/{1 / h:.3g}"]
            for m in ("gauss4", "gauss6", "gauss8"):
                v = [R["scan"].get((de, m, sol, h)) for sol in ("newton", "fixed_point")]
                cells.append(" / ".join(f"{r['it']:.1f}" if r and r["code"] == 0 else "fail" for r in v))
            lines.append("| " + " | ".join(cells) + " |")
    tables["part2_iter"] = "\n".join(lines)

    fig, axs = plt.subplots(2, 3, figsize=(16, 9), sharex=True)
    for col, de in enumerate(DES):
        for m in ("gauss4", "gauss6", "gauss8"):
            s = int(m[-1]) // 2
            for solver, ls in (("newton", "-"), ("fixed_point", "--")):
                hs, rows, _ = series(de, m, solver)
                it = np.array([r["it"] if r["code"] == 0 else np.nan for r in rows])
                axs[0, col].loglog(hs, it, ls, color=COLORS[m], marker=".", ms=3,
                                   label=f"{m} {'Newton' if solver == 'newton' else 'fixed point'}")
            hs1 = sorted({k[2] for k in gscan if k[1] == m})
            it1 = [gscan[(de, m, h, 1000)]["it"] if gscan[(de, m, h, 1000)]["code"] == 0 else np.nan for h in hs1]
            axs[0, col].loglog(hs1, it1, ":", color=COLORS[m], label=f"{m} Newton max_iter 1000")
            fp = [con[(de, s, h)][0] for h in h_con]
            nw = [con[(de, s, h)][1] for h in h_con]
            axs[1, col].loglog(h_con, fp, "--", color=COLORS[m], label=f"{m} fixed point")
            axs[1, col].loglog(h_con, nw, "-", color=COLORS[m], label=f"{m} simplified Newton")
            for solver, mi, mk in (("fixed_point", 0, "X"), ("newton", 0, "v"), ("newton", 1000, "^")):
                e = edges.get((de, m, solver, mi))
                if e:
                    hm = np.sqrt(e["lo"] * e["hi"])
                    axs[1, col].plot([hm], [con_at(de, s, hm, 0 if solver == "fixed_point" else 1)], mk,
                                     color=COLORS[m], ms=8)
        axs[0, col].axhline(10, color="k", lw=0.6, ls=":")
        axs[0, col].axhline(100, color="k", lw=0.6, ls=":")
        axs[1, col].axhline(1, color="k", lw=0.6, ls=":")
        axs[0, col].set_title(f"dE = {de:.0f} (cm/s)^2")
        axs[1, col].set_xlabel("step h [s]")
        for r in (0, 1):
            axs[r, col].grid(True, which="major", lw=0.3)
    axs[0, 0].set_ylabel("stage iterations per step (10 s run)")
    axs[1, 0].set_ylabel("linearised contraction factor, max over the orbit")
    axs[0, 0].legend(fontsize=7)
    axs[1, 0].legend(fontsize=7)
    fig.suptitle("Gauss stage solvers: iterations per step (top) and contraction factor along the reference "
                 "orbit (bottom); markers = measured limits (X fixed point, v Newton max_iter 10, ^ 1000)",
                 fontsize=10)
    fig.tight_layout(rect=(0, 0, 1, 0.96))
    fig.savefig(out / "stability_gauss.png", dpi=100)
    plt.close(fig)

    # ---------------- part 3
    tao_om, omegas, tao_ed, om_edge, h_tao = R["tao_om"], R["omegas"], R["tao_ed"], R["om_edge"], R["h_tao"]
    refs = R["refs"]
    fig, axs = plt.subplots(1, 4, figsize=(21, 5.2))
    mk = {100.0: "o", 1500.0: "s", 4000.0: "^"}
    lss = {100.0: ":", 1500.0: "-", 4000.0: "--"}
    lines = ["| method | dE | error (2 s) at omega 200 | best error (2 s), at omega | max dE/E (100 s) at 200 | "
             "best max dE/E (100 s), at omega | contiguous omega range around 200 with max dE/E (100 s) < 1e-3 |",
             "|---|---|---|---|---|---|---|"]
    for m in ("tao2", "tao4", "tao6"):
        for de in DES:
            err = np.array([rel_err(tao_om[(de, m, om)]["x2"], refs[de]) if tao_om[(de, m, om)]["x2"] is not None
                            and np.all(np.isfinite(tao_om[(de, m, om)]["x2"])) else np.nan for om in omegas])
            den = np.array([tao_om[(de, m, om)]["de"] if tao_om[(de, m, om)]["code"] == 0 else np.nan for om in omegas])
            axs[0].loglog(omegas, np.minimum(err, 10), lss[de], color=COLORS[m], marker=mk[de], ms=3,
                          label=f"{m} dE={de:.0f}")
            axs[1].loglog(omegas, np.minimum(den, 10), lss[de], color=COLORS[m], marker=mk[de], ms=3)
            i200 = int(np.argmin(np.abs(omegas - 200)))
            ok = np.nan_to_num(den, nan=np.inf) < 1e-3
            lo_i = hi_i = i200
            while ok[i200] and lo_i > 0 and ok[lo_i - 1]:
                lo_i -= 1
            while ok[i200] and hi_i < len(omegas) - 1 and ok[hi_i + 1]:
                hi_i += 1
            good = omegas[lo_i:hi_i + 1] if ok[i200] else []
            ie, idn = int(np.nanargmin(err)), int(np.nanargmin(den))
            lines.append(f"| {m} | {de:.0f} | {err[i200]:.2e} | {err[ie]:.2e}, {omegas[ie]:.0f} | "
                         f"{den[i200]:.2e} | {den[idn]:.2e}, {omegas[idn]:.0f} | "
                         + (f"{good.min():.0f} - {good.max():.0f} |" if len(good) else "none |"))
    tables["part3_omega"] = "\n".join(lines)
    lines = ["| method | dE | " + " | ".join(f"{om:.0f}" for om in om_edge) + " |",
             "|---|---|" + "---|" * len(om_edge)]
    for m in ("tao2", "tao4", "tao6"):
        for de in DES:
            cols = [tao_ed[(de, m, om)] for om in om_edge]
            hh = np.array([np.sqrt(c["edge"][0] * c["edge"][1]) if c["edge"] else np.nan for c in cols])
            axs[2].loglog(om_edge, hh, lss[de], color=COLORS[m], marker=mk[de], ms=4, label=f"{m} dE={de:.0f}")
            axs[3].semilogx(om_edge, 2 * om_edge * hh, lss[de], color=COLORS[m], marker=mk[de], ms=4)
            # above the edge: theta cells that run without blow-up, and those also accurate
            isl = []
            for c, h in zip(cols, hh):
                above = [(th, code, d) for th, code, d in c["col"] if code != -999 and np.isfinite(h) and th > 2 * c["omega"] * h]
                isl.append(sum(1 for a in above if a[1] == 0 and a[2] <= ACC_LEVEL))
            lines.append(f"| {m} h_edge [ms] | {de:.0f} | " + " | ".join(
                f"{h * 1e3:.3g}" if np.isfinite(h) else "-" for h in hh) + " |")
            lines.append(f"| {m} 2 omega h_edge | {de:.0f} | " + " | ".join(
                f"{2 * om * h:.3g}" if np.isfinite(h) else "-" for h, om in zip(hh, om_edge)) + " |")
            lines.append(f"| {m} accurate cells above the edge | {de:.0f} | " + " | ".join(
                str(k) if np.isfinite(h) else "-" for k, h in zip(isl, hh)) + " |")
    tables["part3_edge"] = "\n".join(lines)
    axs[2].loglog(om_edge, np.pi / (2 * om_edge), ":", color="k", lw=1.0)
    axs[3].axhline(np.pi, color="k", lw=0.8, ls=":")
    axs[3].set_xlabel("omega_bind [1/s]")
    axs[3].set_ylabel("2 omega h at the blow-up edge")
    axs[3].set_title("dotted: pi", fontsize=9)
    axs[0].axvline(200, color="k", lw=0.5, ls=":")
    axs[1].axvline(200, color="k", lw=0.5, ls=":")
    axs[0].set_xlabel("omega_bind [1/s]")
    axs[1].set_xlabel("omega_bind [1/s]")
    axs[2].set_xlabel("omega_bind [1/s]")
    axs[0].set_ylabel(f"relative error at t = 2 s (h = 1/{1 / h_tao:.0f} s)")
    axs[1].set_ylabel(f"max |E - E0|/E0 over 100 s (h = 1/{1 / h_tao:.0f} s)")
    axs[2].set_ylabel("stability edge h [s] (10 s run)")
    axs[2].set_title("first blow-up from below (10 s runs); dotted: 2 omega h = pi", fontsize=9)
    axs[0].legend(fontsize=6, ncol=3)
    axs[2].legend(fontsize=6, ncol=3)
    for ax in axs:
        ax.grid(True, which="major", lw=0.3)
    fig.suptitle("Tao's binding constant omega: accuracy, long-time energy, stability edge", fontsize=10)
    fig.tight_layout(rect=(0, 0, 1, 0.95))
    fig.savefig(out / "stability_tao.png", dpi=100)
    plt.close(fig)

    fig, axs = plt.subplots(3, 3, figsize=(15, 12), sharex=True, sharey=True)
    from matplotlib.colors import ListedColormap
    cmap = matplotlib.colormaps["viridis"].copy()
    cmap.set_bad("white")
    ex = np.log(om_edge)
    xe = np.exp(np.concatenate([[ex[0] - 0.35], (ex[1:] + ex[:-1]) / 2, [ex[-1] + 0.35]]))
    lt = theta_fwd(THETA)
    ye = theta_inv(np.concatenate([[lt[0] - 0.05], (lt[1:] + lt[:-1]) / 2, [lt[-1] + 0.03]]))
    for i, m in enumerate(("tao2", "tao4", "tao6")):
        for j, de in enumerate(DES):
            z = np.full((len(THETA), len(om_edge)), np.nan)
            blow = np.zeros_like(z)
            for k, om in enumerate(om_edge):
                for r, (th, code, d) in enumerate(tao_ed[(de, m, om)]["col"]):
                    if code == -999:
                        continue
                    if code != 0:
                        blow[r, k] = 1
                    else:
                        z[r, k] = np.log10(max(d, 1e-12))
            ax = axs[i, j]
            pc = ax.pcolormesh(xe, ye, np.ma.masked_invalid(z), cmap=cmap, vmin=-9, vmax=0, shading="flat")
            ax.pcolormesh(xe, ye, np.ma.masked_where(blow == 0, blow), cmap=ListedColormap(["red"]), shading="flat")
            for kk in (1, 2):
                ax.axhline(kk * np.pi, color="w", lw=0.6, ls=":")
            ax.set_xscale("log")
            ax.set_yscale("function", functions=(theta_fwd, theta_inv))
            ax.set_yticks([1e-3, 1e-2, 0.1, 1, 2, 3, 4, 5, 6, 7, 8])
            ax.set_yticklabels(["1e-3", "1e-2", "0.1", "1", "2", "3", "4", "5", "6", "7", "8"])
            ax.set_title(f"{m}, dE = {de:.0f}", fontsize=9)
            if i == 2:
                ax.set_xlabel("omega_bind [1/s]")
            if j == 0:
                ax.set_ylabel("2 omega h")
    fig.colorbar(pc, ax=axs, shrink=0.6, label="log10 max |E - E0|/E0 over 10 s (red: blow-up or failure; white: not run)")
    fig.suptitle("Tao: stability map over (omega, 2 omega h); dotted lines at 2 omega h = pi, 2 pi", fontsize=10)
    fig.savefig(out / "stability_tao_map.png", dpi=90)
    plt.close(fig)

    # ---------------- part 4
    evref, ev, settings = R["evref"], R["ev"], R["settings"]
    lines = ["| dE | reference crossings in 50 s (closest pair) | dop853 1e-13 vs gauss8 h = 1/512 (FP): state difference at 10 / 20 / 30 s | "
             "crossing-time difference, t < 10 / 20 s | lists agree one-to-one up to | gauss8 FP vs Newton (roundoff only): counts in 50 s | "
             "real128 check (dop853 1e-13 / gauss8): error at 10 s, 20 s | trusted to (difference < 1e-4) |",
             "|---|---|---|---|---|---|---|---|"]
    trust = {}
    for de in DES:
        r = evref[de]
        g = r["gauss8"]["fixed_point"]
        d = np.max(np.abs(g["x"] - r["x"]), axis=1) / np.max(np.abs(r["x"]), axis=1)
        tt = r["t"]
        tr = float(tt[np.argmax(d > TRUST)]) if (d > TRUST).any() else T_EV
        trust[de] = tr
        pairs, ua, ub = match(r["ct"], r["cd"], g["ct"], g["cd"], TAU)
        # one-to-one agreement: first unmatched crossing on either list
        firsts = [r["ct"][i] for i in ua] + [g["ct"][j] for j in ub]
        agree = min(firsts) if firsts else T_EV
        tdiff = {T: max((abs(r["ct"][i] - g["ct"][j]) for i, j in pairs if r["ct"][i] < T), default=0.0)
                 for T in (10, 20)}
        dd = [d[int(round(T / DT_CMP))] for T in (10, 20, 30)]
        lines.append(f"| {de:.0f} | {len(r['ct'])} ({np.diff(r['ct']).min():.2f} s) | {dd[0]:.1e} / {dd[1]:.1e} / {dd[2]:.1e} | "
                     f"{tdiff[10]:.1e} / {tdiff[20]:.1e} s | {agree:.1f} s | {len(g['ct'])} / "
                     f"{len(r['gauss8']['newton']['ct'])} | {r['r128'][10.0][0]:.1e} / {r['r128'][10.0][1]:.1e}, "
                     f"{r['r128'][20.0][0]:.1e} / {r['r128'][20.0][1]:.1e} | {tr:.1f} s |")
    tables["part4_ref"] = "\n".join(lines)
    tables["part4_bitwise"] = all(evref[de]["bitwise"] for de in DES)

    lines = ["| setting | dE | steps | crossings in 50 s (ref) | naive, whole trusted range: missed / spurious (of ref) | "
             "T_div | W = min(T_div, trust) | matched in W | missed in W | spurious in W | max time error in W [s] | "
             "detector: crossings on own dense output | detector missed | detector spurious |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    evsum = {}
    for (m, h, solver, tol) in settings:
        for de in DES:
            e = ev[(de, m, h, solver, tol)]
            name = f"dop853 tol {tol:.0e}" if m == "dop853" else f"{m} h 1/{1 / h:.0f}"
            if e["code"] != 0:
                lines.append(f"| {name} | {de:.0f} | fails ({e['code']}) | | | | | | | | | | | |")
                continue
            r = evref[de]
            ig = np.round(e["tg"] / DT_CMP).astype(int)
            d = np.max(np.abs(e["xg"] - r["x"][ig]), axis=1) / np.max(np.abs(r["x"][ig]), axis=1)
            tdiv = float(e["tg"][np.argmax(d > DELTA)]) if (d > DELTA).any() else T_EV
            w = min(tdiv, trust[de])
            sel_r = r["ct"] < w - TAU
            sel_m = e["ct"] < w - TAU
            pairs, ua, ub = match(r["ct"][sel_r], r["cd"][sel_r], e["ct"], e["cd"], TAU)
            pairs2, ua2, ub2 = match(e["ct"][sel_m], e["cd"][sel_m], r["ct"], r["cd"], TAU)
            # naive: the whole trusted range, whatever the trajectory error
            nr, nm = r["ct"] < trust[de] - TAU, e["ct"] < trust[de] - TAU
            _, na, _ = match(r["ct"][nr], r["cd"][nr], e["ct"], e["cd"], TAU)
            _, ns, _ = match(e["ct"][nm], e["cd"][nm], r["ct"], r["cd"], TAU)
            t_first = min([r["ct"][nr][i] for i in na] + [e["ct"][nm][j] for j in ns], default=np.nan)
            terr = max((abs(r["ct"][sel_r][i] - e["ct"][j]) for i, j in pairs), default=0.0)
            evsum[(de, m, h, tol)] = dict(n=len(e["ct"]), tdiv=tdiv, w=w, matched=len(pairs), missed=len(ua),
                                          spurious=len(ua2), terr=terr, dmiss=len(e["det_missed"]),
                                          dspur=len(e["det_spurious"]), same=e["same"], nref=len(r["ct"]),
                                          nmiss=len(na), nspur=len(ns), nref_t=int(nr.sum()), t_first=t_first,
                                          name=name, nsteps=e["nsteps"], det_n=e["det_n"], det_dt=e["det_dt"])
            lines.append(f"| {name} | {de:.0f} | {e['nsteps']} | {len(e['ct'])} ({len(r['ct'])}) | "
                         f"{len(na)} / {len(ns)} ({int(nr.sum())}) | {tdiv:.2f} s | {w:.2f} s | "
                         f"{len(pairs)} | {len(ua)} | {len(ua2)} | {terr:.1e} | {e['det_n']} (dt {e['det_dt']:.2g} s) | "
                         f"{len(e['det_missed'])} | {len(e['det_spurious'])} |")
    tables["part4_full"] = "\n".join(lines)
    # condensed: a few settings per method
    keep = {("dop853", t) for t in (1e-12, 1e-9, 1e-6, 1e-3)} | {(m, 2.0 ** -k) for m in FIXED_NAMES
                                                                 for k in (12, 10, 8, 6, 4, 2)}
    short = lines[:2]
    for (m, h, solver, tol) in settings:
        if (m, tol if m == "dop853" else h) not in {(a, b) for a, b in keep}:
            continue
        for de in DES:
            v = evsum.get((de, m, h, tol))
            if v is None:
                continue
            short.append(next(l for l in lines[2:] if l.startswith(f"| {v['name']} | {de:.0f} |")))
    tables["part4"] = "\n".join(short)
    allv = list(evsum.values())
    tables["part4_totals"] = (
        f"{len(allv)} runs; crossings missed in W: {sum(v['missed'] for v in allv)}, spurious in W: "
        f"{sum(v['spurious'] for v in allv)}; naive comparison over the trusted range: "
        f"{sum(v['nmiss'] for v in allv)} missed, {sum(v['nspur'] for v in allv)} spurious, the earliest of them "
        f"{min((v['t_first'] - v['tdiv'] for v in allv if np.isfinite(v['t_first'])), default=np.nan):+.2f} s "
        f"after T_div; detector check: {sum(v['dmiss'] for v in allv)} missed, {sum(v['dspur'] for v in allv)} "
        f"spurious ({sum(1 for v in allv if v['dmiss'] or v['dspur'])} runs)")
    tables["part4_same"] = all(v["same"] for v in evsum.values())
    det_notes = []
    for (de, m, h, solver, tol), e in ev.items():
        if e.get("code", 1) == 0 and (e["det_missed"] or e["det_spurious"]):
            name = f"dop853 tol {tol:.0e}" if m == "dop853" else f"{m} h 1/{1 / h:.0f}"
            allm = e["det_missed"] + e["det_spurious"]
            det_notes.append(
                f"- {name}, dE = {de:.0f}: {len(e['det_missed'])} missed and {len(e['det_spurious'])} spurious, "
                f"all at t >= {min(a[0] for a in allm):.2f} s, where E = {min(a[1] for a in allm):.4f} to "
                f"{max(a[1] for a in allm):.4f} (cm/s)^2 (E0 = {e['e0']:.1f}) and |p_theta| <= "
                f"{max(abs(a[2]) for a in allm):.1e} cm^2/s")
    tables["part4_det"] = "\n".join(det_notes) if det_notes else "- none"

    fig, axs = plt.subplots(1, 3, figsize=(17, 5.2))
    for de in DES:
        tols = [s[3] for s in settings if s[0] == "dop853"]
        tv = [evsum.get((de, "dop853", 0.0, tol), {}).get("tdiv", np.nan) for tol in tols]
        axs[0].semilogx(tols, tv, lss[de], color="k", marker=mk[de], label=f"dop853 dE={de:.0f}")
        axs[0].axhline(trust[de], color="k", lw=0.5, ls=lss[de])
        for m in ("rk4", "tao2", "tao4", "tao6", "gauss4", "gauss6", "gauss8"):
            hs = [s[1] for s in settings if s[0] == m]
            tv = [evsum.get((de, m, h, 0.0), {}).get("tdiv", np.nan) for h in hs]
            axs[1].semilogx(hs, tv, lss[de], color=COLORS[m], marker=mk[de], ms=4,
                            label=f"{m}" if de == 1500.0 else None)
        for (de2, m, h, tol), v in evsum.items():
            if de2 != de:
                continue
            c = COLORS[m]
            if np.isfinite(v["t_first"]):
                axs[2].plot(v["tdiv"], v["t_first"], mk[de], color=c, ms=5, alpha=0.8)
            else:
                axs[2].plot(v["tdiv"], trust[de], mk[de], color=c, ms=5, mfc="none", alpha=0.8)
        axs[1].axhline(trust[de], color="k", lw=0.5, ls=lss[de])
    axs[0].set_xlabel("dop853 rtol = atol")
    axs[1].set_xlabel("fixed step h [s]")
    axs[2].plot([0, T_EV], [0, T_EV], "k:", lw=0.8)
    axs[2].set_xlabel("T_div [s]")
    axs[0].set_ylabel(f"T_div: first time the state error > {DELTA:g} [s]")
    axs[1].set_ylabel(f"T_div [s]; thin lines: reference trusted to")
    axs[2].set_ylabel("first mismatched crossing (naive) [s]; open: none")
    axs[0].legend(fontsize=7)
    axs[1].legend(fontsize=7)
    for ax in axs:
        ax.grid(True, which="major", lw=0.3)
    axs[0].set_title("markers o/s/^ = dE 100/1500/4000", fontsize=9)
    fig.suptitle("Section U1: T_div = time up to which the trajectory agrees with the reference to 1e-3 (left, "
                 "middle); every crossing-list mismatch comes after T_div (right, all settings)", fontsize=10)
    fig.tight_layout(rect=(0, 0, 1, 0.95))
    fig.savefig(out / "stability_events.png", dpi=100)
    plt.close(fig)

    # machine
    try:
        cpu = next(l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo") if l.startswith("model name"))
    except (OSError, StopIteration):
        cpu = platform.processor()
    tables["machine"] = (f"{datetime.date.today().isoformat()}; {cpu}, {os.cpu_count()} cores, Linux "
                         f"{platform.release()}, Python {platform.python_version()}, numpy {np.__version__}")
    tables["starts"] = "\n".join(f"| {de:.0f} | (4, {float(R['starts'][de][1])!r}) | {tubes.energy(R['starts'][de]):.6f} |"
                                 for de in DES)
    tables["rho"] = (", ".join(f"rho(A) = {R['rho_a'][s]:.4f} (s = {s})" for s in (2, 3, 4)) + "; max rho(J) on the "
                     "10 s reference orbit: " + ", ".join(f"{R['rho_j'][de].max():.2f} /s (dE = {de:.0f})" for de in DES)
                     + "; median: " + ", ".join(f"{np.median(R['rho_j'][de]):.2f}" for de in DES))
    print("\n\n".join(f"[{k}]\n{v}" for k, v in tables.items()), flush=True)
    return tables


def write_doc(out, tables, elapsed):
    md = out / "stability.md"
    if not md.exists():
        print(f"{md} does not exist: tables printed only")
        return
    text = md.read_text()
    tables = dict(tables, elapsed=f"{elapsed:.0f} s")
    for k, v in tables.items():
        b, e = f"<!-- bench_stability:{k} begin -->", f"<!-- bench_stability:{k} end -->"
        if b in text and e in text:
            pre, rest = text.split(b, 1)
            post = rest.split(e, 1)[1]
            text = pre + b + "\n" + str(v) + "\n" + e + post
    md.write_text(text)
    print(f"updated {md}")


if __name__ == "__main__":
    main()
