"""python -m tubes.plots and python -m tubes.figures on every input/*.nml (copies with their sample
counts shrunk: every group the scenes write is there) and on every built-in 2-DOF model with a
plane section (henon_heiles, de_leon_berne, coupled_quartic, the CR3BP, and a formula double well
with its own coordinate names u, v, pu, pv), issue 37 items 1-2. Checked: both exit 0 and write the
figures the file has data for (before: KeyError 'angle' on every plane-section file); the texts
of every figure the CLI draws (its Axes, caught before they are written) carry the model's units
(cm and s for the ball, no cm and no "[1]" for a dimensionless model) and the section's own
coordinate names; the leading-order p_trans is drawn only where it is valid and does not set the
axis limits; and the plotting API draws the results of the Python calls (not a file). The figures
are drawn once per case, by tubes.figures' main in this process (before: in the process to read
their texts, then again by a `python -m tubes.figures` subprocess per case; now one case's
subprocess checks the module's entry point)."""
import os
import pathlib
import re
import subprocess
import sys

import numpy as np
import pytest

from conftest import ROOT, run_tubes

PY = str(ROOT / ".venv" / "bin" / "python") if (ROOT / ".venv" / "bin" / "python").exists() else sys.executable

# the inputs' sample counts shrunk (every scene kept): (pattern, replacement)
SHRINK = [(r"n_samples = 10000", "n_samples = 500"), (r"n_samples = 4000", "n_samples = 1000"),
          (r"n_samples = 20000", "n_samples = 4000"), (r"n_cut = 16", "n_cut = 8"),
          (r"n_seeds = 40, n_iter = 300", "n_seeds = 4, n_iter = 30"), (r"n_tracks = 600", "n_tracks = 60"),
          (r"output = '[^']*'", "")]

SCENES = "&run scenes = 'equilibria', 'orbits', 'tubes', 'transition', 'montecarlo', 'sections' /\n"
BUILTIN = {   # built-in 2-DOF models with their default plane section (docs/models.md), and a formula
    "henon_heiles": "&model system = 'henon_heiles' /\n" + SCENES
    + "&orbits de = 0.001, 0.01 /\n&tubes de = 0.01 /\n&transition de = 0.001, 0.005, 0.01, 0.02 /\n"
      "&montecarlo de = 0.02, n_samples = 500 /\n&sections de = 0.01, n_seeds = 5, n_iter = 30 /\n",
    "de_leon_berne": "&model system = 'de_leon_berne' /\n" + SCENES
    + "&orbits de = 0.01, 0.05 /\n&tubes de = 0.05 /\n&transition de = 0.01, 0.02, 0.05, 0.1 /\n"
      "&montecarlo de = 0.05, n_samples = 500 /\n&sections de = 0.05, n_seeds = 5, n_iter = 30 /\n",
    "coupled_quartic": "&model system = 'coupled_quartic' /\n" + SCENES
    + "&orbits de = 0.01, 0.05 /\n&tubes de = 0.05 /\n&transition de = 0.01, 0.02, 0.05, 0.1 /\n"
      "&montecarlo de = 0.05, n_samples = 500 /\n&sections de = 0.05, n_seeds = 5, n_iter = 30 /\n",
    # the double well u^4/4 - u^2/2 coupled to a bath mode v, on the plane u = -0.5 (s = v, p_s = pv);
    # transition up to dE = 1, where the leading order has long turned negative
    "double_well": "&model system = 'expression', hamiltonian = '(pu^2 + pv^2)/2 + u^4/4 - u^2/2 + v^2/2 "
                   "+ 0.1*u*v', coordinates = 'u', 'v', momenta = 'pu', 'pv' /\n" + SCENES
    + "&orbits de = 0.01, 0.05 /\n&section kind = 'plane', index = 1, value = -0.5, direction = 1 /\n"
      "&tubes de = 0.1 /\n&transition de = 0.01, 0.05, 0.1, 0.5, 1.0 /\n"
      "&montecarlo de = 0.1, n_samples = 500 /\n&sections de = 0.1, n_seeds = 5, n_iter = 30 /\n",
    # gyroscopic: no potential, so no surface.png; a plane x = 0.7 on the Earth's side of L1
    "cr3bp": "&model system = 'cr3bp' /\n&run scenes = 'equilibria', 'orbits', 'tubes', 'transition', "
             "'montecarlo' /\n&orbits de = 0.0001, 0.0005 /\n"
             "&section kind = 'plane', index = 1, value = 0.7, direction = 1 /\n&tubes de = 0.0005 /\n"
             "&transition de = 0.0001, 0.0005 /\n&montecarlo de = 0.0005, n_samples = 300 /\n",
}
INPUTS = sorted(p.stem for p in (ROOT / "input").glob("*.nml"))
CASES = [f"input/{n}" for n in INPUTS] + sorted(BUILTIN)

