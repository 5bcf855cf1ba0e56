"""Tracks written the way lab software writes them (issue 17, "getting data in"): times in ms,
positions in mm, m or pixels, other column names, ';' or tab separators, rows ordered by frame.
With the right options the reader returns the canonical file's samples (to round-off) and the
analysis prints the canonical numbers; without them the run refuses and names the option."""
import math
import os
import re
import subprocess

import numpy as np
import pytest

import tubes.experiment as ex
from conftest import ROOT

PY = str(ROOT / ".venv" / "bin" / "python")


def _run(args, cwd):
    env = dict(os.environ, OMP_NUM_THREADS="1", PYTHONPATH=str(ROOT / "python"))
    return subprocess.run([PY, "-m", "tubes.experiment", *args], cwd=cwd, capture_output=True,
                          text=True, timeout=300, env=env)


@pytest.fixture(scope="module")
def canon(tmp_path_factory):
    d = tmp_path_factory.mktemp("lab")
    tr = ex.synthetic_tracks(6, duration=4.0, ensemble="microcanonical", dE_range=(100.0, 300.0),
                             seed=5, noise=0.05, pixel=0.16, rate=50.0)
    rows = list(zip(tr.track.tolist(), tr.t.tolist(), tr.x.tolist(), tr.y.tolist()))
    with open(d / "canon.csv", "w") as f:
        f.write("track,t,x,y\n")
        f.writelines(f"{k},{t!r},{x!r},{y!r}\n" for k, t, x, y in rows)
    return d, rows


def _lab(path, rows, tscale=1.0, lscale=1.0, sep=",", header=("track", "t", "x", "y"),
         by_frame=False, frame=False):
    """Write rows as a tracker would: times x tscale, lengths x lscale, named columns, a frame
    column first, rows ordered by frame (time) instead of by track."""
    out = sorted(rows, key=lambda r: (r[1], r[0])) if by_frame else rows
    with open(path, "w") as f:
        f.write(sep.join((["frame"] if frame else []) + list(header)) + "\n")
        for k, t, x, y in out:
            cells = [str(int(round(t * 50)))] if frame else []
            cells += [str(k), repr(t * tscale), repr(x * lscale), repr(y * lscale)]
            f.write(sep.join(cells) + "\n")


def _same(tr, rows):
    k, t, x, y = (np.array(c) for c in zip(*rows))
    assert np.array_equal(tr.track, k)
    np.testing.assert_allclose(tr.t, t, rtol=1e-15, atol=1e-15)
    np.testing.assert_allclose(tr.x, x, rtol=1e-15, atol=1e-14)
    np.testing.assert_allclose(tr.y, y, rtol=1e-15, atol=1e-14)


CASES = [  # (name, writer kwargs, reader kwargs)
    ("ms", dict(tscale=1e3), dict(time_unit="ms")),
    ("us", dict(tscale=1e6), dict(time_unit="us")),
    ("mm", dict(lscale=10.0), dict(length_unit="mm")),
    ("m", dict(lscale=0.01), dict(length_unit="m")),
    ("px", dict(lscale=1 / 0.16), dict(length_unit="px", pixel_size=0.16)),
    ("semicolon", dict(sep=";"), {}),
    ("tab", dict(sep="\t"), {}),
    ("by frame", dict(by_frame=True), {}),
    ("lab header", dict(header=("track_id", "time_s", "x_cm", "y_cm"), frame=True),
     dict(columns={"track": "track_id", "t": "time_s", "x": "x_cm", "y": "y_cm"})),
    ("all at once", dict(tscale=1e3, lscale=10.0, sep=";", by_frame=True, frame=True,
                         header=("id", "ms", "xmm", "ymm")),
     dict(time_unit="ms", length_unit="mm", columns={"track": "id", "t": "ms", "x": "xmm", "y": "ymm"})),
]


@pytest.mark.parametrize("name,wk,rk", CASES, ids=[c[0] for c in CASES])
def test_the_reader_returns_the_canonical_samples(canon, tmp_path, name, wk, rk):
    d, rows = canon
    _lab(tmp_path / "lab.csv", rows, **wk)
    _same(ex.read_tracks(str(tmp_path / "lab.csv"), **rk), rows)


