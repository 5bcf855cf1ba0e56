"""Issue 39 ("trust"), the Python side: every file the Python tools write follows the C program's
rule (tubes._output: a regular file or none yet, written to FILE.tmp.<pid> and renamed, on failure
exit 3 with the system's reason and nothing left), no `python -m` tool ends in a traceback, the
track reader takes ASCII numbers only, and the lab options refuse what they cannot honour.

The full-disk cases mount a small tmpfs (root only; skipped, with the reason, where mount is
refused) and unmount it afterwards."""
import os
import stat
import subprocess

import numpy as np
import pytest

import tubes._output as out
import tubes.experiment as ex
from conftest import ROOT, run_tubes

PY = str(ROOT / ".venv" / "bin" / "python")


def _run(module, args, cwd, timeout=300):
    env = dict(os.environ, OMP_NUM_THREADS="1", PYTHONPATH=str(ROOT / "python"), MPLBACKEND="Agg")
    return subprocess.run([PY, "-m", module, *args], cwd=cwd, capture_output=True, text=True,
                          timeout=timeout, env=env)


def _no_traceback(r):
    assert "Traceback" not in r.stderr and "Exception ignored" not in r.stderr, r.stderr
    assert r.returncode not in (0, 139, -11), (r.returncode, r.stderr)


@pytest.fixture(scope="module")
def tracks_csv(tmp_path_factory):
    """Six microcanonical tracks of 4 s (the lab tests' canonical file): analysed in ~2 s."""
    d = tmp_path_factory.mktemp("trust")
    tr = ex.synthetic_tracks(6, duration=4.0, ensemble="microcanonical", dE_range=(100.0, 300.0),
                             seed=5, noise=0.05, pixel=0.16, rate=50.0)
    p = d / "canon.csv"
    ex.write_tracks_csv(str(p), tr)
    return p


@pytest.fixture(scope="module")
def results(tmp_path_factory, tubes_exe):
    """Two small tubes outputs: e.h5 (the equilibria: python -m tubes.plots draws surface.png) and
    s.h5 (6 synthetic tracks: python -m tubes.figures analyses them)."""
    d = tmp_path_factory.mktemp("results")
    (d / "e.nml").write_text("&run scenes = 'equilibria' /\n")
    (d / "s.nml").write_text("&run scenes = 'synthetic_experiment' /\n&experiment n_tracks = 6, duration = 4.0, "
                             "seed = 3 /\n")
    for n in ("e", "s"):
        r = run_tubes([f"{n}.nml", "-o", f"{n}.h5"], d)
        assert r.returncode == 0, r.stderr
    return d


@pytest.fixture
def full_disk(tmp_path):
    """A 16 KiB tmpfs: every output of the tools here is larger (the analysis ~35 KB, a figure
    60-80 KB)."""
    d = tmp_path / "full"
    d.mkdir()
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=16k", "tmpfs", str(d)], capture_output=True, text=True)
    if r.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs to fill (needs root): {r.stderr.strip()}")
    try:
        yield d
    finally:
        subprocess.run(["umount", str(d)], check=True)


# ------------------------------------------------------------------------------------------------
# 1. One writer rule
# ------------------------------------------------------------------------------------------------

def _fifo(path):
    os.mkfifo(path)
    return lambda: stat.S_ISFIFO(os.stat(path).st_mode)


def _device(path):
    """A character device node (the numbers of /dev/null) in the test's directory, or /dev/null
    itself where mknod is not permitted."""
    try:
        os.mknod(path, 0o666 | stat.S_IFCHR, os.makedev(1, 3))
    except (PermissionError, OSError):
        path = "/dev/null"
    st0 = os.stat(path)
    return path, lambda: stat.S_ISCHR(os.stat(path).st_mode) and os.stat(path).st_rdev == st0.st_rdev