# what each case must show: ball (units cm, s), the section's coordinate names, the figures
SECTION_NAMES = {"input/paper": ("r", "p_r"), "input/damped": ("r", "p_r"), "input/expression": ("y", "py"),
                 "henon_heiles": ("x", "px"), "de_leon_berne": ("x", "px"), "coupled_quartic": ("y", "py"),
                 "double_well": ("v", "pv"), "cr3bp": ("y", "py")}
BALL = {"input/paper", "input/damped"}


def _texts(fig) -> list:
    """Every text of a figure: its Axes' labels, titles and legend entries, and its suptitle."""
    out = [fig._suptitle.get_text()] if fig._suptitle is not None else []
    for ax in fig.axes:
        out += [ax.get_xlabel(), ax.get_ylabel(), ax.get_title()]
        if hasattr(ax, "get_zlabel"):
            out.append(ax.get_zlabel())
        if ax.get_legend() is not None:
            out += [t.get_text() for t in ax.get_legend().get_texts()]
    return [t for t in out if t]


def _labels(fig) -> list:
    return [(ax.get_xlabel(), ax.get_ylabel()) for ax in fig.axes]


@pytest.fixture(scope="module")
def results(tmp_path_factory, tubes_exe):
    """Every case run once: name -> the output file."""
    d = tmp_path_factory.mktemp("every_model")
    out = {}
    for case in CASES:
        stem = case.replace("/", "_")
        if case.startswith("input/"):
            text = (ROOT / f"{case}.nml").read_text()
            for pat, rep in SHRINK:
                text = re.sub(pat, rep, text)
        else:
            text = BUILTIN[case]
        (d / f"{stem}.nml").write_text(text)
        r = run_tubes([f"{stem}.nml", "-o", f"{stem}.h5"], d, timeout=300)
        assert r.returncode == 0, (case, r.stderr[-2000:])
        out[case] = d / f"{stem}.h5"
    return out


@pytest.fixture(scope="module")
def drawn(results):
    """What python -m tubes.figures does on every case, run in this process (figures.main; one
    case also as `python -m`, test_the_module_entry_point): its exit code, its listing on stdout,
    the figures it wrote, and their texts, caught as they are written: case -> dict(rc, stdout,
    figs={file name: (texts, (xlabel, ylabel) per Axes)})."""
    import contextlib
    import io
    import matplotlib.pyplot as plt
    from tubes import _output, figures
    caught = {}
    real = _output.save_figure

    def catch(fig, path, option=None, **kw):
        caught[os.path.basename(str(path))] = (_texts(fig), _labels(fig))
        return real(fig, path, option, **kw)
    out = {}
    _output.save_figure = catch
    try:
        for case, h5 in results.items():
            caught = {}
            buf = io.StringIO()
            with contextlib.redirect_stdout(buf):
                rc = figures.main([str(h5), "-o", str(h5.parent / (h5.stem + "_figs"))])
            out[case] = dict(rc=rc, stdout=buf.getvalue(), figs=caught)
            plt.close("all")
    finally:
        _output.save_figure = real
    return out


def _expected(case, h5) -> set:
    import h5py
    with h5py.File(h5) as f:
        groups = set(f)
        ndof = int(f["model"].attrs["ndof"])
    want = set()
    if ndof == 2 and case != "cr3bp" and groups & {"equilibria", "section"}:
        want.add("surface.png")                          # any 2-DOF natural model
    if "orbits" in groups:
        want |= {"orbit_family.png", "orbit_properties.png"}
    if ndof == 2:
        want |= {name for g, name in (("transition", "p_trans.png"), ("montecarlo", "montecarlo.png"),
                                      ("tubes", "tube_trajectories.png")) if g in groups}
    if "sections" in groups:
        want.add("section_dE*")
    if "flux" in groups:
        want.add("tube_cut_3dof.png")
    return want


