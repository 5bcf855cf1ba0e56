"""MPI scaling (make bench, when build/mpi/bin/tubes exists): wall time of typical scenes with
1-2 MPI ranks x 1-2 OpenMP threads, against the serial executable, each output compared bit for
bit with the serial one; then the cost model of docs/cluster.md fitted to these numbers and
its prediction for more ranks. Results into docs/benchmarks.md (between the bench_mpi markers)."""
import datetime
import os
import pathlib
import platform
import subprocess
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "python"))
from tubes.h5compare import compare  # noqa: E402

MPI_BIN = ROOT / "build" / "mpi" / "bin" / "tubes"
SCENES = {
    "tube cut, dE = 100, area_tol 1e-10 (4096 seeds, twice)": "&run scenes = 'tubes' /\n&tubes de = 100, area_tol = 1e-10 /\n",
    "Monte Carlo, 20000 points at dE = 100": "&run scenes = 'montecarlo' /\n&montecarlo de = 100, n_samples = 20000 /\n",
    "Poincare maps, 2 x 40 seeds x 300 returns": "&run scenes = 'sections' /\n&sections de = 100, 500, n_seeds = 40, n_iter = 300 /\n",
    "p_trans on 15 energies (transition)": "&run scenes = 'transition' /\n&transition de = 1, 5, 10, 20, 40, 60, 80, 100, 140, 200, 300, 400, 500, 600, 700 /\n",
    "input/paper.nml (every scene)": None,
}
CONFIGS = [("serial", 1, 1), ("serial", 1, 2), ("mpi", 1, 1), ("mpi", 1, 2), ("mpi", 2, 1), ("mpi", 2, 2)]


def launcher():
    v = subprocess.run(["mpirun", "--version"], capture_output=True, text=True)
    if "Open MPI" in v.stdout + v.stderr:
        return ["mpirun", "--allow-run-as-root", "--oversubscribe", "--bind-to", "none", "-x", "OMP_NUM_THREADS"]
    return ["mpiexec", "-genvlist", "OMP_NUM_THREADS"]


def run(kind, ranks, threads, nml_path, workdir, repeat=2):
    env = dict(os.environ, OMP_NUM_THREADS=str(threads), OPENBLAS_NUM_THREADS="1")
    if kind == "serial":
        cmd = [str(ROOT / "tubes"), str(nml_path), "-o", "out.h5"]
    else:
        cmd = launcher() + ["-np", str(ranks), str(MPI_BIN), str(nml_path), "-o", "out.h5"]
    best = 1e9
    for _ in range(repeat):
        t0 = time.perf_counter()
        r = subprocess.run(cmd, cwd=workdir, env=env, capture_output=True, text=True)
        best = min(best, time.perf_counter() - t0)
        if r.returncode not in (0, 4):
            raise RuntimeError(f"{cmd} failed ({r.returncode}): {r.stderr[-2000:]}")
    return best


def main():
    if not MPI_BIN.exists():
        print("bench_mpi: no build/mpi/bin/tubes (make MPI=1); skipped")
        return
    rows, model = [], []
    cpu = platform.processor() or platform.machine()
    try:
        cpu = next(ln.split(":", 1)[1].strip() for ln in open("/proc/cpuinfo") if ln.startswith("model name"))
    except (OSError, StopIteration):
        pass
    for name, nml in SCENES.items():
        with tempfile.TemporaryDirectory() as d:
            d = pathlib.Path(d)
            path = ROOT / "input" / "paper.nml" if nml is None else d / "b.nml"
            if nml is not None:
                path.write_text(nml)
            times, same = {}, True
            for kind, ranks, threads in CONFIGS:
                w = d / f"{kind}{ranks}x{threads}"
                w.mkdir()
                times[(kind, ranks, threads)] = run(kind, ranks, threads, path, w)
                if (kind, ranks, threads) != ("serial", 1, 1):
                    diffs = [x for x in compare(str(d / "serial1x1" / "out.h5"), str(w / "out.h5"))
                             if "input_namelist" not in x]
                    same = same and not diffs
                print(f"bench_mpi: {name}: {kind} {ranks}x{threads}: {times[(kind, ranks, threads)]:.2f} s", flush=True)
            t1 = times[("serial", 1, 1)]
            rows.append(f"| {name} | " + " | ".join(f"{times[c]:.2f}" for c in CONFIGS)
                        + f" | {t1 / times[('mpi', 2, 1)]:.2f} | {'yes' if same else '**no**'} |")
            # cost model: T(W) = s + p/W on W workers; s from the 2-rank run (replicated serial
            # work, synchronisation and load imbalance all count as s)
            s = max(0.0, 2 * times[("mpi", 2, 1)] - times[("mpi", 1, 1)])
            p = max(times[("mpi", 1, 1)] - s, 0.0)
            pred = [(s + p / w_) for w_ in (8, 32, 128)]
            model.append(f"| {name} | {s:.2f} | {p:.2f} | {s / (s + p):.0%} | "
                         + " | ".join(f"{times[('mpi', 1, 1)] / x:.1f}" for x in pred) + f" | {(s + p) / max(s, 1e-9):.0f} |")
    head = "| scene | serial 1 thr | serial 2 thr | MPI 1x1 | MPI 1x2 | MPI 2x1 | MPI 2x2 | speed-up 2x1 | identical |"
    lines = ["<!-- bench_mpi begin -->", "## MPI scaling", "",
             f"Measured {datetime.date.today().isoformat()} by `make bench` (bench/bench_mpi.py) on {os.cpu_count()} "
             f"cores ({cpu}), OpenMPI, `--bind-to none`; wall time in s, best of 2; ranks x threads. "
             "2x2 oversubscribes the 2 cores. *identical*: every output file equals the serial one bit for bit "
             "(python -m tubes.h5compare).", "",
             head, "|" + "---|" * (head.count("|") - 1), *rows, "",
             "Cost model (docs/cluster.md): T(W) = s + p/W on W = ranks x threads workers, with s (work every rank "
             "repeats, synchronisation, load imbalance) = 2 T(2x1) - T(1x1) and p = T(1x1) - s. Predicted speed-up "
             "over MPI 1x1 (an upper bound: it assumes every loop has >= W items):", "",
             "| scene | s [s] | p [s] | s share | W = 8 | W = 32 | W = 128 | limit (W -> inf) |",
             "|---|---|---|---|---|---|---|---|", *model, "<!-- bench_mpi end -->", ""]
    for ln in lines:
        print(ln)
    md = ROOT / "docs" / "benchmarks.md"
    text = md.read_text()
    if "<!-- bench_mpi begin -->" in text:
        text = text.split("<!-- bench_mpi begin -->")[0] + "\n".join(lines) + text.split("<!-- bench_mpi end -->")[1]
    else:
        text = text.rstrip() + "\n\n" + "\n".join(lines)
    md.write_text(text)


if __name__ == "__main__":
    main()
