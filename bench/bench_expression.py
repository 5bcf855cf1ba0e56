"""Models written as formulas against the built-ins (docs/models.md): one DOP853 trajectory of
each, through the executable, in the same run; the build (SymPy + gcc) and cache-hit times.

Usage: .venv/bin/python bench/bench_expression.py   (about a minute; writes its section of
docs/benchmarks.md between <!-- bench_expression begin/end -->)
"""
import os
import pathlib
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))
from test_expression import BALL, FOURWELL, HH, PAPER  # noqa: E402  (the formulas the tests check)
from benchdoc import write_section  # noqa: E402

REPEAT = 5
CONSTS = ", ".join(f"'{k} = {v}'" for k, v in PAPER.items())
SURF_CONSTS = ", ".join(f"'{k} = {v}'" for k, v in PAPER.items() if k != "g")
HH_START = "x0 = 0.0, y0 = 0.1, px0 = 0.35, py0 = 0.0, at_rest = .false., t_end = 40000.0, dt_out = 1000.0"
BALL_START = "x0 = 4.0, y0 = 12.614863819914357, t_end = 2000.0, dt_out = 100.0"
CASES = [
    ("Hénon–Heiles", "henon_heiles", "&model system = 'henon_heiles' /",
     f"&model system = 'expression', hamiltonian = '{HH}' /", HH_START),
    ("four-well ball (H as a formula)", "rolling_ball", "&model system = 'rolling_ball' /",
     f"&model system = 'expression', hamiltonian = '{BALL}', constants = {CONSTS} /", BALL_START),
    ("four-well ball (height as a formula)", "rolling_ball", "&model system = 'rolling_ball' /",
     f"&model system = 'rolling_ball', surface = 'expression', height = '{FOURWELL}', "
     f"constants = {SURF_CONSTS} /", BALL_START),
]


def run(tmp, model, start, cache):
    path = os.path.join(tmp, "b.nml")
    with open(path, "w") as f:
        f.write(f"&run scenes = 'trajectory', output = 'b.h5' /\n{model}\n&trajectory {start} /\n"
                "&integrator method = 'dop853', rtol = 1e-12, atol = 1e-12 /\n")
    p = subprocess.run([str(ROOT / "tubes"), path], cwd=tmp, capture_output=True, text=True,
                       env=dict(os.environ, TUBES_CACHE_DIR=cache, OMP_NUM_THREADS="1"))
    if p.returncode:
        raise SystemExit(p.stdout + p.stderr)
    m = re.search(r"(\d+) evaluations, ([\d.]+) s", p.stdout)
    build = re.search(r"compiled in ([\d.]+) s", p.stdout)
    hit = re.search(r"from the cache in ([\d.]+) ms", p.stdout)
    return (int(m.group(1)), float(m.group(2)), float(build.group(1)) if build else None,
            float(hit.group(1)) if hit else None)


def main():
    tmp = tempfile.mkdtemp()
    rows, builds = [], []
    try:
        for name, _, builtin, formula, start in CASES:
            caches = [os.path.join(tmp, f"cache{k}") for k in range(3)]
            b = [run(tmp, formula, start, c)[2] for c in caches]          # three fresh builds
            hits = [run(tmp, formula, start, caches[0])[3] for _ in range(3)]
            builds.append((name, statistics.median(b), statistics.median(hits)))
            tb, te = [], []
            for _ in range(REPEAT):                                      # interleaved
                nb, t1, _, _ = run(tmp, builtin, start, caches[0])
                ne, t2, _, _ = run(tmp, formula, start, caches[0])
                tb.append(t1)
                te.append(t2)
            rows.append((name, nb, ne, min(tb), min(te)))
            print(f"{name}: built-in {min(tb):.3f} s ({nb} evaluations), formula {min(te):.3f} s ({ne}); "
                  f"ratio {min(te) / min(tb):.2f}; build {statistics.median(b):.2f} s, "
                  f"hit {statistics.median(hits):.2f} ms", flush=True)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    lines = ["<!-- bench_expression begin -->", "## Models written as formulas", "",
             f"Measured {time.strftime('%Y-%m-%d')} by `make bench` (bench/bench_expression.py): one DOP853 "
             "trajectory (rtol = atol = 1e-12) of each built-in model and of the same model written as a "
             "formula (docs/models.md; the formulas of tests/test_expression.py), through `./tubes`, "
             f"best of {REPEAT} interleaved runs of the integration alone (the trajectory line's time). "
             "Hénon–Heiles: 40,000 time units from (0, 0.1, 0.35, 0); the ball: 2,000 s from the paper's "
             "release (4, 12.6149) cm at rest.", "",
             "| model | built-in [s] | formula [s] | formula / built-in | evaluations (built-in, formula) |",
             "|---|---|---|---|---|"]
    for name, nb, ne, tb, te in rows:
        lines.append(f"| {name} | {tb:.3f} | {te:.3f} | {te / tb:.2f} | {nb}, {ne} |")
    lines += ["", "Building a model (SymPy's parsing, derivatives, common subexpressions and C printing, then "
              "`gcc -O2 -shared`; median of 3 builds into empty caches) and loading it from the cache "
              "(median of 3):", "", "| model | build [s] | cache hit [ms] |", "|---|---|---|"]
    for name, b, h in builds:
        lines.append(f"| {name} | {b:.2f} | {h:.2f} |")
    lines += ["<!-- bench_expression end -->", ""]
    write_section("bench_expression", lines)


if __name__ == "__main__":
    main()
