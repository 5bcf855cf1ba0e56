"""The damped region (docs/dissipation.md): with viscous damping the tube's cut on U1^- gives way
to the transition region, the points of the section that still reach the other well. At
dE = 100 (cm/s)^2 on the paper's ball: the conservative tube's cut beside the regions at damping
ratios zeta = 1e-6, 0.0025 and 0.025. As zeta -> 0 the region's area tends to the cut's
(continuity, docs/dissipation.md); it shrinks as zeta grows. One dE and DOP853 (no Taylor
kernel): a few seconds (damping.py draws the whole p_trans table, ~40 s).

    .venv/bin/python docs/examples/damped_region.py [OUTDIR]   (writes OUTDIR/damped_region.png)
"""
import os
import sys

import tubes

DE = 100.0
DOP853 = {"method": "dop853"}
ZETAS = [1e-6, 0.0025, 0.025]


def main(outdir="."):
    cut = tubes.Model().tube_cut(dE=DE, integrator=DOP853)
    print(f"conservative tube cut at dE = {DE:g}: area {cut['area']:.6f} cm^2/s")
    regions = {}
    for z in ZETAS:
        r = tubes.Model(damping_ratio=z).transition_region(dE=DE, integrator=DOP853)
        regions[z] = r
        print(f"zeta = {z:g}: region area {r['area']:.6f}, ratio to the cut {r['area'] / cut['area']:.6f}, "
              f"p_trans {r['p_trans']:.6f}")

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6, 5))
    ax.plot(cut["r"], cut["p_r"], "k-", lw=1.2, label="conservative tube cut")
    for z in ZETAS[1:]:
        r = regions[z]
        ax.plot(r["curve_r"], r["curve_p_r"], ".", ms=1.5, label=f"damped region, zeta = {z:g}")
    ax.set_xlabel("r on U1^- [cm]")
    ax.set_ylabel("p_r [cm/s]")
    ax.set_title(f"the paper's ball at dE = {DE:g} (cm/s)^2")
    ax.legend(fontsize=8)
    ax.grid(True, lw=0.3)
    fig.tight_layout()
    path = os.path.join(outdir, "damped_region.png")
    fig.savefig(path, dpi=110)
    plt.close(fig)
    print(f"wrote {path}")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else ".")
