"""The halo branch points of the Earth–Moon planar Lyapunov families (docs/orbits.md,
"Bifurcations"): the orbits scene on the spatial CR3BP (&orbits family = 2, the planar family) at
L1 and L2, dE = 0.001 .. 0.02, monitors the Floquet indices; the vertical pair's index nu_v
crosses +1 where the halo family branches off. Printed: each branch point's Jacobi constant
C = -2E, dE and period (tests/test_bifurcations.py checks them against an independent scipy
computation; literature: C ~ 3.1743 at L1, 3.1521 at L2). The figure: nu_v against C, the branch
points marked. About 5 s.

    .venv/bin/python docs/examples/halo_branch.py [OUTDIR]    (writes OUTDIR/halo_branch.png)
"""
import os
import pathlib
import subprocess
import sys

import h5py
import numpy as np

TUBES = pathlib.Path(__file__).resolve().parents[2] / "tubes"
DES = [round(0.001 * k, 3) for k in range(1, 21)]


def family(outdir, saddle):
    nml = pathlib.Path(outdir) / f"halo_{saddle}.nml"
    nml.write_text(f"&run scenes = 'orbits', output = 'halo_{saddle}.h5' /\n"
                   "&model system = 'cr3bp', spatial = .true. /\n"
                   f"&orbits saddle = '{saddle}', family = 2, de = {', '.join(map(str, DES))}, n_samples = 2 /\n")
    subprocess.run([str(TUBES), nml.name], cwd=outdir, check=True, capture_output=True, text=True)
    with h5py.File(pathlib.Path(outdir) / f"halo_{saddle}.h5") as f:
        g = f["orbits"]
        b = g["bifurcations"]
        return (-2 * g["energy"][()], g["floquet_index"][:, 1],
                {k: b[k][()] for k in ("kind", "dE", "energy", "period", "floquet_index")})


def main(outdir="."):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6, 4.2))
    for saddle, colour in (("L1", "C0"), ("L2", "C1")):
        c, nu_v, b = family(outdir, saddle)
        ax.plot(c, nu_v, ".-", color=colour, lw=1, label=f"{saddle} planar Lyapunov family: nu_v")
        for k in range(len(b["kind"])):
            cb = -2 * b["energy"][k]
            print(f"{saddle}: kind {b['kind'][k]} (branch point) at dE = {b['dE'][k]:.12g}, C = {cb:.12f}, "
                  f"period {b['period'][k]:.10f}, nu = {b['floquet_index'][k][0]:.6f}, {b['floquet_index'][k][1]:.10f}")
            ax.plot([cb], [1], "o", mfc="none", color=colour, ms=9)
            ax.annotate(f"halo branch {saddle}\nC = {cb:.6f}", (cb, 1), textcoords="offset points",
                        xytext=(-70 if saddle == "L1" else 10, 18), fontsize=8)
    ax.axhline(1, color="k", lw=0.5)
    ax.invert_xaxis()
    ax.set_xlabel("Jacobi constant C = -2E")
    ax.set_ylabel("vertical Floquet index nu_v = (lambda + 1/lambda)/2")
    ax.set_title("Earth–Moon: where the halo families branch off")
    ax.legend(fontsize=8, loc="lower right")
    ax.grid(True, lw=0.3)
    fig.tight_layout()
    path = os.path.join(outdir, "halo_branch.png")
    fig.savefig(path, dpi=110)
    print(f"wrote {path}")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else ".")
