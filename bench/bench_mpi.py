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
from benchdoc import write_section  # noqa: E402

MPI_BIN = ROOT / "build" / "mpi" / "bin" / "tubes"
# scene: (input, items per synchronisation: the most workers one loop can keep busy)
SCENES = {
    "tube cut, dE = 100, area_tol 1e-10 (4096 seeds, twice)":
        ("&run scenes = 'tubes' /\n&tubes de = 100, area_tol = 1e-10 /\n", "64 (first rounds) .. 2048"),
    "Monte Carlo, 20000 points at dE = 100":
        ("&run scenes = 'montecarlo' /\n&montecarlo de = 100, n_samples = 20000 /\n", "20000 (after a 64..2048-seed cut)"),
    "Poincare maps, 2 x 40 seeds x 300 returns":
        ("&run scenes = 'sections' /\n&sections de = 100, 500, n_seeds = 40, n_iter = 300 /\n", "40"),
    "p_trans on 15 energies (transition)":
        ("&run scenes = 'transition' /\n&transition de = 1, 5, 10, 20, 40, 60, 80, 100, 140, 200, 300, 400, 500, 600, "
         "700 /\n", "15 energies (ranks) x 64.. seeds (threads)"),
    "input/paper.nml (every scene)": (None, "all of the above"),
}
CONFIGS = [("serial", 1, 1), ("serial", 1, 2), ("mpi", 1, 1), ("mpi", 1, 2), ("mpi", 2, 1), ("mpi", 2, 2)]
REPEAT = 3


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
    # launch overhead: mpirun, MPI_Init and MPI_Finalize around a run that does nothing
    launch = {}
    for n in (1, 2):
        best = 1e9
        for _ in range(3):
            t0 = time.perf_counter()
            subprocess.run(launcher() + ["-np", str(n), str(MPI_BIN), "--version"], capture_output=True, check=True,
                           env=dict(os.environ, OMP_NUM_THREADS="1"))
            best = min(best, time.perf_counter() - t0)
        launch[n] = best
    print(f"bench_mpi: launch overhead {launch}", flush=True)
    for name, (nml, items) in SCENES.items():
        with tempfile.TemporaryDirectory() as d:
            d = pathlib.Path(d)
            path = ROOT / "input" / "paper.nml" if nml is None else d / "b.nml"
            if nml is not None:
                path.write_text(nml)
            times, same = {c: 1e9 for c in CONFIGS}, True
            # the configurations interleaved, REPEAT rounds, the best of each: a slow spell of the
            # machine then spoils one round of every configuration rather than one configuration
            for rep in range(REPEAT):
                for kind, ranks, threads in CONFIGS:
                    w = d / f"{kind}{ranks}x{threads}"
                    w.mkdir(exist_ok=True)
                    c = (kind, ranks, threads)
                    times[c] = min(times[c], run(kind, ranks, threads, path, w, repeat=1))
                    if rep == 0 and c != ("serial", 1, 1):
                        diffs = [x for x in compare(str(d / "serial1x1" / "out.h5"), str(w / "out.h5"))
                                 if "input_namelist" not in x]
                        same = same and not diffs
            for c in CONFIGS:
                print(f"bench_mpi: {name}: {c[0]} {c[1]}x{c[2]}: {times[c]:.2f} s", flush=True)
            t1 = times[("serial", 1, 1)]
            rows.append(f"| {name} | " + " | ".join(f"{times[c]:.2f}" for c in CONFIGS)
                        + f" | {t1 / times[('mpi', 2, 1)]:.2f} | {'yes' if same else '**no**'} |")
            # cost model: T(W) = L + s + p/W on W workers, L the launch overhead; s from the
            # 2-rank run (repeated serial work, synchronisation and load imbalance all count as s)
            t1n = times[("mpi", 1, 1)] - launch[1]
            t2n = times[("mpi", 2, 1)] - launch[2]
            s = min(max(0.0, 2 * t2n - t1n), t1n)
            p = t1n - s
            pred = [(s + p / w_) for w_ in (8, 32, 128)]
            model.append(f"| {name} | {s:.2f} | {p:.2f} | {s / (s + p):.0%} | {items} | "
                         + " | ".join(f"{t1n / x:.1f}" for x in pred) + f" | {(s + p) / max(s, 1e-9):.0f} |")
    head = "| scene | serial 1 thr | serial 2 thr | MPI 1x1 | MPI 1x2 | MPI 2x1 | MPI 2x2 | speed-up 2x1 | identical |"
    lines = ["<!-- bench_mpi begin -->", "## MPI scaling", "",
             f"Measured {datetime.date.today().isoformat()} by `make bench` (bench/bench_mpi.py) on {os.cpu_count()} "
             f"cores ({cpu}), OpenMPI, `--bind-to none`; wall time in s, best of {REPEAT} interleaved rounds; ranks x threads. "
             "2x2 oversubscribes the 2 cores. *identical*: every output file equals the serial one bit for bit "
             "(python -m tubes.h5compare).", "",
             head, "|" + "---|" * (head.count("|") - 1), *rows, "",
             f"MPI launch overhead (mpirun, MPI_Init, MPI_Finalize; `tubes --version`): {launch[1]:.2f} s with 1 rank, "
             f"{launch[2]:.2f} s with 2; it is included in the MPI columns above.", "",
             "Cost model (docs/cluster.md): T(W) = L + s + p/W on W = ranks x threads workers, L the launch overhead, "
             "s (work every rank repeats, synchronisation, load imbalance) = 2 T'(2x1) - T'(1x1) and p = T'(1x1) - s, "
             "with T' = T - L. Predicted speed-up of the computation (T' over s + p/W), an upper bound once W "
             "exceeds the items per synchronisation:", "",
             "| scene | s [s] | p [s] | s share | items per synchronisation | W = 8 | W = 32 | W = 128 | limit (W -> inf) |",
             "|---|---|---|---|---|---|---|---|---|", *model, "<!-- bench_mpi end -->", ""]
    for ln in lines:
        print(ln)
    write_section("bench_mpi", lines)


if __name__ == "__main__":
    main()
