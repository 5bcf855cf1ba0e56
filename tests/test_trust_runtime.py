"""The program's runtime boundary (issue 39): the model cache is a trust boundary (a library is
identified by the SHA-256 its builder recorded, on its bytes, before it is loaded; files and a
directory others can write are refused), a damaged library is rebuilt, never run, by ./tubes and by
Python; every catchable terminating signal removes the temporary output file, a closed reader of
stdout stops the run cleanly, a signal after the rename says the output is complete; the code
generator runs in its own process group under a time limit and goes with the program; a full cache
disk says why (docs/cluster.md "The model cache", docs/output.md "Exit codes and signals")."""
import hashlib
import os
import pathlib
import pwd
import signal
import subprocess
import sys
import textwrap
import time

import h5py
import pytest

from conftest import ROOT, TIMEOUT_SCALE, TUBES

HH = "(px^2 + py^2)/2 + (x^2 + y^2)/2 + x^2*y - y^3/3"
HH_NML = f"&run scenes = 'equilibria', output = 'e.h5' /\n&model system = 'expression', hamiltonian = '{HH}' /\n"
PY = str(ROOT / ".venv" / "bin" / "python")
# a Taylor kernel of the rolling ball (method = 'auto', the default): one short trajectory
JET_NML = "&run scenes = 'trajectory', output = 't.h5' /\n&trajectory t_end = 0.5 /\n"


def run(tmp, text, cache, env=None, timeout=300, name="x.nml"):
    (tmp / name).write_text(text)
    e = dict(os.environ, OMP_NUM_THREADS="1", TUBES_CACHE_DIR=str(cache), **(env or {}))
    return subprocess.run([str(TUBES), name], cwd=tmp, capture_output=True, text=True, env=e,
                          timeout=timeout * TIMEOUT_SCALE)


def fresh_cache(tmp, mode=0o700):
    c = tmp / "cache"
    c.mkdir()
    c.chmod(mode)
    return c


def built(tmp, text=HH_NML, pattern="expr_*.so"):
    """A cache with the library of text built in it, and the library's path."""
    c = fresh_cache(tmp)
    p = run(tmp, text, c)
    assert p.returncode == 0, p.stderr
    libs = sorted(c.glob(pattern), key=lambda f: f.stat().st_mtime)
    assert libs, list(c.iterdir())
    return c, libs[-1]


def evil_library(tmp, marker):
    """A shared object whose constructor creates marker (the auditor's foreign library)."""
    src = tmp / "evil.c"
    src.write_text(textwrap.dedent(f"""\
        #include <fcntl.h>
        #include <unistd.h>
        __attribute__((constructor)) static void own(void) {{
          int fd = open("{marker}", O_WRONLY | O_CREAT, 0666);
          if (fd >= 0) close(fd);
        }}
        const char tubes_expr_text[] = "not this model";
        const int tubes_expr_abi = 1;
        """))
    so = tmp / "evil.so"
    subprocess.run(["cc", "-shared", "-fPIC", "-o", str(so), str(src)], check=True)
    return so.read_bytes()


def record(lib):
    """The sidecar a build records: sha256sum's format, beside the library."""
    digest = hashlib.sha256(lib.read_bytes()).hexdigest()
    pathlib.Path(str(lib) + ".sha256").write_text(f"{digest}  {lib.name}\n")


def python_energy(cache, env=None):
    """The formula's energy at one state through the Python package (the same C loader)."""
    code = ("import tubes; m = tubes.Model(system='expression', hamiltonian=%r); "
            "print(repr(tubes.energy([0.1, 0.2, 0.3, -0.4], model=m)))" % HH)
    e = dict(os.environ, OMP_NUM_THREADS="1", TUBES_CACHE_DIR=str(cache), **(env or {}))
    return subprocess.run([PY, "-c", code], capture_output=True, text=True, env=e, timeout=300 * TIMEOUT_SCALE)


