"""Ctrl-C stops a Python call of the core (src/base/tubes_cancel_shim.c, the ensembles' check in
src/parallel/tubes_ensemble.f90): a 10^7-point Monte Carlo took 66 s after Ctrl-C to raise
KeyboardInterrupt, and three long calls ignored it for 10-15 s (issues 37 and 39). The child
process below is interrupted at several moments of the call (drawing the points, classifying
them); each time KeyboardInterrupt comes within 2 s, Python's own handler is back afterwards, and
the same model then gives the numbers of a fresh one (what it kept was dropped, not cut short)."""
import os
import signal
import subprocess
import sys
import textwrap
import time

import pytest

from conftest import TIMEOUT_SCALE

CHILD = textwrap.dedent("""
    import signal, sys, time
    import tubes
    m = tubes.Model()
    m.monte_carlo(100.0, n_samples=200)          # the set-up (equilibria, orbit, cut) kept
    print("ready", flush=True)
    try:
        m.monte_carlo(100.0, n_samples=10_000_000)
        print("finished", flush=True)
    except KeyboardInterrupt:
        print("interrupted", time.time(), flush=True)
    print("handler", signal.getsignal(signal.SIGINT) is signal.default_int_handler, flush=True)
    a = m.monte_carlo(100.0, n_samples=3000)
    b = tubes.Model().monte_carlo(100.0, n_samples=3000)
    print("same", a["fraction"] == b["fraction"] and list(a["transit"]) == list(b["transit"]), flush=True)
""")


@pytest.mark.parametrize("after", [0.3, 1.5, 4.0])
def test_ctrl_c_stops_a_long_monte_carlo_within_two_seconds(tmp_path, after):
    script = tmp_path / "child.py"
    script.write_text(CHILD)
    env = dict(os.environ, OMP_NUM_THREADS="1")
    p = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         env=env)
    try:
        assert p.stdout.readline().strip() == "ready"
        time.sleep(after)
        sent = time.time()
        p.send_signal(signal.SIGINT)
        out, err = p.communicate(timeout=120 * TIMEOUT_SCALE)
    finally:
        p.kill()
    lines = dict(x.split(" ", 1) for x in out.splitlines() if " " in x)
    assert "interrupted" in lines, out + err
    assert float(lines["interrupted"]) - sent < 2.0 * TIMEOUT_SCALE
    assert lines["handler"] == "True"
    assert lines["same"] == "True", out + err
