"""An interrupted multi-scene run keeps its finished scenes (docs/output.md "Exit codes and
signals"): the first SIGINT or SIGTERM during the scenes stops the running scene within one unit of
its ensemble, drops what that scene wrote, and writes the finished scenes into the output file,
marked incomplete (/@incomplete, /@scenes_complete), exit 128 + the signal; a second signal stops
at once without output. The kept groups are checked against an uninterrupted run of those scenes."""
import os
import signal
import subprocess
import threading
import time

import h5py
import numpy as np
import pytest

from conftest import TIMEOUT_SCALE, TUBES

SCENES = ("&run scenes = 'equilibria', 'orbits', 'montecarlo', output = 'm.h5' /\n"
          "&orbits de = 1, 10 /\n"
          "&montecarlo de = 100, n_samples = 10000000 /\n")


def datasets(group):
    out = {}
    group.visititems(lambda name, obj: out.__setitem__(name, obj[()]) if isinstance(obj, h5py.Dataset) else None)
    return out


def start(tmp, text):
    (tmp / "m.nml").write_text(text)
    env = dict(os.environ, OMP_NUM_THREADS="1")
    p = subprocess.Popen([str(TUBES), "m.nml"], cwd=tmp, env=env, stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True)
    err, seen = [], threading.Event()

    def read():
        for line in p.stderr:
            err.append(line)
            if "integrating" in line:
                seen.set()
    t = threading.Thread(target=read, daemon=True)
    t.start()
    assert seen.wait(120 * TIMEOUT_SCALE), "".join(err)   # the Monte Carlo has started
    return p, err, t


@pytest.mark.parametrize("name", ["SIGINT", "SIGTERM"])
def test_a_signal_keeps_the_finished_scenes_in_a_file_marked_incomplete(tmp_path, name):
    sig = getattr(signal, name)
    p, err, t = start(tmp_path, SCENES)
    time.sleep(0.5)
    t0 = time.time()
    p.send_signal(sig)
    out = p.stdout.read()
    p.wait(timeout=60)
    t.join(10)
    took = time.time() - t0
    text = "".join(err)
    assert p.returncode == 128 + sig, (p.returncode, text)
    assert took < 5 * TIMEOUT_SCALE, took                      # the ensemble stopped within a unit
    assert f"stopped by {name}" in text and "the finished scenes will be kept" in text, text
    assert "kept the finished scenes (equilibria orbits) in m.h5, marked incomplete" in text, text
    assert "wrote m.h5" not in out
    assert sorted(p.name for p in tmp_path.glob("m.h5*")) == ["m.h5"]    # no temporary file left
    with h5py.File(tmp_path / "m.h5") as f:
        assert f.attrs["incomplete"] == f"stopped by {name} during the scene 'montecarlo'"
        assert f.attrs["scenes_complete"] == "equilibria orbits"
        assert f.attrs["exit_status"] == 128 + sig
        assert "montecarlo" not in f and "orbits" in f and "equilibria" in f
        kept = datasets(f["orbits"])
    # the kept scenes are those of a run of only them (a different code path: no signal, no drop)
    (tmp_path / "ref").mkdir()
    (tmp_path / "ref" / "r.nml").write_text("&run scenes = 'equilibria', 'orbits', output = 'r.h5' /\n"
                                            "&orbits de = 1, 10 /\n")
    r = subprocess.run([str(TUBES), "r.nml"], cwd=tmp_path / "ref", capture_output=True, text=True,
                       env=dict(os.environ, OMP_NUM_THREADS="1"))
    assert r.returncode == 0, r.stderr
    with h5py.File(tmp_path / "ref" / "r.h5") as f:
        ref = datasets(f["orbits"])
    assert sorted(kept) == sorted(ref) and len(ref) > 5
    for k, v in kept.items():
        if v.dtype.kind in "fc":
            np.testing.assert_array_equal(v, ref[k], err_msg=k)
        else:
            assert np.array_equal(v, ref[k]), k


def test_a_second_signal_stops_at_once_without_output(tmp_path):
    """A scene that does not look at the request (one long trajectory) runs on after the first
    signal; the second ends the run at once, with no output."""
    (tmp_path / "t.nml").write_text("&run scenes = 'equilibria', 'trajectory', output = 't.h5' /\n"
                                    "&trajectory t_end = 4000000, dt_out = 100 /\n")
    p = subprocess.Popen([str(TUBES), "t.nml"], cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         text=True, env=dict(os.environ, OMP_NUM_THREADS="1"))
    t0 = time.time()
    while not list(tmp_path.glob("t.h5.tmp*")):
        assert time.time() - t0 < 60 * TIMEOUT_SCALE and p.poll() is None
        time.sleep(0.05)
    time.sleep(0.5)
    p.send_signal(signal.SIGTERM)
    time.sleep(0.5)
    assert p.poll() is None                                  # the trajectory goes on
    p.send_signal(signal.SIGTERM)
    out, err = p.communicate(timeout=60)
    assert p.returncode == 143, err
    assert "the finished scenes will be kept" in err and err.rstrip().endswith("no output written"), err
    assert not list(tmp_path.glob("t.h5*"))


def test_a_signal_in_the_first_scene_leaves_no_file(tmp_path):
    p, err, t = start(tmp_path, "&run scenes = 'montecarlo', 'orbits', output = 'm.h5' /\n"
                                "&montecarlo de = 100, n_samples = 10000000 /\n")
    p.send_signal(signal.SIGINT)
    p.wait(timeout=60)
    t.join(10)
    text = "".join(err)
    assert p.returncode == 130, text
    assert "no scene had finished (the scene 'montecarlo' was stopped); no output written" in text, text
    assert not list(tmp_path.glob("m.h5*"))
