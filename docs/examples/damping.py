"""The paper's ball with dissipation (docs/dissipation.md), from the Python API: p_trans(dE) of the
conservative model and of the damped one at several damping ratios and rolling resistances
(the transition region's area over A_E), and on U1^- at dE = 100 the conservative tube's cut
beside the damped regions. Prints the table it draws.

    .venv/bin/python docs/examples/damping.py [damping.png]     (about 40 s on 2 cores)
"""
import sys

import numpy as np

import tubes

DE = [10, 20, 40, 60, 80, 100, 120, 140, 160, 200, 250, 300, 400, 500, 600, 700]   # (cm/s)^2
LAWS = [("conservative", {}), ("zeta 0.0025", {"damping_ratio": 0.0025}), ("zeta 0.005", {"damping_ratio": 0.005}),
        ("zeta 0.014", {"damping_ratio": 0.014}), ("zeta 0.025", {"damping_ratio": 0.025}),
        ("C_rr 0.003", {"rolling_resistance": 0.003}), ("C_rr 0.006", {"rolling_resistance": 0.006}),
        ("C_rr 0.013", {"rolling_resistance": 0.013})]


def compute():
    """{label: (p_trans over DE, the region or tube cut at dE = 100, threshold)}."""
    out = {}
    for label, par in LAWS:
        m = tubes.Model(**par)
        t = m.transition(dE=DE)
        if par:
            r = m.transition_region(dE=100.0)
            curve = (r["curve_r"], r["curve_p_r"])
            thr = t["dE_threshold"]
        else:
            c = m.tube_cut(dE=100.0)
            curve = (c["r"], c["p_r"])
            thr = (np.nan, np.nan)
        out[label] = (np.asarray(t["p_trans"]), curve, thr)
    return out


def main(path=None):
    res = compute()
    print(f"{'dE':>6} " + " ".join(f"{label:>13}" for label, _ in LAWS))
    for k, de in enumerate(DE):
        print(f"{de:6g} " + " ".join(f"{res[label][0][k]:13.6f}" for label, _ in LAWS))
    de = np.array(DE, float)
    fit = de <= 160                 # the paper's fit: through the origin over dE <= 160 (uniform weights)
    for label, _ in LAWS:
        p = res[label][0]
        slope = np.sum(de[fit] * p[fit]) / np.sum(de[fit] ** 2)
        lo, hi = res[label][2]
        print(f"{label}: slope through the origin over dE <= 160: {slope * 1e3:.3f}e-3 (s/cm)^2"
              + (f"; no transit at dE <= {lo:.6g}, a region at {hi:.6g}" if np.isfinite(lo) else ""))
    if path is None:
        return
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (a, b) = plt.subplots(1, 2, figsize=(12, 4.8))
    for label, _ in LAWS:
        a.plot(DE, res[label][0], "o-" if label == "conservative" else ".-", label=label, ms=4)
    a.set_xlabel("dE at U1 [(cm/s)^2]")
    a.set_ylabel("p_trans = A / A_E")
    a.set_title("transition fraction: conservative tube and damped regions")
    a.grid(True, lw=0.3)
    a.legend(fontsize=8)
    bd = tubes.section_boundary(dE=100.0)
    b.plot(bd["s"], bd["p_min"], "m", lw=0.8)
    b.plot(bd["s"], bd["p_max"], "m", lw=0.8, label="energy surface, dE = 100")
    for label, _ in LAWS:
        r, p = res[label][1]
        if len(r):
            b.plot(np.append(r, r[0]), np.append(p, p[0]), lw=1.4 if label == "conservative" else 1, label=label)
    b.set_xlabel("r [cm]")
    b.set_ylabel("p_r [cm/s]")
    b.set_xlim(6, 11.5)
    b.set_ylim(-56, -26)
    b.set_title("U1^- at dE = 100: the tube's cut and the damped regions")
    b.legend(fontsize=7, loc="upper right")
    fig.tight_layout()
    fig.savefig(path, dpi=120)


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else None)