@pytest.mark.parametrize("option", ["-o", "--figure", "--dissipation-figure"])
@pytest.mark.parametrize("kind", ["fifo", "device"])
def test_experiment_refuses_a_target_that_is_not_a_regular_file(tracks_csv, tmp_path, option, kind):
    target = str(tmp_path / "target")
    if kind == "fifo":
        still = _fifo(target)
    else:
        target, still = _device(target)
    r = _run("tubes.experiment", [str(tracks_csv), option, target], tmp_path)
    _no_traceback(r)
    assert r.returncode == 3
    assert option in r.stderr and ("a FIFO" if kind == "fifo" else "a device") in r.stderr
    assert "regular file" in r.stderr
    assert "camera rate" not in r.stdout      # refused before the work
    assert still()
    assert not [p for p in os.listdir(tmp_path) if ".tmp." in p]


def test_plots_and_figures_refuse_a_fifo_among_their_files(results, tmp_path):
    d = tmp_path / "figs"
    d.mkdir()
    still = _fifo(d / "surface.png")
    r = _run("tubes.plots", [str(results / "e.h5"), "-o", str(d)], tmp_path)
    _no_traceback(r)
    assert r.returncode == 3 and "a FIFO" in r.stderr and still()
    os.remove(d / "surface.png")
    still = _fifo(d / "experiment.png")
    r = _run("tubes.figures", [str(results / "s.h5"), "-o", str(d)], tmp_path)
    _no_traceback(r)
    assert r.returncode == 3 and "a FIFO" in r.stderr and still()
    assert "experiment (synthetic tracks)" not in r.stdout          # refused before the analysis
    assert sorted(os.listdir(d)) == ["experiment.png"]      # experiment.h5 not written either


def test_experiment_refuses_an_output_that_is_an_input(tracks_csv, tmp_path):
    p = tmp_path / "t.csv"
    p.write_bytes(tracks_csv.read_bytes())
    r = _run("tubes.experiment", [str(p), "-o", str(p)], tmp_path)
    _no_traceback(r)
    assert r.returncode == 1 and "input file" in r.stderr
    assert p.read_bytes() == tracks_csv.read_bytes()
    r = _run("tubes.experiment", [str(p), "-o", "a.png", "--figure", "a.png"], tmp_path)
    assert r.returncode == 1 and "same file" in r.stderr


def test_a_figure_format_matplotlib_cannot_write_is_refused_first(tracks_csv, tmp_path):
    r = _run("tubes.experiment", [str(tracks_csv), "--figure", "fig.xyz"], tmp_path)
    _no_traceback(r)
    assert r.returncode == 3 and ".xyz" in r.stderr and ".png" in r.stderr
    assert "camera rate" not in r.stdout and os.listdir(tmp_path) == []


@pytest.mark.parametrize("options", [["-o", "a.h5"], ["--figure", "a.png"], ["--dissipation-figure", "l.png"],
                                     ["-o", "a.h5", "--figure", "a.png"]])
def test_experiment_on_a_full_disk(tracks_csv, full_disk, options):
    """Before: -o gave HDF5 tracebacks, a RuntimeError traceback (exit 1) or a segfault at exit
    (139) with a.h5.tmp.PID left; --figure left nothing but a.h5 written beside a failed figure."""
    args = [str(tracks_csv)] + [v if v.startswith("-") else str(full_disk / v) for v in options]
    r = _run("tubes.experiment", args, full_disk.parent)
    _no_traceback(r)
    assert r.returncode == 3, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "No space left on device" in lines[0] and "no output file was left" in lines[0]
    assert os.listdir(full_disk) == []


def test_experiment_on_an_8k_disk_does_not_crash(tracks_csv, tmp_path):
    """8 KiB: where h5py writing in place failed while creating the datasets and the interpreter
    then died of SIGSEGV in HDF5's exit handler."""
    d = tmp_path / "tiny"
    d.mkdir()
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=8k", "tmpfs", str(d)], capture_output=True).returncode:
        pytest.skip("cannot mount a tmpfs (needs root)")
    try:
        r = _run("tubes.experiment", [str(tracks_csv), "-o", str(d / "a.h5")], tmp_path)
        _no_traceback(r)
        assert r.returncode == 3 and "No space left on device" in r.stderr
        assert os.listdir(d) == []
    finally:
        subprocess.run(["umount", str(d)], check=True)


