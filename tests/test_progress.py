"""Python scene calls report progress (issue 37): with tubes.progress = True a long Monte Carlo
prints the core's progress lines on stderr (count, share, time, time left; at most once a second
once the loop has run a second); False prints none, and the default (None) prints them only when
stderr is a terminal: none into a pipe."""
import os
import re
import subprocess
import sys

import pytest

from conftest import ROOT

SCRIPT = """
import tubes
{setting}
r = tubes.Model().monte_carlo(100.0, n_samples=200000)
print("fraction", r["fraction"])
"""


@pytest.mark.parametrize("setting,shown", [("tubes.progress = True", True), ("tubes.progress = False", False),
                                           ("", False)])
def test_progress_lines(tmp_path, setting, shown):
    env = dict(os.environ, OMP_NUM_THREADS="1", PYTHONPATH=str(ROOT / "python"))
    r = subprocess.run([sys.executable, "-c", SCRIPT.format(setting=setting)], capture_output=True, text=True,
                       env=env, timeout=300)
    assert r.returncode == 0, r.stderr
    assert "fraction" in r.stdout
    lines = [ln for ln in r.stderr.splitlines() if re.match(r"\s+\d+ of 200000 points \(\d+%\), [\d.]+ s, about \d+ s left", ln)]
    assert bool(lines) == shown, r.stderr
    # the same numbers with and without the lines
    assert float(r.stdout.split()[-1]) == pytest.approx(0.08196, abs=0.003)   # p_trans = A_tube/A_E, 5 se
