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

# The test files whose tests take more than about 8 s in all on this machine (pytest --durations=0,
# 2026-11-29): marked slow, left out of make quick (make check runs them). A file that grows past
# that goes here (docs/development.md, "make quick").
SLOW = {"test_plots_every_model.py", "test_expression.py", "test_experiment.py", "test_normal_form.py",
        "test_trust_runtime.py", "test_tube_cut3.py", "test_models_cli.py", "test_figures.py",
        "test_dissipation.py", "test_tubes_cli.py", "test_experiment_lab.py", "test_trust_python_io.py",
        "test_experiment_fold.py", "test_trust_formula.py", "test_cli.py", "test_flux.py", "test_gallery.py",
        "test_three_dof.py", "test_progress.py", "test_python_scenes.py", "test_dissipation_models.py",
        "test_centres.py", "test_experiment_law.py"}
# and single tests: those that run input/paper.nml (the paper_h5 fixture, ~25 s) or take > 8 s
SLOW_TESTS = {"test_load_reads_a_run", "test_a_long_ensemble_reports_its_progress"}
# single tests by file and name, > 10 s each under make quick (--durations, 2026-11-29: 77, 33, 16, 13,
# 12, 10 s with two other builds running beside it)
SLOW_IN_FILE = {("test_guess.py", "test_python_guess_and_branch_are_the_program_s"),
                ("test_guess.py", "test_fold_of_l2_halo_family"),
                ("test_halo_tubes.py", "test_gallery_halo_tubes"), ("test_halo_tubes.py", "test_refusals"),
                ("test_table_file.py", "test_the_orbit_family_s_bifurcations_are_the_file_s"),
                ("test_scan.py", "test_formula_constant_scan_in_the_program"),
                # 2026-11-30 (make quick's slowest, 11 s): the family searched to its end for a period
                ("test_orbit_parameter.py", "test_bad_input_python")}


def pytest_configure(config):
    config.addinivalue_line("markers", "slow: more than a few seconds (left out of make quick)")


def pytest_collection_modifyitems(config, items):
    for item in items:
        if (item.path.name in SLOW or item.originalname in SLOW_TESTS or "paper_h5" in item.fixturenames
                or (item.path.name, item.originalname) in SLOW_IN_FILE):
            item.add_marker(pytest.mark.slow)


@pytest.fixture(scope="session")
def model_cache():
    """The formula models' and Taylor kernels' cache (TUBES_CACHE_DIR) the tests share: one
    directory for every test file, worker and run (build/test-cache, or TUBES_TEST_CACHE), so
    that each library is built once, not once per test module (building one is 1-5 s: SymPy and
    the C compiler). Its entries are named by the hash of their source and generator and checked
    by their SHA-256 (docs/models.md), so a changed model or generator builds anew. A test of the
    cache itself (a first build, a damaged or foreign file) makes its own empty one."""
    d = pathlib.Path(os.environ.get("TUBES_TEST_CACHE", ROOT / "build" / "test-cache"))
    d.mkdir(parents=True, exist_ok=True)
    return str(d)


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