def test_plots_and_figures_on_a_full_disk(results, full_disk):
    r = _run("tubes.plots", [str(results / "e.h5"), "-o", str(full_disk / "p")], full_disk.parent)
    _no_traceback(r)
    assert r.returncode == 3 and "No space left on device" in r.stderr
    assert os.listdir(full_disk / "p") == []
    r = _run("tubes.figures", [str(results / "s.h5"), "-o", str(full_disk)], full_disk.parent)
    _no_traceback(r)
    assert r.returncode == 3 and "No space left on device" in r.stderr
    assert sorted(os.listdir(full_disk)) == ["p"]


def test_the_writer_removes_its_temporary_file_on_any_exception(tmp_path):
    target = tmp_path / "x.bin"
    target.write_bytes(b"old")
    for exc in (KeyboardInterrupt, RuntimeError, OSError):
        with pytest.raises((exc, out.OutputError)):
            with out.atomic_path(target) as tmp:
                assert os.path.dirname(tmp) == str(tmp_path)
                with open(tmp, "wb") as f:
                    f.write(b"partial")
                raise exc("stop")
        assert sorted(os.listdir(tmp_path)) == ["x.bin"] and target.read_bytes() == b"old"
    with out.atomic_path(target) as tmp:
        with open(tmp, "wb") as f:
            f.write(b"new")
    assert sorted(os.listdir(tmp_path)) == ["x.bin"] and target.read_bytes() == b"new"


def test_the_writer_refuses_before_the_block_runs(tmp_path):
    _fifo(tmp_path / "f")
    ran = []
    with pytest.raises(out.OutputError, match="a FIFO"):
        with out.atomic_path(tmp_path / "f", "--x"):
            ran.append(1)
    assert ran == []
    with pytest.raises(out.OutputError, match="a directory"):
        out.check_target(tmp_path)
    with pytest.raises(out.OutputError, match="does not exist"):
        out.check_target(tmp_path / "no" / "x.h5")
    os.symlink(tmp_path / "nothing", tmp_path / "dangling")
    with pytest.raises(out.OutputError, match="symbolic link to nothing"):
        out.check_target(tmp_path / "dangling")


def test_a_symbolic_link_writes_the_file_it_names(tmp_path):
    (tmp_path / "real.bin").write_bytes(b"old")
    os.symlink("real.bin", tmp_path / "link.bin")
    out.write_bytes(tmp_path / "link.bin", b"new")
    assert os.path.islink(tmp_path / "link.bin") and (tmp_path / "real.bin").read_bytes() == b"new"


def test_a_batch_writes_all_or_none(tmp_path):
    _fifo(tmp_path / "b")
    with pytest.raises(out.OutputError):
        with out.batch():
            out.emit(tmp_path / "a", b"a")
            out.emit(tmp_path / "b", b"b")
    assert sorted(os.listdir(tmp_path)) == ["b"]
    with out.batch():
        out.emit(tmp_path / "a", b"a")
        out.emit(tmp_path / "c", b"c")
    assert (tmp_path / "a").read_bytes() == b"a" and (tmp_path / "c").read_bytes() == b"c"


def test_the_analysis_file_is_unchanged_in_content(tracks_csv, tmp_path):
    """The in-memory HDF5 image reads back as the analysis (the same bins and crossings)."""
    import h5py
    an = ex.analyse(ex.read_tracks(str(tracks_csv)))
    ex.write_analysis(str(tmp_path / "a.h5"), an)
    with h5py.File(tmp_path / "a.h5", "r") as f:
        for k, v in an.bins.items():
            np.testing.assert_array_equal(f["experiment"][k][()], np.asarray(v))
        for k, v in an.crossings.items():
            np.testing.assert_array_equal(f["experiment/crossings"][k][()], np.asarray(v))
    assert os.listdir(tmp_path) == ["a.h5"]


