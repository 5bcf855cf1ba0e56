"""A parameter scan: the paper's ball with the bowl's curvature alpha varied (docs/models.md).

One call, Model.scan with p_trans=True (docs/scan.md): for each alpha the saddle S12's energy
E_e and its centre frequency omega, and the transition fraction p_trans at dE = 2 and 20 (cm/s)^2,
each what Model(alpha=...).transition gives there. Close to the saddle the tube's cut is the
Lyapunov orbit's action, A_tube = 2 pi dE / omega to leading order (docs/theory.md): the script
prints the ratio of the computed A_tube to it at dE = 2, 1 to ~1e-4. DOP853
(integrator={'method': 'dop853'}) is used so that no Taylor kernel is compiled per alpha: four
values of alpha, about 2 s.

    .venv/bin/python docs/examples/parameter_scan.py [OUTDIR]   (writes OUTDIR/parameter_scan.png)
"""
import math
import os
import sys

import numpy as np

import tubes

DE = [2.0, 20.0]                      # (cm/s)^2


def main(outdir="."):
    rows = []
    print(f"{'alpha':>6} {'E_e':>12} {'omega':>10} {'p(dE=2)':>10} {'p(dE=20)':>10} {'A_tube/(2 pi dE/omega)':>24}")
    s = tubes.Model(alpha=0.06).scan("alpha", 0.09, 3, dE=DE, p_trans=True, saddle="S12",
                                     integrator={"method": "dop853"})
    for k, a in enumerate(s.value):
        w = float(s.omega[k, 0])
        ratio = s.A_tube[k, 0] / (2 * math.pi * DE[0] / w)
        rows.append((a, s.saddle_energy[k], w, *s.p_trans[k], ratio))
        print(f"{a:6.3f} {s.saddle_energy[k]:12.4f} {w:10.6f} {s.p_trans[k, 0]:10.6f} {s.p_trans[k, 1]:10.6f} "
              f"{ratio:24.6f}")
    r = np.array(rows)

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot(r[:, 0], r[:, 3], "o-", label="dE = 2 (cm/s)^2")
    ax.plot(r[:, 0], r[:, 4], "s-", label="dE = 20 (cm/s)^2")
    ax.set_yscale("log")
    ax.set_xlabel("alpha [1/cm]")
    ax.set_ylabel("p_trans = A_tube / A_E")
    ax.set_title("the four-well ball: p_trans against the bowl's curvature")
    ax.grid(True, lw=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    path = os.path.join(outdir, "parameter_scan.png")
    fig.savefig(path, dpi=110)
    plt.close(fig)
    print(f"wrote {path}")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else ".")