def _numbers(out):
    """The analysis' result lines, without the camera-rate line that names the units."""
    return [ln for ln in out.splitlines() if not ln.startswith("camera rate")]


def test_the_analysis_of_a_lab_file_with_its_options_is_the_canonical_one(canon, tmp_path):
    d, rows = canon
    ref = _run([str(d / "canon.csv")], tmp_path)
    assert ref.returncode == 0, ref.stderr
    assert "camera rate 50 Hz (from the file)" in ref.stdout
    _lab(tmp_path / "lab.csv", rows, **CASES[-1][1])
    r = _run(["lab.csv", "--time-unit", "ms", "--length-unit", "mm", "--columns",
              "track=id,t=ms,x=xmm,y=ymm"], tmp_path)
    assert r.returncode == 0, r.stderr
    assert "camera rate 50 Hz (from the file); times in ms, lengths in mm" in r.stdout
    num = re.compile(r"[-+]?\d+\.\d+(?:e[-+]?\d+)?")
    a, b = _numbers(ref.stdout), _numbers(r.stdout)
    assert len(a) == len(b)
    for la, lb in zip(a, b):       # the same numbers to round-off (unit conversion of the inputs)
        xa, xb = [float(v) for v in num.findall(la)], [float(v) for v in num.findall(lb)]
        assert len(xa) == len(xb) and num.sub("#", la) == num.sub("#", lb), (la, lb)
        np.testing.assert_allclose(xb, xa, rtol=1e-6, atol=1e-9)


REFUSALS = [  # (name, writer kwargs, extra args, substrings of the message)
    ("ms read as s", dict(tscale=1e3), [], ["camera rate 0.05 Hz", "--time-unit ms"]),
    ("metres read as cm", dict(lscale=0.01), [], ["within", "of the plate's centre", "--length-unit m"]),
    ("mm read as cm", dict(lscale=10.0), [], ["off the plate", "--length-unit"]),
    ("origin at the corner", dict(), ["--columns", "x=xs"], []),
    ("lab header without --columns", dict(header=("track_id", "time_s", "x_cm", "y_cm")), [],
     ["missing track, t, x, y", "--columns"]),
    ("px without a size", dict(), ["--length-unit", "px"], ["--pixel-size"]),
]


@pytest.mark.parametrize("name,wk,extra,needles", REFUSALS, ids=[c[0] for c in REFUSALS])
def test_without_the_options_the_run_refuses_and_names_the_cause(canon, tmp_path, name, wk, extra, needles):
    d, rows = canon
    if name == "origin at the corner":          # x, y measured from the plate's corner
        with open(tmp_path / "lab.csv", "w") as f:
            f.write("track,t,x,y,xs\n")
            f.writelines(f"{k},{t!r},{x + 15.0!r},{y + 15.0!r},0\n" for k, t, x, y in rows)
        extra, needles = [], ["off the plate", "origin"]
    else:
        _lab(tmp_path / "lab.csv", rows, **wk)
    r = _run(["lab.csv", "-o", "an.h5", *extra], tmp_path)
    assert r.returncode == 1, (r.returncode, r.stdout, r.stderr)
    for n in needles:
        assert n in r.stderr, (n, r.stderr)
    assert not (tmp_path / "an.h5").exists()


# ------------------------------------------------ fits, pipes, warnings, the theory's model

