"""Formulas that cannot hang, crash or mislead (issue 39; docs/models.md, "Limits"): each case
below ran before, through `./tubes` and the code generator (python/tubes/codegen.py), into a
silently dropped rest (`#`), a traceback's first line, nine lines of gcc output, a wrong message
("the coordinate 'x' never appears" for 1/0) or a hang (10^10^10, exp(exp(exp(10))) for 261 s).
Now each is one line naming the variable, the column, what is wrong and what is allowed, exit 1,
no output file. The generator's own limits and its catch-all are checked on the module too."""
import os
import subprocess
import sys
import time

import pytest

from conftest import ROOT, TUBES

sys.path.insert(0, str(ROOT / "python" / "tubes"))
import codegen  # noqa: E402  (the generator is a script by path, not a package module)

H = "(px^2 + py^2)/2 + {} + y^2"


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return str(tmp_path_factory.mktemp("cache"))


def run(tmp, model, cache, env=None):
    (tmp / "f.nml").write_text("&run scenes = 'equilibria', output = 'f.h5' /\n"
                               f"&model system = 'expression', {model} /\n")
    t0 = time.time()
    r = subprocess.run([str(TUBES), "f.nml"], cwd=tmp, capture_output=True, text=True, timeout=120,
                       env=dict(os.environ, TUBES_CACHE_DIR=cache, **(env or {})))
    return r, time.time() - t0


CASES = [   # (the model's variables, the message's words)
    ("hamiltonian = '" + H.format("x^2") + " # a comment ('", "hamiltonian: '#' at column 29 is not allowed: a formula has no comments"),
    ("hamiltonian = '" + H.format("1e400*x^2") + "'", "hamiltonian: the number 1e400 at column 19 is beyond a double"),
    ("hamiltonian = '" + H.format("1e-400*x^2") + "'", "hamiltonian: the number 1e-400 at column 19 is below the smallest double"),
    ("hamiltonian = '" + H.format("2**2**2**2**2*x^2") + "'", "the power (2)^(65536) at column 19 is beyond a double"),
    ("hamiltonian = '" + H.format("10**10**10*x^2") + "'", "the power (10)^(1e+10) at column 19 is beyond a double"),
    ("hamiltonian = '" + H.format("x^2/0") + "'", "hamiltonian: division by zero at column 19"),
    ("hamiltonian = '" + H.format("1/0*x^2") + "'", "hamiltonian: division by zero at column 19"),
    ("hamiltonian = '" + H.format("x^2/(x - x)") + "'", "hamiltonian: is not finite: a division by an expression that is identically 0"),
    ("hamiltonian = '" + H.format("sqrt(-1)*x^2") + "'", "sqrt(-1) at column 19 is the square root of a negative number"),
    ("hamiltonian = '" + H.format("log(-1)*x^2") + "'", "log(-1) at column 19 is the logarithm of a number <= 0"),
    ("hamiltonian = '" + H.format("(-8)^(1/3)*x^2") + "'", "at column 19 is complex: a negative number to a non-integer power"),
    ("hamiltonian = '" + H.format("asin(2)*x^2") + "'", "asin(2) at column 19 is asin of a number outside [-1, 1]"),
    ("hamiltonian = '" + H.format("x^100") + "'", "the power ^100 at column 19 of an expression with variables"),
    ("hamiltonian = '" + H.format("exp(exp(exp(10)))*x^2") + "'", "exp(22026.5) at column 23 overflows a double"),
    ("hamiltonian = '" + H.format("a*x^2") + "', constants = 'a = 1e400'", "constants: constants(1): a = 1e400: the number 1e400"),
    ("hamiltonian = '" + H.format("a*x^2") + "', constants = 'a = 1/0'", "constants: constants(1): a = 1/0: division by zero at column 1"),
    ("hamiltonian = '" + H.format("a*x^2") + "', constants = 'a = exp(exp(exp(10)))'", "constants(1): a = exp(exp(exp(10))): exp(22026.5) at column 5 overflows"),
    ("hamiltonian = '" + H.format("a*b*x^2") + "', constants = 'a = 1e300', 'b = a*a'", "constants(2): b = a*a: the constant part 'a*a' at column 1 is beyond a double"),
    ("hamiltonian = '" + H.format("-" * 1200 + "x^2") + "'", "levels deep: at most 1000"),
]


