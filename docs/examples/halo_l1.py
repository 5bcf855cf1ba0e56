"""The Earth–Moon L1 planar Lyapunov and halo families in 3-D (docs/orbits.md, "Branch
switching"): the orbits scene (run as a command) on the spatial CR3BP, &orbits family = 2 (planar)
and family = 'halo_north' / 'halo_south' at dE = 0.008 .. 0.05. Printed per halo orbit: dE, the
Jacobi constant C = -2E, the period and z at its start (tests/test_halo.py checks such orbits
against an independent scipy corrector). About 5 s.

    .venv/bin/python docs/examples/halo_l1.py [OUTDIR]    (writes OUTDIR/halo_l1.png)
"""
import os
import pathlib
import subprocess
import sys

import h5py

TUBES = pathlib.Path(__file__).resolve().parents[2] / "tubes"
DES = [0.008, 0.012, 0.018, 0.026, 0.036, 0.05]


def family(outdir, fam):
    name = f"l1_{fam}"
    (pathlib.Path(outdir) / f"{name}.nml").write_text(
        f"&run scenes = 'orbits', output = '{name}.h5' /\n&model system = 'cr3bp', spatial = .true. /\n"
        f"&orbits saddle = 'L1', family = {fam if fam.isdigit() else repr(fam)}, "
        f"de = {', '.join(map(str, DES))}, n_samples = 301 /\n")
    subprocess.run([str(TUBES), f"{name}.nml"], cwd=outdir, check=True, capture_output=True, text=True)
    with h5py.File(pathlib.Path(outdir) / f"{name}.h5") as f:
        g = f["orbits"]
        return [(g.attrs["family_name"], de, -2 * e, t, g[f"orbit_{k:03d}"]["state"][()])
                for k, (de, e, t, ok) in enumerate(zip(g["dE"][()], g["energy"][()], g["period"][()],
                                                         g["converged"][()])) if ok]


def main(outdir="."):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig = plt.figure(figsize=(7, 5.5))
    ax = fig.add_subplot(projection="3d")
    for fam, colour in (("2", "0.5"), ("halo_north", "C0"), ("halo_south", "C3")):
        for name, de, c, t, x in family(outdir, fam):
            ax.plot(x[:, 0], x[:, 1], x[:, 2], color=colour, lw=0.8)
            if fam != "2":
                print(f"{name}: dE = {de:g}, C = {c:.10f}, period {t:.10f}, z0 = {x[0, 2]:+.8f}")
    ax.set_xlabel("x")
    ax.set_ylabel("y")
    ax.set_zlabel("z")
    ax.set_title("Earth–Moon L1: planar Lyapunov (grey), halo north (blue) and south (red)\n"
                 "dE = 0.008 .. 0.05 above L1", fontsize=9)
    fig.tight_layout()
    path = os.path.join(outdir, "halo_l1.png")
    fig.savefig(path, dpi=110)
    print(f"wrote {path}")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else ".")
