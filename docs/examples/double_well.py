"""A double well written as a formula, from H to Monte Carlo (docs/models.md, "Models from the
input file"): H = (px^2 + py^2)/2 - x^2/2 + x^4/4 + w^2 y^2/2, w = 1.3.

The saddle is the origin at E_e = 0 (wells at x = +-1, E = -1/4), with growth rate lambda = 1 and
frequency omega = w. The bath y is harmonic and uncoupled, so the Lyapunov orbit's action, the
area of the tube's cut, is exactly A_tube = 2 pi dE / w at every dE (not only to leading order):
the script prints it beside the computed area. On the section the energy surface's cut is the
ellipse py^2/2 + w^2 y^2/2 <= E - U(-0.5), U(x) = -x^2/2 + x^4/4, so A_E = 2 pi (dE - U(-0.5)) / w
and p_trans = dE / (dE - U(-0.5)) exactly (U(-0.5) = -0.109375). The transition fraction p_trans = A_tube / A_E on
the section x = -0.5 (dx/dt > 0) is checked by a Monte Carlo run of 2000 points (reduced from the
program's default so that the script runs in ~10 s; the first run also compiles the model's
Taylor kernels, cached in ~/.cache/tubes).

    .venv/bin/python docs/examples/double_well.py [OUTDIR]      (writes OUTDIR/double_well.png)
"""
import math
import os
import sys

import numpy as np

import tubes

W = 1.3
H = "(px^2 + py^2)/2 - x^2/2 + x^4/4 + w^2*y^2/2"
SECTION = {"kind": "plane", "index": 1, "value": -0.5, "direction": 1}   # x = -0.5, dx/dt > 0
DE = [0.01, 0.02, 0.05, 0.1, 0.15]


def main(outdir="."):
    m = tubes.Model(system="expression", hamiltonian=H, constants={"w": W})
    eq = tubes.equilibria(m)
    i = int(np.argmax(eq["morse_index"] == 1))          # the saddle (index 1)
    print(f"saddle {eq['name'][i]} at E_e = {eq['energy'][i]:.3g} (closed form 0), lambda = {eq['lambda'][i]:.6f} "
          f"(1), omega = {eq['omega'][i]:.6f} ({W})")
    tr = tubes.transition(m, dE=DE, section=SECTION)
    u = -0.5**2 / 2 + 0.5**4 / 4
    print(f"{'dE':>6} {'A_tube':>12} {'2 pi dE / w':>12} {'A_E':>12} {'p_trans':>10} {'dE/(dE-U)':>10}")
    for d, at, ae, p in zip(tr["dE"], tr["A_tube"], tr["A_E"], tr["p_trans"]):
        print(f"{d:6.3g} {at:12.8f} {2 * math.pi * d / W:12.8f} {ae:12.8f} {p:10.6f} {d / (d - u):10.6f}")
    mc = tubes.monte_carlo(m, dE=0.05, n_samples=2000, seed=1, section=SECTION)
    print(f"Monte Carlo at dE = 0.05: {mc['fraction']:.4f} +- {mc['std_error']:.4f} against A_tube/A_E = "
          f"{mc['p_trans']:.4f}")

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot(tr["dE"], tr["p_trans"], "o-", label="A_tube / A_E")
    ax.errorbar([0.05], [mc["fraction"]], yerr=[2 * mc["std_error"]], fmt="s", color="r", capsize=3,
                label="Monte Carlo, 2000 points (2 s.e.)")
    ax.set_xlabel("dE = E - E_e")
    ax.set_ylabel("transition fraction on x = -0.5")
    ax.set_title("H = p^2/2 - x^2/2 + x^4/4 + w^2 y^2/2")
    ax.grid(True, lw=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    path = os.path.join(outdir, "double_well.png")
    fig.savefig(path, dpi=110)
    plt.close(fig)
    print(f"wrote {path}")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else ".")