@pytest.mark.parametrize("model,words", CASES, ids=[w[:40] for _, w in CASES])
def test_a_bad_formula_is_one_clear_line(tmp_path, cache, model, words):
    r, took = run(tmp_path, model, cache)
    assert r.returncode == 1, r.stdout + r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("f.nml:2: &model: ") and words in lines[0], r.stderr
    assert "Traceback" not in r.stderr and "error:" not in r.stderr      # neither Python's nor gcc's
    assert took < 30                                                      # 10^10^10 hung, exp^3 took 261 s
    assert not list(tmp_path.glob("f.h5*"))


def test_good_formulas_still_build(tmp_path, cache):
    # the checks let through what they should: constants of constants, powers, functions of numbers
    r, _ = run(tmp_path, "hamiltonian = '" + H.format("a*x^4 - b*x^2 + 2^-3*sqrt(2)*exp(-1)*x^2 + x^32") + "', "
                         "constants = 'a = 0.25', 'b = a*2', 'c = 10^300'", cache)
    assert r.returncode == 0, r.stderr


def test_an_internal_error_of_the_generator_is_one_line(tmp_path, cache):
    """Any exception the generator did not foresee becomes one line, not a traceback."""
    fake = tmp_path / "codegen_broken.py"
    fake.write_text(f"import sys\nsys.path.insert(0, {str(ROOT / 'python' / 'tubes')!r})\nimport codegen\n"
                    "def boom(*a):\n    raise KeyError('some key')\ncodegen._main = boom\n"
                    "sys.exit(codegen.main(sys.argv))\n")
    r, _ = run(tmp_path, "hamiltonian = '" + H.format("0.3*x^2") + "'", cache, env={"TUBES_CODEGEN": str(fake)})
    assert r.returncode == 1
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "internal error in the code generator: KeyError: 'some key' (please report it)" in lines[0], r.stderr


def test_the_generators_size_limits_on_the_module():
    import sympy as sp
    x = sp.Symbol("x")
    with pytest.raises(codegen.FormulaError, match=f"terms and operators: at most {codegen.MAX_NODES}"):
        codegen.parse("+".join(["x"] * 3000), "hamiltonian", {"x": x}, sp)
    with pytest.raises(codegen.FormulaError, match="levels deep: at most 1000"):
        codegen.parse("-" * 1500 + "x", "hamiltonian", {"x": x}, sp)
    # a long sum is a deep chain in the syntax tree: it is allowed, and summed
    assert codegen.parse("+".join(["x"] * 900), "hamiltonian", {"x": x}, sp) == 900 * x
    assert codegen.parse("-" * 800 + "x", "hamiltonian", {"x": x}, sp) == x


def test_a_changed_generator_rebuilds_the_cached_model(tmp_path):
    """The cache key holds a hash of the code generator: a library built by an older generator
    (which let '#' through) is not loaded by a newer one."""
    cache = str(tmp_path / "c")
    old = tmp_path / "codegen_old.py"
    old.write_text((ROOT / "python" / "tubes" / "codegen.py").read_text() + "\n# an older generator\n")
    (tmp_path / "jetgen.py").write_text((ROOT / "python" / "tubes" / "jetgen.py").read_text())
    model = "hamiltonian = '" + H.format("0.7*x^2") + "'"
    r1, _ = run(tmp_path, model, cache, env={"TUBES_CODEGEN": str(old)})
    r2, _ = run(tmp_path, model, cache)
    assert r1.returncode == 0 and r2.returncode == 0, r1.stderr + r2.stderr
    assert "code generated" in r1.stdout and "code generated" in r2.stdout    # built twice, not a cache hit