HH_ENERGY = (0.3**2 + 0.4**2) / 2 + (0.1**2 + 0.2**2) / 2 + 0.1**2 * 0.2 - 0.2**3 / 3


# ------------------------------------------------------------------ defect 1: a foreign library


@pytest.mark.parametrize("how", ["replaced", "replaced with its hash, owner nobody",
                                 "replaced with its hash, mode 666"])
@pytest.mark.parametrize("via", ["tubes", "python"])
def test_a_foreign_library_in_the_cache_is_never_loaded(tmp_path, how, via):
    c, lib = built(tmp_path)
    marker = tmp_path / "pwned"
    lib.write_bytes(evil_library(tmp_path, marker))
    if "hash" in how:
        record(lib)                      # the attacker's own sidecar: the bytes match it
    if "nobody" in how:
        if os.geteuid() != 0:
            pytest.skip("changing a file's owner needs root")
        nobody = pwd.getpwnam("nobody")
        os.chown(lib, nobody.pw_uid, nobody.pw_gid)
        os.chown(str(lib) + ".sha256", nobody.pw_uid, nobody.pw_gid)
    if "666" in how:
        lib.chmod(0o666)
    if via == "tubes":
        p = run(tmp_path, HH_NML, c)
        assert p.returncode == 0, p.stderr
        assert "equilibria of expression: 4" in p.stdout
    else:
        p = python_energy(c)
        assert p.returncode == 0, p.stderr
        assert abs(float(p.stdout) - HH_ENERGY) < 1e-15, p.stdout  # a sum of 4 terms of size 0.1
    assert not marker.exists(), "the foreign library ran"
    why = {"replaced": "does not match", "replaced with its hash, owner nobody": "owned by",
           "replaced with its hash, mode 666": "writable by"}[how]
    assert str(lib) in p.stderr and why in p.stderr and "built anew" in p.stderr, p.stderr
    assert b"not this model" not in lib.read_bytes()     # rebuilt in its place
    assert lib.stat().st_uid == os.geteuid() and lib.stat().st_mode & 0o022 == 0


@pytest.mark.parametrize("mode,accepted", [(0o777, False), (0o770, False), (0o1777, True), (0o755, True)])
def test_a_cache_directory_others_can_write_is_refused_unless_sticky(tmp_path, mode, accepted):
    c = fresh_cache(tmp_path, mode)
    c.chmod(mode)                        # mkdir's mode passes through the umask
    marker = tmp_path / "pwned"
    p = run(tmp_path, HH_NML, c)
    if accepted:
        assert p.returncode == 0, p.stderr
        return
    assert p.returncode == 1, p.stderr
    assert str(c) in p.stderr and "TUBES_CACHE_DIR" in p.stderr and "writable by" in p.stderr
    assert "sticky" in p.stderr, p.stderr
    assert not (tmp_path / "e.h5").exists() and not marker.exists()
    assert not list(c.glob("expr_*")), list(c.iterdir())   # nothing built or loaded there


# ------------------------------------------------------------------ defect 2: a damaged library


