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


def run_tubes(args, cwd, timeout=120):
    """Run the executable; returns the CompletedProcess (text mode)."""
    env = dict(os.environ, OMP_NUM_THREADS="1")
    return subprocess.run([str(TUBES), *args], cwd=cwd, capture_output=True, text=True,
                          timeout=timeout * TIMEOUT_SCALE, env=env)
