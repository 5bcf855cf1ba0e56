"""The paper's run on its method ('auto': the Taylor method for the states, the ensembles in lanes,
DOP853 for the variational equations) against the method it had before 2026-11-29 ('dop853'
throughout), the same executable, run alternately (issue 36's target: at most 0.5x). Wall time of
`./tubes input/paper.nml`, median of 5 each, OMP_NUM_THREADS as set (2 by make bench); the output
of the two compared with h5compare's tolerance (docs/paper.md). Writes its section of
docs/benchmarks.md.

    .venv/bin/python bench/bench_paper_method.py [runs]
"""
import os
import pathlib
import platform
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "bench"))
from benchdoc import write_section  # noqa: E402


def main():
    runs = int(sys.argv[1]) if len(sys.argv) > 1 else 5
    text = (ROOT / "input" / "paper.nml").read_text()
    assert "method = 'auto'" in text, "input/paper.nml's &integrator is not method = 'auto'"
    env = dict(os.environ, OMP_NUM_THREADS=os.environ.get("OMP_NUM_THREADS", "2"))
    walls = {"dop853": [], "auto": []}
    with tempfile.TemporaryDirectory() as d:
        d = pathlib.Path(d)
        (d / "auto.nml").write_text(text)
        (d / "dop853.nml").write_text(text.replace("method = 'auto'", "method = 'dop853'", 1))
        for _ in range(runs):
            for m in ("dop853", "auto"):
                t0 = time.perf_counter()
                subprocess.run([str(ROOT / "tubes"), f"{m}.nml", "-o", f"{m}.h5"], cwd=d, env=env, check=True,
                               capture_output=True)
                walls[m].append(time.perf_counter() - t0)
        cmp = subprocess.run([sys.executable, "-m", "tubes.h5compare", "--rtol", "1e-8", "dop853.h5", "auto.h5"],
                             cwd=d, capture_output=True, text=True, env=dict(env, PYTHONPATH=str(ROOT / "python")))
    med = {m: statistics.median(w) for m, w in walls.items()}
    ratio = med["auto"] / med["dop853"]
    differ = [ln.split(":")[0] for ln in cmp.stdout.splitlines() if ln.startswith("/")]
    print(f"paper run: dop853 {med['dop853']:.2f} s, auto {med['auto']:.2f} s (median of {runs}), ratio {ratio:.2f}")
    lines = ["<!-- bench_paper_method begin -->",
             "### The paper's run on the Taylor method (issue 36)", "",
             f"`./tubes input/paper.nml` with its method 'auto' (the Taylor method for the states, the ensembles "
             f"in lanes, DOP853 for the variational equations) and with 'dop853' throughout (its method before "
             f"2026-11-29), the same executable, run alternately {runs} times each, OMP_NUM_THREADS="
             f"{env['OMP_NUM_THREADS']} ({platform.machine()}, {os.cpu_count()} CPUs, "
             f"{time.strftime('%Y-%m-%d')}; bench/bench_paper_method.py):", "",
             "| method | runs [s] | median [s] |", "|---|---|---|"]
    for m in ("dop853", "auto"):
        lines.append(f"| {m} | {', '.join(f'{w:.2f}' for w in walls[m])} | {med[m]:.2f} |")
    lines += ["", f"auto / dop853 = **{ratio:.2f}** (the target: at most 0.5). The outputs beyond 1e-8 relative "
              f"(`python -m tubes.h5compare --rtol 1e-8`): {len(differ)} objects, each explained in docs/paper.md "
              "(\"The paper's run on the Taylor method\"):", "",
              "    " + (", ".join(differ) if differ else "none"), "",
              "<!-- bench_paper_method end -->"]
    write_section("bench_paper_method", lines)


if __name__ == "__main__":
    main()