# ------------------------------------------------------------------------------------------------
# 2. No traceback: sizes bounded before allocating, a dataset of the wrong type named
# ------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("args,needles", [
    (["--bins", "0:1e9:1e-3"], ["--bins", "1e+12 bins", f"at most {ex.MAX_BINS}"]),
    (["--bins", "0:1e400:1"], ["--bins", "finite"]),
    (["--resamples", "100000000"], ["--resamples", f"0 to {ex.MAX_RESAMPLES}"]),
    (["--bootstrap", "1000000000"], ["--bootstrap", f"0 to {ex.MAX_BOOTSTRAP}"]),
    (["--resamples", "-1"], ["--resamples", "0 to"]),
])
def test_sizes_are_bounded_before_allocating(tracks_csv, tmp_path, args, needles):
    """Before: numpy's MemoryError (or an endless bootstrap) as a traceback."""
    r = _run("tubes.experiment", [str(tracks_csv), *args], tmp_path, timeout=60)
    _no_traceback(r)
    for n in needles:
        assert n in r.stderr, r.stderr


@pytest.mark.parametrize("column,data,needle", [
    ("t", np.array([b"0", b"0.02", b"0.04"]), "/tracks/t holds byte strings"),
    ("x", np.array(["a", "b", "c"], dtype=object), "/tracks/x holds strings"),
    ("track", np.array([1 + 1j, 2, 3]), "/tracks/track holds complex numbers"),
])
def test_a_tracks_dataset_of_another_type_is_named(tmp_path, column, data, needle):
    import h5py
    cols = {"track": np.zeros(3, int), "t": np.array([0.0, 0.02, 0.04]), "x": np.zeros(3), "y": np.zeros(3)}
    cols[column] = data
    with h5py.File(tmp_path / "bad.h5", "w") as f:
        g = f.create_group("tracks")
        for k, v in cols.items():
            g.create_dataset(k, data=v, dtype=h5py.string_dtype() if v.dtype == object else None)
    r = _run("tubes.experiment", [str(tmp_path / "bad.h5")], tmp_path)
    _no_traceback(r)
    assert r.returncode == 1 and needle in r.stderr and "must hold" in r.stderr, r.stderr


# ------------------------------------------------------------------------------------------------
# 3. Track numbers in ASCII only
# ------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("cell,column", [
    ("\u0660.02", "t"),          # Arabic-Indic zero
    ("\uff10.02", "t"),          # full-width zero
    ("0.0_2", "t"),              # an underscore
    ("\u0661", "track"),         # Arabic-Indic one as a track id
    ("1_0", "x"),
    ("0.02\u00a0", "t"),         # a no-break space after the number
])
def test_track_numbers_are_ascii_only(tracks_csv, tmp_path, cell, column):
    """float() and int() take these; before, they were read as numbers."""
    lines = tracks_csv.read_text().splitlines()
    fields = lines[2].split(",")
    k = ["track", "t", "x", "y"].index(column)
    fields[k] = cell
    lines[2] = ",".join(fields)
    p = tmp_path / "odd.csv"
    p.write_text("\n".join(lines) + "\n", encoding="utf-8")
    with pytest.raises(ex.ExperimentError) as e:
        ex.read_tracks(str(p))
    msg = str(e.value)
    assert f"odd.csv:3: column {column!r} (field {k + 1})" in msg and "ASCII digits" in msg, msg
    r = _run("tubes.experiment", [str(p)], tmp_path)
    _no_traceback(r)
    assert r.returncode == 1 and "odd.csv:3" in r.stderr


