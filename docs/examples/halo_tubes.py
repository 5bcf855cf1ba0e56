"""Tubes of the Earth–Moon halo orbits (docs/tubes.md, "Tubes of halo orbits"): the tubes scene
(run as a command) on the spatial CR3BP with `&orbits family = 'halo_north'`, the stable and
unstable manifolds of the L1 halo orbit at dE = 0.01 and of the L2 halo orbit at dE = 0.015, cut
by the Moon's plane x = 1 - mu (the branch towards the Moon of each). Printed per cut: the points,
the cut's loop integral of p . dq (the program's `area`) against the orbit's action, their
change with eps/10, the largest |C - C_orbit| of the cut's points (C = -2H computed here from the
written states), the flight times and the closest approach to the Moon's centre. About 10 s.

    .venv/bin/python docs/examples/halo_tubes.py [OUTDIR]    (writes OUTDIR/halo_tubes.png)
"""
import os
import pathlib
import subprocess
import sys

import h5py
import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]
TUBES = ROOT / "tubes"
sys.path.insert(0, str(ROOT / "python"))
MU = 0.01215058560962404
PLANE = 1 - MU
# (saddle, dE, kind, the crossing's sign of dx/dt): the branches towards the Moon
CUTS = [("L1", 0.01, "unstable", 1), ("L1", 0.01, "stable", -1),
        ("L2", 0.015, "stable", 1), ("L2", 0.015, "unstable", -1)]


def jacobi(s):
    x, y, z, px, py, pz = s.T
    r1 = np.sqrt((x + MU) ** 2 + y * y + z * z)
    r2 = np.sqrt((x - 1 + MU) ** 2 + y * y + z * z)
    return -((px * px + py * py + pz * pz) / 2 + y * px - x * py - (1 - MU) / r1 - MU / r2) * 2


def cut(outdir, saddle, de, kind, direction):
    name = f"{saddle}_{kind}"
    (pathlib.Path(outdir) / f"{name}.nml").write_text(
        f"&run scenes = 'orbits', 'tubes', output = '{name}.h5' /\n"
        f"&model system = 'cr3bp', spatial = .true. /\n"
        f"&orbits saddle = '{saddle}', family = 'halo_north', de = {de} /\n"
        f"&section kind = 'plane', index = 1, value = {PLANE!r}, direction = {direction} /\n"
        f"&tubes de = {de}, kind = '{kind}', t_max = 20 /\n")
    subprocess.run([str(TUBES), f"{name}.nml"], cwd=outdir, check=True, capture_output=True, text=True)
    with h5py.File(pathlib.Path(outdir) / f"{name}.h5") as f:
        g = f[f"tubes/{kind}_000"]
        c_orbit = -2 * f["orbits/energy"][0]
        return {"saddle": saddle, "dE": de, "kind": kind, "state": g["state"][()], "section": g["section"][()],
                "time": g["time"][()], "axes": g.attrs["axes"], "c_orbit": c_orbit,
                **{k: g.attrs[k] for k in ("area", "action", "area_eps_change", "period")}}


def main(outdir="."):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from tubes import plots
    cuts = [cut(outdir, *c) for c in CUTS]
    print(f"{'saddle':6} {'dE':>6} {'kind':>8} {'points':>6} {'area':>16} {'action':>16} {'area/action-1':>13} "
          f"{'eps/10 chg':>10} {'max|dC|':>8} {'flight time':>17} {'min r_Moon':>10}")
    for c in cuts:
        dc = np.max(np.abs(jacobi(c["state"]) - c["c_orbit"]))
        st = c["state"]
        r_moon = np.min(np.sqrt((st[:, 0] - 1 + MU) ** 2 + st[:, 1] ** 2 + st[:, 2] ** 2))
        t = np.abs(c["time"])
        print(f"{c['saddle']:6} {c['dE']:6g} {c['kind']:>8} {len(st):6d} {c['area']:16.13f} {c['action']:16.13f} "
              f"{c['area'] / c['action'] - 1:13.1e} {c['area_eps_change']:10.1e} {dc:8.1e} "
              f"{t.min():8.4f}..{t.max():7.4f} {r_moon:10.5f}")
    fig, axs = plt.subplots(2, 2, figsize=(10, 8))
    for row, saddle in enumerate(("L1", "L2")):
        for c in (c for c in cuts if c["saddle"] == saddle):
            colour = "C3" if c["kind"] == "unstable" else "C0"
            lab = f"{saddle} {c['kind']} (dE = {c['dE']:g})"
            for ax, pairs in zip(axs[row], ((0, 2), (0, 1))):
                plots.manifold_cut(c, ax=ax, pairs=pairs, label=lab, color=colour, lw=1)
        axs[row, 0].plot([0], [0], "k+", ms=10, label="the Moon's centre")
        circle = plt.Circle((0, 0), 1737.4 / 384400, color="0.8", zorder=0, label="the Moon's radius")
        axs[row, 0].add_patch(circle)
        axs[row, 0].set_aspect("equal", adjustable="datalim")
        for ax in axs[row]:
            ax.legend(fontsize=7)
    for ax in axs.ravel():
        ax.set_xlabel({"q2": "y", "p2": "p_y", "q3": "z"}.get(ax.get_xlabel(), ax.get_xlabel()))
        ax.set_ylabel({"q2": "y", "p2": "p_y", "q3": "z"}.get(ax.get_ylabel(), ax.get_ylabel()))
    fig.suptitle("Earth–Moon halo orbits (north): stable (blue) and unstable (red) tubes cut by x = 1 - mu\n"
                 "left: (y, z) on the plane; right: (y, p_y)", fontsize=10)
    fig.tight_layout()
    path = os.path.join(outdir, "halo_tubes.png")
    fig.savefig(path, dpi=110)
    print(f"wrote {path}")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else ".")
