"""The paper's transition fraction, Fig. 4(b)'s theory curve, from the Python API alone.

p_trans(dE) = A_tube / A_E: the area of the stable tube's cut with the section U1^- over the area
of the energy surface on it (Ross et al. 2018, eq. (p_trans); docs/theory.md), at the energies of
input/paper.nml's &transition, with the Monte Carlo check at dE = 100 of its &montecarlo. No input
file, no HDF5: tubes.Model() is the paper's four-well ball and every default (the saddle S12, the
section U1^-, the tolerances) is the program's own. input/paper.nml chooses method 'auto' (the
Taylor method for the states, DOP853 for the variational equations), the default, and so does
this script: the numbers are the program's to the last bit (tests/test_python_scenes.py runs this
script against ./tubes input/paper.nml). With {"method": "dop853"} they are the paper run's before
2026-11-29, the areas within 6e-12 relative of these (docs/paper.md).

    .venv/bin/python docs/examples/p_trans.py [p_trans.png]
"""
import sys

import numpy as np

import tubes

DE = [1, 5, 10, 20, 40, 60, 80, 100, 140, 200, 300, 400, 500, 600, 700]   # (cm/s)^2
INTEGRATOR = {"method": "auto"}                                            # input/paper.nml's


def compute(dE=DE, mc_dE=100.0, n_samples=10000, seed=12345):
    """The transition table and the Monte Carlo check: (transition dict, monte_carlo dict)."""
    m = tubes.Model()
    return (m.transition(dE=dE, integrator=INTEGRATOR),
            m.monte_carlo(dE=mc_dE, n_samples=n_samples, seed=seed, integrator=INTEGRATOR))


def plot(tr, mc, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    ax.plot(tr["dE"], tr["p_trans"], "o-", label="A_tube / A_E (tube dynamics)")
    ax.errorbar([mc["dE"]], [mc["fraction"]], yerr=[2 * mc["std_error"]], fmt="s", color="r", capsize=3,
                label=f"Monte Carlo, {mc['transit'].size} points (2 s.e.)")
    ax.set_xlabel("dE [(cm/s)^2]")
    ax.set_ylabel("transition fraction p_trans")
    ax.grid(True, lw=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)


def main(argv):
    tr, mc = compute()
    print(f"{'dE':>8} {'A_tube':>14} {'A_E':>14} {'p_trans':>12}")
    for d, at, ae, p in zip(tr["dE"], tr["A_tube"], tr["A_E"], tr["p_trans"]):
        print(f"{d:8.4g} {at:14.8g} {ae:14.8g} {p:12.6g}")
    z = (mc["fraction"] - mc["p_trans"]) / mc["std_error"]
    print(f"Monte Carlo at dE = {mc['dE']:g}: {mc['fraction']:.4f} +- {mc['std_error']:.4f} against "
          f"A_tube/A_E = {mc['p_trans']:.4f} ({z:+.1f} standard errors), {mc['misclassified']} misclassified")
    if np.any(np.isnan(tr["p_trans"])):
        sys.exit("p_trans: a tube cut failed (NaN in the table)")
    if abs(z) > 4 or mc["misclassified"]:
        sys.exit("p_trans: the Monte Carlo check disagrees with the tube (more than 4 standard errors, "
                 "or points misclassified)")
    path = argv[1] if len(argv) > 1 else "p_trans.png"
    plot(tr, mc, path)
    print(f"wrote {path}")


if __name__ == "__main__":
    main(sys.argv)