def _names(listing: str) -> set:
    names = {os.path.basename(line.strip()) for line in listing.splitlines() if line.strip().endswith(".png")}
    return {"section_dE*" if n.startswith("section_dE") else n for n in names}


def _run_cli(tool, h5, cwd):
    env = dict(os.environ, PYTHONPATH=str(ROOT / "python"), OMP_NUM_THREADS="1", MPLBACKEND="Agg")
    return subprocess.run([PY, "-m", tool, str(h5), "-o", "figs"], cwd=cwd, capture_output=True, text=True,
                          timeout=300, env=env)


@pytest.mark.parametrize("case", CASES)
def test_the_cli_draws_every_figure(results, drawn, case):
    """python -m tubes.figures (python -m tubes.plots' figures, and the experiment's; its main, in
    this process: the fixture drawn) exits 0 on the case's file and lists and writes every figure
    it has data for."""
    h5, d = results[case], drawn[case]
    want = _expected(case, h5) | ({"experiment.png"} if case == "input/paper" else set())
    assert d["rc"] == 0, case
    assert {"section_dE*" if n.startswith("section_dE") else n for n in d["figs"]} == want, case
    assert _names(d["stdout"]) == want, (case, d["stdout"])
    for line in d["stdout"].splitlines():
        if line.endswith(".png"):
            assert pathlib.Path(line).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", line


def test_the_module_entry_point(results, drawn, tmp_path):
    """`python -m tubes.figures` as a user runs it (a new interpreter: the module's entry point) on
    one case lists the same figures as its main did in this process."""
    r = _run_cli("tubes.figures", results["henon_heiles"], tmp_path)
    assert r.returncode == 0, r.stderr[-3000:]
    assert _names(r.stdout) == _names(drawn["henon_heiles"]["stdout"]) == _expected("henon_heiles",
                                                                                     results["henon_heiles"])
    for line in r.stdout.splitlines():
        if line.endswith(".png"):
            assert (tmp_path / line).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", line


@pytest.mark.parametrize("case", ["double_well", "input/expression"])
def test_python_m_tubes_plots_on_a_plane_section(results, case, tmp_path):
    """The issue's report: python -m tubes.plots on input/expression.nml's output (a plane section)
    ended in KeyError 'angle'; it now exits 0 and writes every figure."""
    r = _run_cli("tubes.plots", results[case], tmp_path)
    assert r.returncode == 0, r.stderr[-3000:]
    assert _names(r.stdout) == _expected(case, results[case]), r.stdout


@pytest.mark.parametrize("case", CASES)
def test_labels_carry_the_models_units_and_the_sections_names(drawn, case):
    figs = drawn[case]["figs"]
    assert figs, case
    every = [t for texts, _ in figs.values() for t in texts]
    if case in BALL:
        assert "dE [(cm/s)^2]" in [x for x, _ in figs["p_trans.png"][1]]
        assert ("x [cm]", "y [cm]") in figs["surface.png"][1]
        assert ("x [cm]", "y [cm]") in figs["tube_trajectories.png"][1]
        if "orbit_properties.png" in figs:
            assert [y for _, y in figs["orbit_properties.png"][1]] == ["period [s]", "action [cm^2/s]", "mu_unstable"]
    else:      # dimensionless: no ball units, no "[1]"
        assert not [t for t in every if "cm" in t or "[1]" in t or "(cm/s)" in t], every
        assert "dE" in [x for x, _ in figs.get("p_trans.png", ([], [("dE", "")]))[1]]
        if "orbit_properties.png" in figs:
            assert [y for _, y in figs["orbit_properties.png"][1]] == ["period", "action", "mu_unstable"]
    if case in SECTION_NAMES:
        s, p_s = SECTION_NAMES[case]
        sec = s + (" [cm]" if case in BALL else ""), p_s + (" [cm/s]" if case in BALL else "")
        assert figs["montecarlo.png"][1] == [sec], figs["montecarlo.png"]
        for name in figs:
            if name.startswith("section_dE"):
                assert figs[name][1] == [sec], (name, figs[name])
                title = [t for t in figs[name][0] if t.startswith("Poincare")][0]
                assert ("U1^-" in title) == (case in BALL), title
                assert ("(cm/s)^2" in title) == (case in BALL), title
    if case == "double_well":          # the formula's own coordinate names
        assert ("u", "v") in figs["surface.png"][1] and ("u", "v") in figs["tube_trajectories.png"][1]
        assert "v_v" in [t for texts, _ in [figs["tube_trajectories.png"]] for t in texts]
    if case == "input/three_dof":      # the 3-DOF cut keeps its figure, in the model's names
        assert ("q2", "p2") in figs["tube_cut_3dof.png"][1] and ("q3", "p3") in figs["tube_cut_3dof.png"][1]


