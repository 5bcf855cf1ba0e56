"""The CR3BP's L1 tube and its cut (docs/models.md, "cr3bp"): Earth–Moon (the model's default mu),
the plane x = 0.9 between L1 and the Moon, crossed towards L1 (dx/dt < 0).

Printed: L1's position and energy (closed form: the root of the collinear quintic between the
primaries, and H = U_eff there, U_eff = -x^2/2 - (1 - mu)/r1 - mu/r2); the tube's cut at
dE = 1e-3 (2048 points, the cut's area by the program's two methods and the Lyapunov orbit's
action, which it equals), against the leading order 2 pi dE / omega; and p_trans = A_tube / A_E.
DOP853 so that no Taylor kernel is compiled; well under a second.

    .venv/bin/python docs/examples/cr3bp_l1.py [OUTDIR]    (writes OUTDIR/cr3bp_l1.png)
"""
import math
import os
import sys

import numpy as np

import tubes

SECTION = {"kind": "plane", "index": 1, "value": 0.9, "direction": -1}
DE = 1e-3
DOP853 = {"method": "dop853"}


def main(outdir="."):
    m = tubes.Model(system="cr3bp")
    mu = m.mu
    eq = tubes.equilibria(m)
    i = list(eq["name"]).index("L1")
    print(f"mu = {mu:.15g}: L1 at x = {eq['x'][i]:.10f}, energy {eq['energy'][i]:.10f}, lambda = {eq['lambda'][i]:.6f}, "
          f"omega = {eq['omega'][i]:.6f}")
    cut = m.tube_cut(dE=DE, section=SECTION, integrator=DOP853)
    lead = 2 * math.pi * DE / eq["omega"][i]
    print(f"tube cut at dE = {DE:g}: area {cut['area']:.10f} (polygon {cut['area_polygon']:.10f}), action "
          f"{cut['action']:.10f}, period {cut['period']:.6f}; leading order 2 pi dE / omega = {lead:.10f}")
    tr = m.transition(dE=[DE], section=SECTION, integrator=DOP853)
    print(f"p_trans = A_tube / A_E = {tr['A_tube'][0]:.6g} / {tr['A_E'][0]:.6g} = {tr['p_trans'][0]:.6f}")

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(5.5, 4.5))
    ax.plot(np.r_[cut["r"], cut["r"][:1]], np.r_[cut["p_r"], cut["p_r"][:1]], "-", lw=1)
    ax.set_xlabel("y on x = 0.9")
    ax.set_ylabel("p_y")
    ax.set_title(f"Earth–Moon: the L1 tube's cut, dE = {DE:g}")
    ax.grid(True, lw=0.3)
    fig.tight_layout()
    path = os.path.join(outdir, "cr3bp_l1.png")
    fig.savefig(path, dpi=110)
    plt.close(fig)
    print(f"wrote {path}")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else ".")
