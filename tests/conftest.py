"""Shared fixtures: paths to the built executable and a scratch directory per test."""
import os
import pathlib
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent
# the executable under test: ./tubes, or another build of it (make sanitize sets TUBES_EXE)
TUBES = pathlib.Path(os.environ.get("TUBES_EXE", ROOT / "tubes")).resolve()
# a slower build of it (the sanitized one runs 3-5 times slower) stretches the hang guards
TIMEOUT_SCALE = float(os.environ.get("TUBES_TIMEOUT_SCALE", "1"))


@pytest.fixture(scope="session")
def tubes_exe():
    if not TUBES.exists():
        pytest.fail("./tubes is not built (run make)")
    return str(TUBES)


def run_tubes(args, cwd, timeout=120, threads=1):
    """Run the executable; returns the CompletedProcess (text mode)."""
    env = dict(os.environ, OMP_NUM_THREADS=str(threads))
    return subprocess.run([str(TUBES), *args], cwd=cwd, capture_output=True, text=True,
                          timeout=timeout * TIMEOUT_SCALE, env=env)


@pytest.fixture(scope="session")
def paper_h5(tmp_path_factory, tubes_exe):
    """input/paper.nml run once per session (2 threads: the output is the same for any number):
    the directory holds only
    its output p.h5 and the run's CompletedProcess is returned with it, (path, result). With
    pytest-xdist the workers share one run (a lock file in their common base directory)."""
    import fcntl
    import pickle
    base = tmp_path_factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):
        base = base.parent                      # shared by the workers of this session
    d = base / "paper_run"
    with open(base / "paper_run.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        done = base / "paper_run.pickle"
        if not done.exists():
            d.mkdir(exist_ok=True)
            r = run_tubes([str(ROOT / "input" / "paper.nml"), "-o", "p.h5"], d, timeout=300, threads=2)
            done.write_bytes(pickle.dumps((r.returncode, r.stdout, r.stderr)))
        rc, out, err = pickle.loads(done.read_bytes())
    return d / "p.h5", subprocess.CompletedProcess(["tubes", "input/paper.nml"], rc, out, err)