def test_the_leading_order_is_drawn_only_where_valid(results):
    """The double well's /transition reaches dE = 1, where (T_po/A0) dE (1 - tau dE/A0) is far below
    0 (the file holds it): the dashed curve keeps the points in [0, 1] before the formula's maximum
    A0/(2 tau), and the axis stays on the real curve (before: drawn everywhere, the y axis down to
    the formula's minimum)."""
    import h5py
    import matplotlib.pyplot as plt
    from tubes import load, plots
    with h5py.File(results["double_well"]) as f:
        de, lead = f["transition/dE"][()], f["transition/p_trans_leading"][()]
        a0, tau = f["section"].attrs["A0"], f["section"].attrs["tau"]
    assert lead.min() < -0.5                               # the check has something to leave out
    ax = plots.p_trans(load(str(results["double_well"])))
    dashed = [ln for ln in ax.get_lines() if ln.get_linestyle() == "--"]
    assert len(dashed) == 1
    y, x = dashed[0].get_ydata(), dashed[0].get_xdata()
    assert np.all((y >= 0) & (y <= 1)) and np.all(x <= a0 / (2 * tau))
    assert x.size == np.sum((lead >= 0) & (lead <= 1) & (de <= a0 / (2 * tau))) >= 1
    assert ax.get_ylim()[0] > -0.1                         # the real curve's range, not the formula's
    plt.close("all")


def test_plots_from_python_results():
    """The API on the results of the Python calls (no file): Henon-Heiles' transition Table and
    Monte Carlo dict, and its surface from the Model; each returns the Axes it drew on, on an
    Axes given or on a new figure, labelled in the section's names (the plane y = 0: s = x)."""
    import matplotlib.pyplot as plt
    import tubes
    from tubes import plots
    m = tubes.Model("henon_heiles")
    t = m.transition(dE=[0.001, 0.005, 0.01])
    mc = m.monte_carlo(dE=0.01, n_samples=300)
    fig, axs = plt.subplots(1, 3)
    ax = plots.p_trans(t, ax=axs[0], montecarlo=mc)
    assert ax is axs[0]
    assert np.array_equal(ax.get_lines()[0].get_ydata(), t["p_trans"])
    assert ax.get_xlabel() == "dE"
    assert any(f"Monte Carlo ({mc['n_samples']} points" in x.get_text() for x in ax.get_legend().get_texts())
    ax = plots.monte_carlo(mc, ax=axs[1], model=m)
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("x", "px")
    n = sum(len(ln.get_xdata()) for ln in ax.get_lines())
    assert n == mc["n_samples"]                            # every point drawn, by its outcome
    ax = plots.surface(m, ax=axs[2])
    from matplotlib.text import Annotation
    assert sorted(a.get_text() for a in ax.texts if isinstance(a, Annotation)) == ["S1", "S2", "S3", "W1"]
    new = plots.p_trans(t)                                 # no ax: a new figure's
    assert new.figure is not fig and new.get_xlabel() == "dE"
    ball = plots.p_trans(tubes.Table(dE=np.array([1.0, 2.0]), p_trans=np.array([0.1, 0.2])), model=tubes.Model())
    assert ball.get_xlabel() == "dE [(cm/s)^2]"
    plt.close("all")
