"""Figures from tubes' HDF5 output (matplotlib, headless).

    python -m tubes.plots RESULT.h5 [-o DIR]

draws every figure the file has data for and prints the paths written.
"""
from __future__ import annotations

import argparse
import pathlib

import numpy as np

from . import load


def _mpl():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def surface_height(model, x, y):
    """H(x, y) of the four-well surface from the /model attributes (numpy)."""
    a, b, g, xi, h0 = (model.attrs[k] for k in ("alpha", "beta", "gamma", "xi", "h0"))
    return a * (x * x + y * y) - b * (np.sqrt(x * x + g) + np.sqrt(y * y + g)) - xi * x * y + h0


def plot_orbit_family(res, path):
    """The Lyapunov orbits in (x, y) over the zero-velocity curves g H = E of each energy."""
    plt = _mpl()
    orb = res.orbits
    g = res.model.attrs["g"]
    fig, ax = plt.subplots(figsize=(7, 6))
    xs = np.linspace(-5, 4, 450)
    ys = np.linspace(-1.5, 12.5, 700)
    X, Y = np.meshgrid(xs, ys)
    V = g * surface_height(res.model, X, Y)
    conv = np.asarray(orb.converged, dtype=bool)
    energies = np.asarray(orb.energy)[conv]
    cmap = plt.get_cmap("viridis")
    colors = [cmap(i / max(1, len(energies) - 1)) for i in range(len(energies))]
    ax.contourf(X, Y, V, levels=30, cmap="Greys", alpha=0.35)
    for k, (e, c) in enumerate(zip(energies, colors)):
        ax.contour(X, Y, V, levels=[e], colors=[c], linewidths=0.8, linestyles="--")
    ks = [k for k in range(len(orb.dE)) if conv[k]]
    for j in reversed(range(len(ks))):          # largest first: the small ones stay visible
        k = ks[j]
        o = getattr(orb, f"orbit_{k:03d}")
        ax.plot(o.state[:, 0], o.state[:, 1], color=colors[j], lw=3.0 - 2.0 * j / max(1, len(ks) - 1),
                label=f"dE = {orb.dE[k]:g}")
    ax.plot([res.saddle.x], [res.saddle.y], "k+", ms=10) if "saddle" in res else None
    ax.set_xlabel("x [cm]")
    ax.set_ylabel("y [cm]")
    ax.set_aspect("equal")
    ax.set_title(f"Lyapunov orbits of {orb.saddle} over their zero-velocity curves (dashed)")
    ax.legend(fontsize=7, loc="upper right")
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)


def plot_orbit_properties(res, path):
    """Period, action and mu_unstable against dE, with the dE -> 0 limits."""
    plt = _mpl()
    orb = res.orbits
    conv = np.asarray(orb.converged, dtype=bool)
    de = np.asarray(orb.dE)[conv]
    fig, axs = plt.subplots(1, 3, figsize=(12, 3.8))
    axs[0].plot(de, np.asarray(orb.period)[conv], "o-")
    axs[1].plot(de, np.asarray(orb.action)[conv], "o-", label="action")
    axs[2].semilogy(de, np.asarray(orb.mu_unstable)[conv], "o-")
    if "saddle" in res:
        t_po = res.saddle.T_po
        axs[0].axhline(t_po, color="gray", ls=":", label="T_po = 2 pi / omega")
        axs[1].plot(de, t_po * de, color="gray", ls=":", label="T_po dE (MacKay)")
        axs[2].semilogy(de, np.exp(res.saddle["lambda"] * np.asarray(orb.period)[conv]), color="gray", ls=":",
                        label="exp(lambda T)")
    if "family_end_dE" in orb.attrs:
        for ax in axs:
            ax.axvline(orb.family_end_dE, color="red", ls="--", lw=0.8, label="end of family")
    for ax, lab in zip(axs, ["period [s]", "action [cm^2/s]", "mu_unstable"]):
        ax.set_xlabel("dE [(cm/s)^2]")
        ax.set_ylabel(lab)
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m tubes.plots", description=__doc__.splitlines()[0])
    ap.add_argument("result", help="a tubes HDF5 output file")
    ap.add_argument("-o", "--outdir", default="figures", help="directory for the PNG files (default figures)")
    args = ap.parse_args(argv)
    res = load(args.result)
    out = pathlib.Path(args.outdir)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    if "orbits" in res:
        for name, fn in [("orbit_family.png", plot_orbit_family), ("orbit_properties.png", plot_orbit_properties)]:
            fn(res, out / name)
            written.append(out / name)
    for p in written:
        print(p)
    if not written:
        print("nothing to plot in", args.result)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
