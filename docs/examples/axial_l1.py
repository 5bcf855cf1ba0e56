"""The Earth–Moon L1 vertical and axial families in 3-D (docs/orbits.md, "The vertical and axial
families"): the orbits scene (run as a command) on the spatial CR3BP, &orbits family = 'lyapunov'
(the planar family, grey), 'vertical' (green) and 'axial' (blue) at dE = 0.084 .. 0.098, between the
planar family's branch point (dE = 0.0834745, where the axial family starts) and the vertical
family's (0.0982711, where it ends). Printed per axial orbit: dE, the Jacobi constant C = -2E, the
period and the start (on the x axis: x0, vy0 = py0 - x0, vz0; tests/test_axial.py checks such orbits
against an independent scipy corrector). About 11 s.

    .venv/bin/python docs/examples/axial_l1.py [OUTDIR]    (writes OUTDIR/axial_l1.png)
"""
import os
import pathlib
import subprocess
import sys

import h5py

TUBES = pathlib.Path(__file__).resolve().parents[2] / "tubes"
DES = [0.084, 0.087, 0.09, 0.093, 0.096, 0.098]


def family(outdir, fam):
    name = f"l1_{fam}"
    (pathlib.Path(outdir) / f"{name}.nml").write_text(
        f"&run scenes = 'orbits', output = '{name}.h5' /\n&model system = 'cr3bp', spatial = .true. /\n"
        f"&orbits saddle = 'L1', family = '{fam}', de = {', '.join(map(str, DES))}, n_samples = 301 /\n")
    r = subprocess.run([str(TUBES), f"{name}.nml"], cwd=outdir, capture_output=True, text=True)
    assert r.returncode in (0, 4), r.stderr          # 4: an energy off the family (said on stderr)
    with h5py.File(pathlib.Path(outdir) / f"{name}.h5") as f:
        g = f["orbits"]
        return [(de, -2 * e, t, g["state0"][k], g[f"orbit_{k:03d}"]["state"][()])
                for k, (de, e, t, ok) in enumerate(zip(g["dE"][()], g["energy"][()], g["period"][()],
                                                         g["converged"][()])) if ok]


def main(outdir="."):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig = plt.figure(figsize=(7, 5.5))
    ax = fig.add_subplot(projection="3d")
    for fam, colour in (("lyapunov", "0.6"), ("vertical", "C2"), ("axial", "C0")):
        for de, c, t, s0, x in family(outdir, fam):
            ax.plot(x[:, 0], x[:, 1], x[:, 2], color=colour, lw=0.8)
            if fam == "axial":
                print(f"axial: dE = {de:g}, C = {c:.10f}, period {t:.10f}, x0 = {s0[0]:.8f}, "
                      f"vy0 = {s0[4] - s0[0]:+.8f}, vz0 = {s0[5]:+.8f}")
    ax.set_xlabel("x")
    ax.set_ylabel("y")
    ax.set_zlabel("z")
    ax.set_title("Earth–Moon L1: planar Lyapunov (grey), vertical (green) and axial (blue)\n"
                 "dE = 0.084 .. 0.098 above L1", fontsize=9)
    fig.tight_layout()
    path = os.path.join(outdir, "axial_l1.png")
    fig.savefig(path, dpi=110)
    print(f"wrote {path}")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else ".")