@pytest.fixture(scope="module")
def flat(tmp_path_factory):
    """40 conservative tracks at dE in (0, 300) (transitions in the fit range), a theory file, and
    the same tracks with 1 % of the x samples NaN."""
    d = tmp_path_factory.mktemp("fits")
    tr = ex.synthetic_tracks(24, ensemble="microcanonical", dE_range=(0.0, 300.0), seed=21, noise=0.05,
                             pixel=0.16, rate=50.0)
    ex.write_tracks_h5(str(d / "cons.h5"), tr)
    k = np.random.default_rng(3).choice(tr.x.size, tr.x.size // 100, replace=False)
    tr.x[k] = np.nan
    ex.write_tracks_csv(str(d / "nan.csv"), tr)
    (d / "t.nml").write_text("&run scenes = 'tubes', 'transition' /\n"
                             "&tubes de = 40, 80, 120, 160, 200, 300, area_tol = 1e-6 /\n"
                             "&transition de = 5, 20, 40, 80, 120, 160, 200, 300, area_tol = 1e-6 /\n")
    r = subprocess.run([str(ROOT / "tubes"), "t.nml", "-o", "theory.h5"], cwd=d, capture_output=True, text=True,
                       timeout=300)
    assert r.returncode == 0, r.stderr
    return d


def test_fits_never_crash(flat, tmp_path):
    """Any bins: one bin in the fit range gives the slope through the origin and a note (no free
    line: it was numpy's LinAlgError), none gives no slope; the CLI prints the note and writes
    its outputs."""
    tr = ex.read_tracks(str(flat / "cons.h5"))
    th = ex.load_theory(str(flat / "theory.h5"))
    for bins, fits in (((0.0, 160.0), 1), ((-40.0, 0.0, 160.0), 1), ((-40.0, 0.0), 0), ((150.0, 200.0, 400.0), 0),
                       (tuple(np.arange(-40.0, 401.0, 80.0)), 1), ((0.0, 80.0, 160.0), 2)):
        a = ex.analyse(tr, th, ex.Options(bins=bins, bootstrap=20, resamples=0, compare=False)).attrs
        assert a["n_bins_fit"] == fits, (bins, a["n_bins_fit"])
        assert math.isfinite(a["slope"]) == (fits > 0), bins
        assert ("fit_note" in a) == (fits == 1), bins
    r = _run([str(flat / "cons.h5"), "--theory", str(flat / "theory.h5"), "--bins", "0:160:160", "--bootstrap", "20",
              "--resamples", "0", "-o", str(tmp_path / "an.h5"), "--figure", str(tmp_path / "f.png")], tmp_path)
    assert r.returncode == 0 and "Traceback" not in r.stderr, r.stderr
    assert "a free line needs two" in r.stdout
    assert (tmp_path / "an.h5").exists() and (tmp_path / "f.png").exists()


def test_a_broken_pipe_ends_quietly_with_the_outputs_written(flat, tmp_path):
    env = dict(os.environ, OMP_NUM_THREADS="1", PYTHONPATH=str(ROOT / "python"))
    cmd = (f"{PY} -m tubes.experiment {flat / 'cons.h5'} --theory {flat / 'theory.h5'} --bootstrap 20 "
           f"--resamples 0 -o an.h5 --figure f.png | head -1")
    r = subprocess.run(["bash", "-o", "pipefail", "-c", cmd], cwd=tmp_path, capture_output=True, text=True,
                       timeout=300, env=env)
    assert r.returncode == 0, r.stderr
    assert "Traceback" not in r.stderr and "BrokenPipe" not in r.stderr, r.stderr
    assert r.stdout.startswith("camera rate")
    assert (tmp_path / "an.h5").exists() and (tmp_path / "f.png").exists()


def test_issues_are_summarised(flat, tmp_path):
    """1 % NaN samples: a count per kind and the first three on stderr, not one line per sample;
    --all-issues prints every one."""
    args = [str(flat / "nan.csv"), "--theory", str(flat / "theory.h5"), "--bootstrap", "20", "--resamples", "0"]
    r = _run(args, tmp_path)
    assert r.returncode == 0, r.stderr
    lines = r.stderr.splitlines()
    assert len(lines) <= 12, r.stderr
    assert re.search(r"warning: \d+ issue\(s\) of kind nan \(\d+ samples\); the first 3:", r.stderr)
    r = _run(args + ["--all-issues"], tmp_path)
    assert len(r.stderr.splitlines()) > 50


def test_a_theory_for_another_surface_is_refused(flat, tmp_path):
    """Tracks made by tubes record their /model; a theory computed for another surface (here
    alpha = 0.075 against 0.07) is refused, naming the parameter."""
    (tmp_path / "t2.nml").write_text("&run scenes = 'tubes', 'transition' /\n&model alpha = 0.075 /\n"
                                     "&tubes de = 40, 80, area_tol = 1e-6 /\n&transition de = 5, 40, 80, area_tol = 1e-6 /\n")
    r = subprocess.run([str(ROOT / "tubes"), "t2.nml", "-o", "theory2.h5"], cwd=tmp_path, capture_output=True,
                       text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    (tmp_path / "s.nml").write_text("&run scenes = 'synthetic_experiment' /\n&experiment n_tracks = 4, duration = 3.0 /\n")
    r = subprocess.run([str(ROOT / "tubes"), "s.nml", "-o", "tracks.h5"], cwd=tmp_path, capture_output=True,
                       text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    r = _run(["tracks.h5", "--theory", "theory2.h5"], tmp_path)
    assert r.returncode == 1, r.stdout + r.stderr
    assert "alpha = 0.075 (theory) against 0.07 (tracks)" in r.stderr


@pytest.mark.parametrize("zeta", [0.01, 0.03])
def test_damping_measured_from_the_tracks(zeta):
    """Synthetic tracks of a known damping ratio: the energy's decay gives it back inside its
    95 % interval (the interval a few 1e-4 wide), and an undamped set gives 0 inside its own."""
    for z in (zeta, 0.0):
        tr = ex.synthetic_tracks(16, duration=8.0, damping_ratio=z, seed=11, noise=0.05, pixel=0.16, rate=50.0)
        a = ex.analyse(tr, None, ex.Options(bootstrap=200, resamples=0, compare=False)).attrs
        assert abs(a["damping_ratio"] - z) <= 1.96 * a["damping_ratio_err"], (z, a["damping_ratio"],
                                                                              a["damping_ratio_err"])
        assert a["damping_ratio_err"] < 3e-4
        assert abs(a["damping_rate"] / a["damping_ratio"] - a["damping_rate_err"] / a["damping_ratio_err"]) < 1e-9 \
            if z else True


def _camera(rows, origin, angle, flip):
    """Canonical rows (surface cm) into a camera frame: the inverse of ex.Calibration."""
    a = math.radians(angle)
    out = []
    for k, t, x, y in rows:
        u = math.cos(a) * x + math.sin(a) * y
        v = -math.sin(a) * x + math.cos(a) * y
        out.append((k, t, u + origin[0], (-v if flip else v) + origin[1]))
    return out


def test_calibration_by_options_and_by_known_points(canon, tmp_path):
    """A camera frame turned by 7 degrees, y down, origin at (15, 15) cm: --origin/--rotate/--flip-y
    and a calibration fitted to four known points both give the canonical samples back; the fit
    reports its residual; a mistyped point is refused naming the residual."""
    d, rows = canon
    cam = _camera(rows, (15.0, 15.0), 7.0, True)
    _lab(tmp_path / "cam.csv", cam)
    cal = ex.Calibration((15.0, 15.0), 7.0, True)
    _same(ex.read_tracks(str(tmp_path / "cam.csv"), calibration=cal), rows)
    known = [(6.5, 6.5), (-5.7, 5.7), (-6.5, -6.5), (5.7, -5.7)]
    pts = _camera([(0, 0.0, x, y) for x, y in known], (15.0, 15.0), 7.0, True)
    with open(tmp_path / "cal.csv", "w") as f:
        f.write("camera_x,camera_y,surface_x,surface_y\n")
        f.writelines(f"{p[2]!r},{p[3]!r},{x!r},{y!r}\n" for p, (x, y) in zip(pts, known))
    fit = ex.read_calibration(str(tmp_path / "cal.csv"))
    assert fit.flip_y and abs(fit.angle - 7.0) < 1e-9 and np.allclose(fit.origin, (15.0, 15.0), atol=1e-9)
    assert fit.residual < 1e-9 and fit.n_points == 4
    cp, sp = np.array([p[2:4] for p in pts]), np.array(known)
    assert np.allclose(ex.fit_calibration(cp, sp).origin, fit.origin)
    with pytest.raises(ex.ExperimentError, match=r"camera points must have shape \(n, 2\).*got shape \(2, 4\)"):
        ex.fit_calibration(cp.T, sp.T)           # one point per column: refused, not read as other points
    _same(ex.read_tracks(str(tmp_path / "cam.csv"), calibration=fit), rows)
    base = [str(tmp_path / "cam.csv"), "--bootstrap", "0", "--resamples", "0"]
    r = _run(base + ["--calibration", str(tmp_path / "cal.csv")], tmp_path)
    assert r.returncode == 0 and "fitted to 4 known points, residual rms" in r.stdout, r.stderr
    r = _run(base + ["--origin", "15,15", "--rotate", "7", "--flip-y"], tmp_path)
    assert r.returncode == 0, r.stderr
    r = _run(base, tmp_path)
    assert r.returncode == 1 and "--calibration" in r.stderr
    lines = (tmp_path / "cal.csv").read_text().splitlines()
    lines[2] = lines[2].replace(",", ",1", 1)          # a mistyped camera x
    (tmp_path / "bad.csv").write_text("\n".join(lines) + "\n")
    r = _run(base + ["--calibration", str(tmp_path / "bad.csv")], tmp_path)
    assert r.returncode == 1 and "residual rms" in r.stderr, r.stderr


def test_the_lab_example_walkthrough(tmp_path):
    """input/lab_tracks.csv with docs/experiment.md's command: the calibration fits to round-off of
    the file's 0.1 um digits, the tracks are read and the damping comes back near the 0.025 they
    were made with; the files are what tests/lab_example.py writes."""
    import importlib.util
    spec = importlib.util.spec_from_file_location("lab_example", ROOT / "tests" / "lab_example.py")
    lab = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(lab)
    wells = (ROOT / "input" / "lab_calibration.csv").read_text().splitlines()[1:]
    for line in wells:
        cx, cy, sx, sy = (float(v) for v in line.split(","))
        ex_, ey_ = lab.to_camera(sx, sy)
        assert abs(ex_ - cx) < 1e-4 and abs(ey_ - cy) < 1e-4
    r = _run([str(ROOT / "input" / "lab_tracks.csv"), "--columns", "track=id,t=time_ms,x=x_mm,y=y_mm",
              "--time-unit", "ms", "--length-unit", "mm", "--calibration", str(ROOT / "input" / "lab_calibration.csv"),
              "--bootstrap", "200", "--resamples", "0", "-o", "lab.h5"], tmp_path)
    assert r.returncode == 0, r.stderr
    m = re.search(r"residual rms ([0-9.e+-]+) cm", r.stdout)
    assert m and float(m.group(1)) < 1e-4
    assert "tracks: 8 read, 0 rejected" in r.stdout
    import h5py
    with h5py.File(tmp_path / "lab.h5") as f:
        a = f["experiment"].attrs
        assert abs(a["damping_ratio"] - 0.025) < 4 * a["damping_ratio_err"]


def test_a_flipped_y_axis_is_refused(flat, tmp_path):
    """The image's y axis pointing down (and nothing else wrong): samples lie higher than their
    energy allows (none in the right frame); the run is refused naming --flip-y, and with
    --flip-y the data come back."""
    tr = ex.read_tracks(str(flat / "cons.h5"))
    tr.y = -tr.y
    ex.write_tracks_csv(str(tmp_path / "down.csv"), tr)
    base = [str(tmp_path / "down.csv"), "--theory", str(flat / "theory.h5"), "--bootstrap", "0", "--resamples", "0"]
    r = _run(base, tmp_path)
    assert r.returncode == 1 and "--flip-y" in r.stderr and "higher on the surface" in r.stderr, r.stderr
    r = _run(base + ["--flip-y"], tmp_path)
    assert r.returncode == 0, r.stderr


def test_velocities_that_do_not_fit_the_surface_are_refused(canon, tmp_path):
    """Along a track g H falls by what T gains (the printed energy balance, 1 to 1 %). Time stamps
    from a wrong frame period (a 50 Hz camera stamped as 41.7 Hz: times 1.2 times too long, the
    rate still inside 1 Hz..10 kHz) make the velocities 1.2 times too small, and g H then trades at
    1.2^2 = 1.44 times T: refused, naming --time-unit, --rate and the length units."""
    d, rows = canon
    ok = _run([str(d / "canon.csv"), "--resamples", "0", "--bootstrap", "0"], tmp_path)
    assert ok.returncode == 0, ok.stderr
    m = re.search(r"g H falls by ([0-9.]+) times what T gains", ok.stdout)
    assert m and abs(float(m.group(1)) - 1) < 0.01, ok.stdout
    _lab(tmp_path / "slow.csv", rows, tscale=1.2)
    r = _run([str(tmp_path / "slow.csv"), "--resamples", "0", "--bootstrap", "0"], tmp_path)
    assert r.returncode == 1, r.stdout + r.stderr
    assert "do not trade one for one" in r.stderr and "--rate" in r.stderr and "--time-unit" in r.stderr
    m = re.search(r"g H falls by ([0-9.]+) times", r.stderr)
    assert m and abs(float(m.group(1)) - 1.2**2) < 0.05, r.stderr


@pytest.mark.parametrize("tscale,side", [(1.25, "small"), (0.8, "large")])
def test_the_velocity_factor_is_said_the_right_way_round(canon, tmp_path, tscale, side):
    """Times stretched by 1.25 make the velocities 1.25 times too small (g H trades at 1.25^2 T);
    times shrunk by 0.8 make them 1.25 times too large: the message gives the factor >= 1 and the
    side (it said "0.8 times too large" for 1.25 times too small)."""
    d, rows = canon
    _lab(tmp_path / "lab.csv", rows, tscale=tscale)
    r = _run([str(tmp_path / "lab.csv"), "--resamples", "0", "--bootstrap", "0"], tmp_path)
    assert r.returncode == 1, r.stdout + r.stderr
    m = re.search(r"the velocities look ([0-9.]+) times too (small|large)", r.stderr)
    assert m, r.stderr
    assert m.group(2) == side and abs(float(m.group(1)) - 1.25) < 0.03, r.stderr


def _trackpy(path, rows, rate=50.0, name="frame"):
    """A trackpy-style export: frame, particle, x, y in pixels (0.16 cm), y down."""
    with open(path, "w") as f:
        f.write(f"{name},particle,x,y\n")
        f.writelines(f"{int(round(t * rate))},{k},{x / 0.16!r},{-y / 0.16!r}\n" for k, t, x, y in rows)


def test_frame_numbers_with_time_unit_frame(canon, tmp_path):
    """--time-unit frame --rate 50 divides the frame indices by the rate: the same samples as the
    canonical file (its times are frame / 50 to round-off) and the same analysis."""
    d, rows = canon
    _trackpy(tmp_path / "tp.csv", rows)
    tr = ex.read_tracks(str(tmp_path / "tp.csv"), columns={"t": "frame", "track": "particle"}, time_unit="frame",
                        rate=50.0, length_unit="px", pixel_size=0.16, calibration=ex.Calibration((0.0, 0.0), 0.0, True))
    k, t, x, y = (np.array(c) for c in zip(*rows))
    np.testing.assert_allclose(tr.t, t, rtol=0, atol=1e-9)
    np.testing.assert_allclose(tr.x, x, rtol=1e-12, atol=1e-12)
    args = ["tp.csv", "--columns", "t=frame,track=particle", "--length-unit", "px", "--pixel-size", "0.16",
            "--flip-y", "--resamples", "0", "--bootstrap", "0"]
    r = _run(args + ["--time-unit", "frame", "--rate", "50"], tmp_path)
    assert r.returncode == 0, r.stderr
    assert "camera rate 50 Hz (--rate); times in frames (divided by --rate)" in r.stdout
    ref = _run([str(d / "canon.csv"), "--resamples", "0", "--bootstrap", "0"], tmp_path)
    m = [re.search(r"U1 crossings: .*", o.stdout).group(0) for o in (r, ref)]
    assert m[0] == m[1], m
    # --time-unit frame without --rate: refused, naming --rate
    r = _run(args + ["--time-unit", "frame"], tmp_path)
    assert r.returncode == 1 and "--rate" in r.stderr and "frames per second" in r.stderr, r.stderr


@pytest.mark.parametrize("name", ["frame", "f"])
def test_frame_numbers_read_as_seconds_are_refused(canon, tmp_path, name):
    """Frame indices read as seconds (with --rate 60 they made 36,000 gap issues and "no usable
    track segment"): refused, suggesting --time-unit frame --rate R, whether the column is named
    frame or only holds integers in steps of 1."""
    d, rows = canon
    _trackpy(tmp_path / "tp.csv", rows, name=name)
    r = _run(["tp.csv", "--columns", f"t={name},track=particle", "--length-unit", "px", "--pixel-size", "0.16",
              "--flip-y", "--rate", "50", "-o", "an.h5"], tmp_path)
    assert r.returncode == 1, r.stdout + r.stderr
    assert "looks like frame indices" in r.stderr and "--time-unit frame --rate R" in r.stderr, r.stderr
    assert "Traceback" not in r.stderr and not (tmp_path / "an.h5").exists()


def test_no_nan_in_the_printout_or_the_legend(canon, tmp_path, monkeypatch):
    """One bin (0, 200] with crossings and no transition: the fit is undefined; the printout says
    so with the 95 % upper limit, and neither it (the empty bins' fractions, intervals, theory)
    nor the figure's legend (it drew "slope (0.00 +- nan)e-3") shows a nan."""
    d, rows = canon
    an = ex.analyse(ex.read_tracks(str(d / "canon.csv")), None,
                    ex.Options(bins=(0.0, 200.0), fit_max=200.0, bootstrap=0, resamples=0, compare=False))
    assert an.attrs["n_crossings"] > 0 and an.attrs["n_transitions"] == 0
    texts = []

    def grab(fig, path, option=None, **kw):
        texts.extend(t.get_text() for ax in fig.axes for t in ax.findobj(lambda o: hasattr(o, "get_text")))
    monkeypatch.setattr(ex._output, "save_figure", grab)
    ex.plot_analysis(str(tmp_path / "f.png"), an)
    assert texts and not any("nan" in t.lower() for t in texts), [t for t in texts if "nan" in t.lower()]
    r = _run([str(d / "canon.csv"), "--bins", "-40:400:40", "--resamples", "0", "--bootstrap", "0"], tmp_path)
    assert r.returncode == 0, r.stderr
    assert "nan" not in r.stdout.lower(), r.stdout
    r = _run([str(d / "canon.csv"), "--bins", "0:200:200", "--fit-max", "200", "--resamples", "0", "--bootstrap", "0"],
             tmp_path)
    assert r.returncode == 0 and "the fit is undefined" in r.stdout and "nan" not in r.stdout.lower(), r.stdout


def test_a_single_track_prints_no_nan(tmp_path):
    """One track: the decay's coefficients have no bootstrap error (it needs two tracks); the
    summary prints the values, "(no error)" and a note why, never "+- nan" or "(95%: nan .. nan)"."""
    tr = ex.synthetic_tracks(1, duration=2.0, ensemble="microcanonical", dE_range=(100.0, 300.0), seed=5,
                             noise=0.05, pixel=0.16, rate=50.0)
    ex.write_tracks_csv(str(tmp_path / "one.csv"), tr)
    r = _run(["one.csv", "--resamples", "0", "--bootstrap", "0"], tmp_path)
    assert r.returncode == 0, r.stderr
    assert "damping from the energy's decay" in r.stdout and "(no error)" in r.stdout, r.stdout
    assert "bootstrap over the tracks, which needs two or more" in r.stdout
    assert "nan" not in r.stdout.lower(), r.stdout