def test_ascii_numbers_of_every_form_are_still_read(tmp_path):
    p = tmp_path / "forms.csv"
    p.write_text("track,t,x,y\n0,0,1.5,-2\n0,.02,+1.5e0,-2.E0\n0,2e-2,nan,\n")
    tr = ex.read_tracks(str(p))
    np.testing.assert_array_equal(tr.t, [0.0, 0.02, 0.02])
    assert tr.x[0] == 1.5 and tr.y[1] == -2.0 and np.isnan(tr.x[2]) and np.isnan(tr.y[2])


@pytest.mark.parametrize("args", [["--rate", "\u0665\u0660"], ["--window", "1_5", "--estimator", "savgol"],
                                  ["--bins", "0,\uff14\uff10,80"], ["--origin", "1_0,0"]])
def test_option_numbers_are_ascii_only(tracks_csv, tmp_path, args):
    r = _run("tubes.experiment", [str(tracks_csv), *args], tmp_path)
    _no_traceback(r)
    assert r.returncode == 2 and args[0] in r.stderr, r.stderr


# ------------------------------------------------------------------------------------------------
# 4. Lab options
# ------------------------------------------------------------------------------------------------

def test_pixel_size_without_pixels_is_a_conflict(tracks_csv, tmp_path):
    """Before: --pixel-size silently ignored with --length-unit mm."""
    r = _run("tubes.experiment", [str(tracks_csv), "--length-unit", "mm", "--pixel-size", "0.1"], tmp_path)
    _no_traceback(r)
    assert r.returncode == 1 and "--pixel-size" in r.stderr and "--length-unit mm" in r.stderr, r.stderr
    with pytest.raises(ex.ExperimentError, match="--pixel-size"):
        ex.read_tracks(str(tracks_csv), length_unit="cm", pixel_size=0.16)


@pytest.mark.parametrize("value", ["nan", "inf", "-inf"])
def test_rotate_must_be_finite(tracks_csv, tmp_path, value):
    """Before: --rotate nan was taken, every sample dropped, the message silent on why."""
    r = _run("tubes.experiment", [str(tracks_csv), f"--rotate={value}"], tmp_path)
    _no_traceback(r)
    assert r.returncode == 2 and "--rotate" in r.stderr and "finite" in r.stderr, r.stderr
    with pytest.raises(ex.ExperimentError, match="finite"):
        ex.read_tracks(str(tracks_csv), calibration=ex.Calibration((0.0, 0.0), float(value), False))


@pytest.mark.parametrize("spec,twice", [("x=t", "'t'"), ("track=id,t=id", "'id'"), ("y=X", "'x'")])
def test_one_column_for_two_roles_is_named(tracks_csv, tmp_path, spec, twice):
    """Before: 'cannot infer the camera rate' (the times read from the x column, or the like)."""
    r = _run("tubes.experiment", [str(tracks_csv), "--columns", spec], tmp_path)
    _no_traceback(r)
    assert r.returncode == 1 and f"the column {twice} is named for two roles" in r.stderr, r.stderr


def _cal(tmp_path, header, points):
    p = tmp_path / "cal.csv"
    p.write_text((header + "\n" if header else "") + "".join(",".join(map(repr, q)) + "\n" for q in points))
    return str(p)


WELLS = [(6.5, 6.5, 6.5, 6.5), (-5.7, 5.7, -5.7, 5.7), (-6.5, -6.5, -6.5, -6.5), (5.7, -5.7, 5.7, -5.7)]


@pytest.mark.parametrize("header,needle", [
    ("x,y,sx,sy", "the header must be camera_x,camera_y,surface_x,surface_y"),
    ("surface_x,surface_y,camera_x,camera_y", "the header must be"),
    ("camera_x,camera_y,surface_x", "the header must be"),
    ("camera_x_mm,camera_y_mm,surface_x_cm,surface_y_cm", "give --length-unit mm"),
    ("camera_x,camera_y,surface_x_mm,surface_y_mm", "surface positions are in cm"),
])
def test_a_calibration_header_is_checked(tmp_path, header, needle):
    """Before: any first line that was not four numbers was skipped as a header."""
    with pytest.raises(ex.ExperimentError, match="cal.csv:1: ") as e:
        ex.read_calibration(_cal(tmp_path, header, WELLS))
    assert needle in str(e.value)


