"""The Monte Carlo's throughput against the commit on which issue 36 was filed (issue 36's target: at
least 2.5x). Both executables in one run: the base commit (BASE below) is checked out into a git
worktree under build/bench-base and built there once (make's serial flavour; kept for the next
run), this tree's ./tubes is the other. Throughput at dE = 100 = (400,000 - 2,000) points over the
difference of a 400,000- and a 2,000-point run's wall times (the set-up, the tube's cut, cancels),
each method ('dop853' and 'taylor') of each executable, 1 and 2 threads, the runs interleaved
(one round: every executable x method x size once), median of `rounds`. The base taken at its
strongest: its faster method. Writes its section of docs/benchmarks.md.

    .venv/bin/python bench/bench_mc_base.py [rounds]
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

BASE = "037eef8"          # main when issue 36 was filed (2026-11-29 04:13), before its first commit
BIG, SMALL = 400000, 2000


def base_binary():
    wt = ROOT / "build" / "bench-base"
    exe = wt / "build" / "bin" / "tubes"
    if not exe.exists():
        if not wt.exists():
            subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(wt), BASE], check=True)
        print(f"bench_mc_base: building {BASE} in {wt}", file=sys.stderr)
        subprocess.run(["make", "-j2", "build/bin/tubes"], cwd=wt, check=True, capture_output=True)
    return exe


def run(exe, method, n, threads, d):
    nml = pathlib.Path(d) / f"mc_{method}_{n}.nml"
    nml.write_text(f"&run scenes = 'montecarlo' /\n&montecarlo de = 100, n_samples = {n} /\n"
                   f"&integrator method = '{method}' /\n")
    env = dict(os.environ, OMP_NUM_THREADS=str(threads), OPENBLAS_NUM_THREADS="1")
    t0 = time.perf_counter()
    subprocess.run([str(exe), str(nml), "-o", str(pathlib.Path(d) / "mc.h5")], cwd=d, env=env, check=True,
                   capture_output=True)
    return time.perf_counter() - t0


def main():
    rounds = int(sys.argv[1]) if len(sys.argv) > 1 else 5
    exes = {"base": base_binary(), "now": ROOT / "tubes"}
    cases = [(e, m) for e in exes for m in ("dop853", "taylor")]
    rate = {}
    with tempfile.TemporaryDirectory() as d:
        for e, m in cases:                                  # kernels built, caches warm: not timed
            run(exes[e], m, SMALL, 1, d)
        for threads in (1, 2):
            times = {(e, m, n): [] for e, m in cases for n in (BIG, SMALL)}
            for _ in range(rounds):
                for e, m in cases:
                    for n in (SMALL, BIG):
                        times[(e, m, n)].append(run(exes[e], m, n, threads, d))
            for e, m in cases:
                big, small = statistics.median(times[(e, m, BIG)]), statistics.median(times[(e, m, SMALL)])
                rate[(e, m, threads)] = (BIG - SMALL) / (big - small)
    lines = ["<!-- bench_mc_base begin -->", "### The Monte Carlo against the commit issue 36 was filed on", "",
             f"Measured {time.strftime('%Y-%m-%d')} on {platform.node()} ({platform.machine()}, {os.cpu_count()} CPUs) "
             f"by bench/bench_mc_base.py: `&montecarlo de = 100`, the throughput (points/s) from the difference of a "
             f"{BIG:,}- and a {SMALL:,}-point run (wall, medians of {rounds}, the runs interleaved), this tree's "
             f"./tubes and commit {BASE}'s (built in build/bench-base), each with DOP853 and the Taylor method:", "",
             "| threads | base dop853 | base taylor | now dop853 | now taylor | now taylor / base's best |",
             "|---|---|---|---|---|---|"]
    for threads in (1, 2):
        best = max(rate[("base", "dop853", threads)], rate[("base", "taylor", threads)])
        lines.append(f"| {threads} | " + " | ".join(f"{rate[(e, m, threads)]:,.0f}" for e, m in cases)
                     + f" | **{rate[('now', 'taylor', threads)] / best:.2f}** |")
    lines += ["", "Issue 36's target: at least 2.5x the base's throughput (its faster method).",
              "<!-- bench_mc_base end -->", ""]
    print("\n".join(lines))
    write_section("bench_mc_base", lines)


if __name__ == "__main__":
    main()
