"""Compare two tubes output files dataset by dataset and attribute by attribute.

    python -m tubes.h5compare A.h5 B.h5 [--rtol R] [--ignore NAME ...]

With the default rtol = 0 every number must be identical bit for bit (NaN equals NaN at the
same place). The provenance attributes that describe the run rather than its results (the
creation time, the command line, the compiler, the commit, the numbers of MPI ranks and OpenMP
threads, a formula model's cached library) are skipped. Exit status 0 when the files agree, 1 when they differ (each difference is listed
with the largest absolute and relative deviation), 2 on a usage or read error.
Used by make check to show that MPI and OpenMP runs reproduce the serial output (docs/cluster.md).
"""
from __future__ import annotations

import argparse
import sys

import h5py
import numpy as np

PROVENANCE = ("created", "command_line", "compiler", "fflags", "mpi_ranks", "omp_threads", "taylor_lanes",
              "taylor_lanes_driver",
              "input_file", "wall_seconds", "git_commit",
              # a formula's compiled library: where it is cached, its name (a hash that includes the
              # compiler: mpicc and gcc builds differ), how long building or loading it took
              "library", "library_name", "library_seconds", "library_cached")


def _without_output(text):
    """The effective namelist without its OUTPUT line: where a run wrote its file (-o) is
    provenance, not a result."""
    if isinstance(text, bytes):
        text = text.decode()
    return "\n".join(ln for ln in str(text).splitlines() if not ln.strip().upper().startswith("OUTPUT="))


def _values_equal(a, b, rtol: float) -> tuple[bool, str]:
    a = np.asarray(a)
    b = np.asarray(b)
    if a.shape != b.shape:
        return False, f"shape {a.shape} != {b.shape}"
    if a.dtype.kind in "fiuc" and b.dtype.kind in "fiuc":
        af = a.astype(np.float64) if a.dtype.kind != "c" else a
        bf = b.astype(np.float64) if b.dtype.kind != "c" else b
        nan_a, nan_b = np.isnan(af), np.isnan(bf)
        if not np.array_equal(nan_a, nan_b):
            return False, f"NaN at different places ({int(nan_a.sum())} vs {int(nan_b.sum())})"
        ok = ~nan_a
        if rtol == 0:
            same = np.array_equal(af[ok], bf[ok])
        else:
            same = np.allclose(af[ok], bf[ok], rtol=rtol, atol=0)
        if same:
            return True, ""
        d = np.abs(af[ok] - bf[ok])
        scale = np.maximum(np.abs(af[ok]), np.abs(bf[ok]))
        rel = np.max(np.where(scale > 0, d / np.where(scale > 0, scale, 1), 0))
        return False, f"max |diff| {d.max():.3e}, max rel {rel:.3e}, {int((d > 0).sum())} of {d.size} differ"
    if a.shape == ():
        va, vb = a.item(), b.item()
        if va == vb:
            return True, ""
        if isinstance(va, (str, bytes)) and isinstance(vb, (str, bytes)) and type(va) is type(vb):
            i = next((k for k, (x, y) in enumerate(zip(va, vb)) if x != y), min(len(va), len(vb)))
            return False, f"strings differ from character {i}: {va[max(0, i - 20):i + 30]!r} vs {vb[max(0, i - 20):i + 30]!r}"
        return False, f"{va!r} != {vb!r}"
    eq = bool(np.all(a == b))
    return eq, "" if eq else "values differ"


def compare(path_a: str, path_b: str, rtol: float = 0.0, ignore: tuple[str, ...] = ()) -> list[str]:
    """The differences between two HDF5 files, as readable lines (empty: they agree)."""
    skip = set(PROVENANCE) | set(ignore)
    diffs: list[str] = []
    with h5py.File(path_a, "r") as fa, h5py.File(path_b, "r") as fb:
        def attrs(name, oa, ob):
            ka = {k for k in oa.attrs if k not in skip}
            kb = {k for k in ob.attrs if k not in skip}
            for k in sorted(ka ^ kb):
                diffs.append(f"{name or '/'}: attribute {k} only in {'A' if k in ka else 'B'}")
            for k in sorted(ka & kb):
                va, vb = oa.attrs[k], ob.attrs[k]
                if k == "input_namelist":
                    va, vb = _without_output(va), _without_output(vb)
                eq, why = _values_equal(va, vb, rtol)
                if not eq:
                    diffs.append(f"{name or '/'}@{k}: {why}")

        names_a: list[str] = []
        names_b: list[str] = []
        fa.visit(names_a.append)
        fb.visit(names_b.append)
        for n in sorted(set(names_a) ^ set(names_b)):
            diffs.append(f"/{n}: only in {'A' if n in names_a else 'B'}")
        attrs("", fa, fb)
        for n in sorted(set(names_a) & set(names_b)):
            oa, ob = fa[n], fb[n]
            if isinstance(oa, h5py.Dataset) != isinstance(ob, h5py.Dataset):
                diffs.append(f"/{n}: a dataset in one file, a group in the other")
                continue
            if isinstance(oa, h5py.Dataset):
                eq, why = _values_equal(oa[()], ob[()], rtol)
                if not eq:
                    diffs.append(f"/{n}: {why}")
            attrs("/" + n, oa, ob)
    return diffs


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m tubes.h5compare", description=__doc__.split("\n")[0])
    ap.add_argument("a")
    ap.add_argument("b")
    ap.add_argument("--rtol", type=float, default=0.0, help="relative tolerance (default 0: bitwise)")
    ap.add_argument("--ignore", nargs="*", default=[], help="more attribute names to skip")
    args = ap.parse_args(argv)
    try:
        diffs = compare(args.a, args.b, args.rtol, tuple(args.ignore))
    except OSError as e:
        print(f"h5compare: {e}", file=sys.stderr)
        return 2
    for d in diffs:
        print(d)
    what = "identical" if args.rtol == 0 else f"equal to rtol {args.rtol:g}"
    print(f"h5compare: {args.a} and {args.b}: " + (what if not diffs else f"{len(diffs)} difference(s)"))
    return 0 if not diffs else 1


if __name__ == "__main__":
    sys.exit(main())
