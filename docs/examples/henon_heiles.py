"""Hénon–Heiles: the saddles and a Poincaré section just above the escape energy (docs/models.md).

H = (px^2 + py^2)/2 + (x^2 + y^2)/2 + x^2 y - y^3/3. Its three saddles sit on the unit circle at
the escape energy E_e = 1/6 (closed form: V = 1/6 at (0, 1) and (+-sqrt(3)/2, -1/2)). The section
is the model's default, y = 0 with dy/dt > 0, at dE = 0.002 above E_e: 30 seeds x 150 returns
(reduced from the sections scene's defaults so that the script runs in about a second); a seed
that leaves through a saddle stops returning (NaN), and the script counts them.

    .venv/bin/python docs/examples/henon_heiles.py [OUTDIR]    (writes OUTDIR/henon_heiles.png)
"""
import os
import sys

import numpy as np

import tubes


def main(outdir="."):
    m = tubes.Model(system="henon_heiles")
    eq = tubes.equilibria(m)
    for name, e, k, x, y in zip(eq["name"], eq["energy"], eq["morse_index"], eq["x"], eq["y"]):
        print(f"{name}: ({x:+.6f}, {y:+.6f}), energy {e:.10f}, index {k}, |q| = {np.hypot(x, y):.6f}")
    P = tubes.poincare(m, dE=0.002, n_seeds=30, n_iter=150).points
    escaped = int(np.sum(~np.isfinite(P[:, -1, 0])))
    print(f"section y = 0 at dE = 0.002: {int(np.isfinite(P[..., 0]).sum())} returns, {escaped} of "
          f"{P.shape[0]} seeds escaped")

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(5.5, 5))
    for s in P:
        ax.plot(s[:, 0], s[:, 1], ".", ms=1.2)
    ax.set_xlabel("x")
    ax.set_ylabel("p_x")
    ax.set_title("Hénon–Heiles, y = 0, E = 1/6 + 0.002")
    fig.tight_layout()
    path = os.path.join(outdir, "henon_heiles.png")
    fig.savefig(path, dpi=110)
    plt.close(fig)
    print(f"wrote {path}")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else ".")