def test_calibration_headers_that_are_right_are_read(tmp_path):
    for h in ("camera_x,camera_y,surface_x,surface_y", "Camera_X_cm,camera_y_cm,surface_x_cm,surface_y_cm", None):
        cal = ex.read_calibration(_cal(tmp_path, h, WELLS))
        assert cal.residual < 1e-12 and cal.n_points == 4
    cal = ex.read_calibration(str(ROOT / "input" / "lab_calibration.csv"), length_unit="mm")
    assert cal.residual < 1e-5 and cal.flip_y


@pytest.mark.parametrize("points,rank", [
    ([(10.0, 10.0, 6.5, 6.5)] * 4, 0),                                        # 4 identical points
    ([(0.0, 0.0, 0.0, 0.0), (1.0, 1.0, 1.0, 1.0), (2.0, 2.0, 2.0, 2.0), (3.0, 3.0, 3.0, 3.0)], 1),
    ([(0.0, 0.0, 0.0, 0.0), (4.0, 0.0, 4.0, 0.0)], None),                    # two points: too few
])
def test_degenerate_calibration_points_are_refused(tmp_path, points, rank):
    """Before: 4 identical points gave a 'fit' (rotation 0, residual 0)."""
    with pytest.raises(ex.ExperimentError) as e:
        ex.read_calibration(_cal(tmp_path, "camera_x,camera_y,surface_x,surface_y", points))
    msg = str(e.value)
    if rank is None:
        assert "at least three" in msg, msg
    else:
        assert f"(rank {rank} of 2, {len(points)} points)" in msg, msg
    r = _run("tubes.experiment", [str(ROOT / "input" / "lab_tracks.csv"), "--calibration", str(tmp_path / "cal.csv")],
             tmp_path)
    _no_traceback(r)
    assert r.returncode == 1 and "calibration" in r.stderr


def test_a_position_noise_larger_than_the_plate_is_refused(tracks_csv, tmp_path):
    """Before: --noise 1e300 ended in an OverflowError traceback."""
    r = _run("tubes.experiment", [str(tracks_csv), "--noise", "1e300"], tmp_path)
    _no_traceback(r)
    assert r.returncode == 1 and "--noise" in r.stderr and "--plate" in r.stderr, r.stderr


@pytest.mark.parametrize("sig,status", [("INT", 130), ("TERM", 143)])
def test_a_signal_during_the_run_leaves_no_file(tracks_csv, tmp_path, sig, status):
    """SIGINT or SIGTERM while the analysis runs: one message, 128 + the signal, no file, no
    FILE.tmp.<pid> (SIGTERM used to end the process where it was)."""
    import signal
    import time
    env = dict(os.environ, OMP_NUM_THREADS="1", PYTHONPATH=str(ROOT / "python"), MPLBACKEND="Agg")
    p = subprocess.Popen([PY, "-m", "tubes.experiment", str(tracks_csv), "-o", "a.h5", "--figure", "a.png",
                          "--bootstrap", "100000"], cwd=tmp_path, env=env, stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True)
    time.sleep(2.5)          # imports and reading done (~1 s), the analysis under way
    p.send_signal(getattr(signal, f"SIG{sig}"))
    _, err = p.communicate(timeout=60)
    assert p.returncode == status, err
    assert "Traceback" not in err and "interrupted" in err
    assert os.listdir(tmp_path) == []


def test_output_errors_are_still_oserrors(tmp_path):
    """Library callers of write_analysis that caught OSError before still catch the refusal."""
    _fifo(tmp_path / "f")
    with pytest.raises(OSError, match="a FIFO"):
        ex.write_tracks_csv(str(tmp_path / "f"), ex.Tracks(np.zeros(1, int), np.zeros(1), np.zeros(1),
                                                            np.zeros(1), {}, None, ""))