def damage(lib, how):
    if how == "truncated":
        data = lib.read_bytes()
        lib.write_bytes(data[:len(data) // 2])
        return
    # four bytes of the first function's code zeroed (nm's address is the file offset in a small
    # library from gcc and ld: .text is mapped at its offset)
    nm = subprocess.run(["nm", "-D", "--defined-only", str(lib)], capture_output=True, text=True, check=True)
    addr = min(int(line.split()[0], 16) for line in nm.stdout.splitlines()
               if len(line.split()) == 3 and line.split()[1] == "T")
    with open(lib, "r+b") as f:
        f.seek(addr)
        f.write(b"\0\0\0\0")


@pytest.mark.parametrize("how", ["truncated", "4 bytes zeroed"])
@pytest.mark.parametrize("via", ["tubes", "python"])
def test_a_damaged_formula_library_is_rebuilt_not_run(tmp_path, how, via):
    c, lib = built(tmp_path)
    good = lib.read_bytes()
    damage(lib, how)
    if via == "tubes":
        p = run(tmp_path, HH_NML, c)
        assert p.returncode == 0, (p.returncode, p.stderr)
        assert "S1     -0.86602540   -0.50000000      0.166667" in p.stdout
    else:
        p = python_energy(c)
        assert p.returncode == 0, (p.returncode, p.stderr)
        assert abs(float(p.stdout) - HH_ENERGY) < 1e-15, p.stdout
    assert str(lib) in p.stderr and "does not match" in p.stderr and "built anew" in p.stderr, p.stderr
    assert len(lib.read_bytes()) == len(good)


@pytest.mark.parametrize("how", ["truncated", "4 bytes zeroed"])
@pytest.mark.parametrize("codegen", ["on", "off"])
def test_a_damaged_taylor_kernel_is_rebuilt_or_auto_falls_back(tmp_path, how, codegen):
    c, jet = built(tmp_path, JET_NML, "expr_*.so")
    damage(jet, how)
    p = run(tmp_path, JET_NML, c, env={"TUBES_NO_CODEGEN": "1"} if codegen == "off" else None)
    assert p.returncode == 0, (p.returncode, p.stderr)
    assert str(jet) in p.stderr and "does not match" in p.stderr, p.stderr
    with h5py.File(tmp_path / "t.h5") as f:
        method = f["trajectory"].attrs["method"]
        method = method.decode() if isinstance(method, bytes) else method
    if codegen == "on":
        assert "built anew" in p.stderr and method == "auto (taylor)", (method, p.stderr)
    else:
        assert "DOP853 throughout" in p.stderr and method == "auto (dop853)", (method, p.stderr)


@pytest.mark.parametrize("how", ["truncated", "4 bytes zeroed"])
def test_python_rebuilds_a_damaged_taylor_kernel(tmp_path, how):
    """tubes.integrate (method 'auto') loads its kernel through the same C code as ./tubes."""
    c = fresh_cache(tmp_path)
    code = ("import tubes; r = tubes.integrate([1.0, 0.5, 0.0, 0.0], 0.5, method='auto'); "
            "print(repr(float(r['state'][-1][0])), r.get('method', ''))")
    e = dict(os.environ, OMP_NUM_THREADS="1", TUBES_CACHE_DIR=str(c))
    first = subprocess.run([PY, "-c", code], capture_output=True, text=True, env=e, timeout=300 * TIMEOUT_SCALE)
    assert first.returncode == 0, first.stderr
    jets = sorted(c.glob("expr_*.so"), key=lambda f: f.stat().st_mtime)
    assert jets, list(c.iterdir())
    damage(jets[-1], how)
    again = subprocess.run([PY, "-c", code], capture_output=True, text=True, env=e, timeout=300 * TIMEOUT_SCALE)
    assert again.returncode == 0, (again.returncode, again.stderr)
    assert str(jets[-1]) in again.stderr and "does not match" in again.stderr and "built anew" in again.stderr
    assert again.stdout == first.stdout        # the same kernel, rebuilt: the same numbers


# ------------------------------------------------------------------ defect 3: signals

SECTIONS = ("&run scenes = 'sections', output = 's.h5' /\n"
            "&sections de = 100, 500, n_seeds = 40, n_iter = 5000 /\n")
CAUGHT = ["SIGHUP", "SIGINT", "SIGQUIT", "SIGTERM", "SIGALRM", "SIGUSR1", "SIGUSR2", "SIGPIPE", "SIGXCPU",
          "SIGXFSZ", "SIGVTALRM", "SIGPROF"]


def start(tmp, text, env=None, **kw):
    (tmp / "s.nml").write_text(text)
    e = dict(os.environ, OMP_NUM_THREADS="1", **(env or {}))
    return subprocess.Popen([str(TUBES), "s.nml"], cwd=tmp, env=e, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, **kw)


def wait_for(cond, seconds=60):
    t0 = time.time()
    while not cond():
        assert time.time() - t0 < seconds * TIMEOUT_SCALE, "timed out"
        time.sleep(0.05)


@pytest.mark.parametrize("name", CAUGHT)
def test_every_terminating_signal_removes_the_temporary_file(tmp_path, name):
    sig = getattr(signal, name)
    p = start(tmp_path, SECTIONS)
    wait_for(lambda: list(tmp_path.glob("s.h5.tmp*")))       # the run has started writing
    time.sleep(0.3)
    p.send_signal(sig)
    out, err = p.communicate(timeout=60)
    assert p.returncode == 128 + sig, (p.returncode, err)   # an exit, not a death by the signal
    assert f"stopped by {name}" in err and "no output written" in err, err
    assert not list(tmp_path.glob("s.h5*"))


@pytest.mark.parametrize("name,word", [("SIGSEGV", "segmentation fault"), ("SIGBUS", "bus error"),
                                       ("SIGABRT", "aborted"), ("SIGFPE", "arithmetic exception")])
def test_a_fault_removes_the_temporary_file_and_still_dies_by_its_signal(tmp_path, name, word):
    sig = getattr(signal, name)
    p = start(tmp_path, SECTIONS, preexec_fn=lambda: __import__("resource").setrlimit(
        __import__("resource").RLIMIT_CORE, (0, 0)))                     # no core file in the test's directory
    wait_for(lambda: list(tmp_path.glob("s.h5.tmp*")))
    time.sleep(0.3)
    p.send_signal(sig)
    out, err = p.communicate(timeout=60)
    assert p.returncode == -sig, (p.returncode, err)                    # died by it, as without the handler
    assert f"tubes: {name} (" in err and word in err and "no output written" in err, err
    assert not list(tmp_path.glob("s.h5*"))


def test_a_signal_ignored_at_the_start_stays_ignored(tmp_path):
    """nohup: a SIGHUP the caller ignores does not stop the run."""
    p = start(tmp_path, "&run scenes = 'equilibria', output = 's.h5' /\n",
              preexec_fn=lambda: signal.signal(signal.SIGHUP, signal.SIG_IGN))
    p.send_signal(signal.SIGHUP)
    out, err = p.communicate(timeout=60)
    assert p.returncode == 0 and "wrote s.h5" in out, err


def test_a_closed_reader_of_stdout_stops_the_run_cleanly(tmp_path):
    """./tubes input/paper.nml | head: exit 141, one message, no temporary file."""
    e = dict(os.environ, OMP_NUM_THREADS="1")
    p = subprocess.Popen([str(TUBES), str(ROOT / "input" / "paper.nml"), "-o", "p.h5"], cwd=tmp_path, env=e,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    for _ in range(3):
        p.stdout.readline()
    wait_for(lambda: list(tmp_path.glob("p.h5.tmp*")))
    p.stdout.close()                     # head has read its lines and gone
    err = p.stderr.read()
    p.wait(timeout=120 * TIMEOUT_SCALE)
    assert p.returncode == 141, (p.returncode, err)
    # one message (beside the scenes' progress lines, which go to stderr as the run goes)
    lines = [x for x in err.splitlines() if "SIGPIPE" in x or "Broken pipe" in x or "tubes: stopped" in x]
    assert len(lines) == 1 and "standard output was closed" in lines[0] and "no output written" in lines[0], err
    assert list(tmp_path.iterdir()) == []


def test_the_auditors_pipe_into_head(tmp_path):
    """The shell pipeline itself: ./tubes input/paper.nml | head (pipefail gives tubes' status)."""
    e = dict(os.environ, OMP_NUM_THREADS="1")
    cmd = f"set -o pipefail; '{TUBES}' '{ROOT / 'input' / 'paper.nml'}' -o p.h5 | head -n 2"
    r = subprocess.run(["bash", "-c", cmd], cwd=tmp_path, env=e, capture_output=True, text=True,
                       timeout=300 * TIMEOUT_SCALE)
    assert r.returncode == 141, (r.returncode, r.stderr)
    assert len(r.stdout.splitlines()) == 2
    assert r.stderr.count("tubes: stopped by SIGPIPE (standard output was closed") == 1, r.stderr
    assert list(tmp_path.iterdir()) == []


def test_a_signal_just_after_the_rename_reports_the_output_complete(tmp_path):
    """SIGTERM between the rename and the program's end (a shim raises it inside rename): the file
    is complete and the message says so."""
    shim = tmp_path / "shim.c"
    shim.write_text(textwrap.dedent("""\
        #define _GNU_SOURCE
        #include <dlfcn.h>
        #include <signal.h>
        #include <string.h>
        int rename(const char *a, const char *b) {
          int (*real)(const char *, const char *) = (int (*)(const char *, const char *))dlsym(RTLD_NEXT, "rename");
          int r = real(a, b);
          size_t n = strlen(b);
          if (r == 0 && n > 3 && !strcmp(b + n - 3, ".h5")) raise(SIGTERM);
          return r;
        }
        """))
    subprocess.run(["cc", "-shared", "-fPIC", "-o", str(tmp_path / "shim.so"), str(shim), "-ldl"], check=True)
    p = start(tmp_path, "&run scenes = 'equilibria', output = 's.h5' /\n",
              env={"LD_PRELOAD": str(tmp_path / "shim.so")})
    out, err = p.communicate(timeout=60)
    assert p.returncode == 143, (p.returncode, err)
    assert "stopped by SIGTERM" in err and "output complete: s.h5" in err, err
    assert "no output written" not in err
    with h5py.File(tmp_path / "s.h5") as f:
        assert f.attrs["exit_status"] == 0 and "equilibria" in f
    assert [x.name for x in tmp_path.glob("s.h5*")] == ["s.h5"]


# ------------------------------------------------------------------ defect 4: the code generator


SLOW = """\
import os, sys, time
open(os.environ["SLOW_PID"], "w").write(str(os.getpid()))
sys.stdin.read()
time.sleep(600)
"""


def gone(pid):
    """The process has ended (or is a zombie waiting for a reaper that is not its parent)."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] == "Z"
    except FileNotFoundError:
        return True


def slow_env(tmp):
    (tmp / "slow.py").write_text(SLOW)
    return {"TUBES_CODEGEN": str(tmp / "slow.py"), "TUBES_PYTHON": sys.executable,
            "SLOW_PID": str(tmp / "slow.pid")}


@pytest.fixture
def slow(tmp_path):
    """The slow generator's environment; at the end its process is killed if a failed test left it."""
    yield slow_env(tmp_path)
    pid = (tmp_path / "slow.pid").read_text() if (tmp_path / "slow.pid").exists() else ""
    if pid and not gone(int(pid)):
        os.kill(int(pid), signal.SIGKILL)


def test_a_code_generator_past_its_time_is_stopped(tmp_path, slow):
    c = fresh_cache(tmp_path)
    env = dict(slow, TUBES_CODEGEN_TIMEOUT="2")
    t0 = time.time()
    p = run(tmp_path, HH_NML, c, env=env, timeout=60)
    took = time.time() - t0
    assert p.returncode == 1, (p.returncode, p.stderr)
    assert took < 30, took
    assert "x.nml:2: &model: hamiltonian:" in p.stderr and "2 s" in p.stderr, p.stderr
    assert "TUBES_CODEGEN_TIMEOUT" in p.stderr and HH in p.stderr, p.stderr
    assert gone(int((tmp_path / "slow.pid").read_text()))
    assert list(c.iterdir()) == [], list(c.iterdir())   # its build directory and lock removed
    assert not (tmp_path / "e.h5").exists()


def test_a_bad_code_generator_timeout_is_refused(tmp_path, slow):
    c = fresh_cache(tmp_path)
    p = run(tmp_path, HH_NML, c, env=dict(slow, TUBES_CODEGEN_TIMEOUT="soon"), timeout=60)
    assert p.returncode == 1 and "TUBES_CODEGEN_TIMEOUT = 'soon'" in p.stderr, p.stderr
    assert "seconds > 0" in p.stderr and not (tmp_path / "slow.pid").exists()


@pytest.mark.parametrize("name", ["SIGINT", "SIGTERM", "SIGHUP"])
def test_a_signal_stops_the_code_generator_with_the_program(tmp_path, name, slow):
    c = fresh_cache(tmp_path)
    p = start(tmp_path, HH_NML.replace("e.h5", "s.h5"), env=dict(slow, TUBES_CACHE_DIR=str(c)))
    wait_for(lambda: (tmp_path / "slow.pid").exists() and (tmp_path / "slow.pid").read_text())
    p.send_signal(getattr(signal, name))
    out, err = p.communicate(timeout=60)
    assert p.returncode == 128 + getattr(signal, name), (p.returncode, err)
    assert f"stopped by {name}" in err and "code generator" in err, err
    pid = int((tmp_path / "slow.pid").read_text())
    wait_for(lambda: gone(pid), 10)
    assert list(c.iterdir()) == [], list(c.iterdir())


def test_python_stops_a_code_generator_past_its_time(tmp_path, slow):
    c = fresh_cache(tmp_path)
    p = python_energy(c, env=dict(slow, TUBES_CODEGEN_TIMEOUT="2"))
    assert p.returncode == 1 and "TUBES_CODEGEN_TIMEOUT" in p.stderr, p.stderr
    assert gone(int((tmp_path / "slow.pid").read_text()))
    assert list(c.iterdir()) == [], list(c.iterdir())


def test_ctrl_c_in_python_stops_the_code_generator(tmp_path, slow):
    """The generator has its own process group (the terminal's Ctrl-C does not reach it): a
    SIGINT to Python kills it and Python raises KeyboardInterrupt at once, not after the limit."""
    c = fresh_cache(tmp_path)
    code = "import tubes; tubes.Model(system='expression', hamiltonian=%r)" % HH
    e = dict(os.environ, OMP_NUM_THREADS="1", TUBES_CACHE_DIR=str(c), **slow)
    p = subprocess.Popen([PY, "-c", code], env=e, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    wait_for(lambda: (tmp_path / "slow.pid").exists() and (tmp_path / "slow.pid").read_text())
    t0 = time.time()
    p.send_signal(signal.SIGINT)
    out, err = p.communicate(timeout=60)
    assert time.time() - t0 < 20 and "KeyboardInterrupt" in err, err   # the limit is 120 s
    assert gone(int((tmp_path / "slow.pid").read_text()))
    assert list(c.iterdir()) == [], list(c.iterdir())


# ------------------------------------------------------------------ defect 5: a full cache disk


def test_a_full_cache_disk_says_why(tmp_path):
    small = tmp_path / "small"
    small.mkdir()
    m = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k,mode=700", "tmpfs", str(small)], capture_output=True)
    if m.returncode != 0:
        pytest.skip("cannot mount a small tmpfs as the cache (mount needs root): " + m.stderr.decode().strip())
    try:
        (small / "filler").write_bytes(b"x" * (60 * 1024))   # the library (15 kB) no longer fits
        p = run(tmp_path, HH_NML, small)
        assert p.returncode != 0, p.stderr
        assert "No space left on device" in p.stderr and "x.nml:2: &model" in p.stderr, p.stderr
        assert sorted(x.name for x in small.iterdir()) == ["filler"]
        assert not (tmp_path / "e.h5").exists()
    finally:
        subprocess.run(["umount", str(small)], capture_output=True)
