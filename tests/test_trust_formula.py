"""Formula models that cannot hang, crash or mislead (issue 39; docs/models.md, "Limits"): through the
executable and a namelist (and tubes.Model, which goes the same way), a formula with '#', a constant
part that overflows, divides by zero or is complex, a constant power too large to compute, an
exponent or an expansion over its limit, is refused with one line naming the variable, the column
and what is allowed; an unexpected error in the code generator is one line, not a traceback; formulas
that once ran for minutes now finish within a short code-generation timeout."""
import os
import subprocess
import sys
import textwrap

import pytest

from conftest import ROOT, TUBES, TIMEOUT_SCALE

P = " + px^2 + py^2 + y"      # the rest of a Hamiltonian of x, y, px, py
CODEGEN = os.environ.get("TUBES_CODEGEN", ROOT / "python" / "tubes" / "codegen.py")   # as src/io/tubes_expr.c


def run(tmp_path, hamiltonian, constants=(), env=None, timeout=120):
    consts = ("constants = " + ", ".join(f"'{c}'" for c in constants) + ",") if constants else ""
    path = tmp_path / "t.nml"
    path.write_text(textwrap.dedent(f"""\
        &run scenes = 'equilibria', output = 't.h5' /
        &model system = 'expression', {consts} hamiltonian = '{hamiltonian}' /
        &equilibria box = 2.0 /
        """))
    e = dict(os.environ, OMP_NUM_THREADS="1", TUBES_CACHE_DIR=str(tmp_path / "cache"), **(env or {}))
    return subprocess.run([str(TUBES), "t.nml"], cwd=tmp_path, capture_output=True, text=True, env=e,
                          timeout=timeout * TIMEOUT_SCALE)


def refused(p, *parts):
    """One clean line on stderr, naming the file and line, and containing parts."""
    assert p.returncode != 0, p.stdout + p.stderr
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("t.nml:2: &model: "), p.stderr
    assert "Traceback" not in p.stderr
    for s in parts:
        assert s in lines[0], lines[0]
    return lines[0]


@pytest.mark.parametrize("formula, parts", [
    # the rest after '#' was read as a comment: the model built without it
    ("(px^2 + py^2)/2 + x^2 + y^2 # + (", ["hamiltonian: '#' at column 29 is not allowed"]),
    ("1e400*x" + P, ["hamiltonian: '1e400' at column 1 overflows a double"]),
    ("x" + P + " + 2**2**2**2**2", ["hamiltonian: '2**2**2**2**2' at column 23", "too large: a constant power lies between 2^-1100 and 2^1100"]),
    ("10**10**10*x" + P, ["hamiltonian: '10**10**10' at column 1", "too large: a constant power lies between 2^-1100 and 2^1100"]),
    ("10^-(10^10)*x" + P, ["hamiltonian: '10^-(10^10)' at column 1 is about 2^-3.32e+10, too small"]),
    ("1/0 + x" + P, ["hamiltonian: '1/0' at column 1 divides by zero"]),
    ("sqrt(-1)*x" + P, ["hamiltonian: 'sqrt(-1)' at column 1 is not a real number: sqrt needs an argument >= 0"]),
    ("log(-1)*x" + P, ["hamiltonian: 'log(-1)' at column 1 is not a real number: log needs an argument > 0"]),
    ("(-8)^(1/3)*x" + P, ["hamiltonian: '(-8)^(1/3)' at column 1 is not a real number"]),
    ("exp(exp(exp(10)))*x" + P, ["hamiltonian: 'exp(exp(10))' at column 5 overflows a double"]),
    ("tan(pi/2)*x" + P, ["hamiltonian: is not finite and real", "zoo"]),
    ("x/(x - x)" + P, ["hamiltonian: is not finite and real"]),
    ("(x + px)^1000" + P, ["hamiltonian: '(x + px)^1000' at column 1 raises a formula to the power 1000",
                           "at most 100"]),
    ("((x + px)^30)^30" + P, ["hamiltonian: has the power 900", "at most 100"]),
    ("(x + y + px + py)^60", ["hamiltonian: expands to about 39711 terms", "at most 20000 once expanded"]),
    # found by tests/fuzz/fuzz_formula.py: SymPy makes sqrt(u^2) |u|, whose Hessian has DiracDelta
    ("a/sqrt((x - 1 + a)^2)" + P, ["hamiltonian: becomes Abs(", "not differentiable everywhere"]),
    # found by the fuzz target: a non-polynomial power, expanded for minutes (its naturalness)
    ("((x + y)^3 + py^3/2 - x/y + px)^34 + py", ["hamiltonian: expands to about", "at most 20000 once expanded"]),
    # a SyntaxWarning on stderr came before the message line
    ("x + 1or y" + P, ["hamiltonian: a logical operator at column 1 is not allowed"]),
])
def test_formula_refused(tmp_path, formula, parts):
    refused(run(tmp_path, formula, ["a = 0.5"], timeout=60), *parts)


@pytest.mark.parametrize("value, parts", [
    ("1e400", ["constants: constants(1): a = 1e400: '1e400' at column 1 overflows a double"]),
    ("1/0", ["constants: constants(1): a = 1/0: '1/0' at column 1 divides by zero"]),
    ("exp(exp(exp(10)))", ["constants(1): a = exp(exp(exp(10))): 'exp(exp(10))' at column 5 overflows"]),
])
def test_constant_refused(tmp_path, value, parts):
    refused(run(tmp_path, "a*x" + P, [f"a = {value}"], timeout=60), *parts)


def test_python_model_refuses_the_same(tmp_path, monkeypatch):
    """tubes.Model goes through the same generator: the same message, as a ValueError."""
    monkeypatch.setenv("TUBES_CACHE_DIR", str(tmp_path / "cache"))
    r = subprocess.run([sys.executable, "-c", "import tubes\n"
                        "try:\n tubes.Model(system='expression', hamiltonian='x^2 + y^2 + px^2 + py^2 # + (')\n"
                        "except ValueError as e:\n print(e)\n"], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0 and "Traceback" not in r.stderr, r.stderr
    assert "hamiltonian: '#' at column 25 is not allowed" in r.stdout, r.stdout + r.stderr


def test_internal_error_is_one_line(tmp_path):
    """An exception the generator does not expect (here: a SymPy that fails) is one line."""
    fake = tmp_path / "fake" / "sympy"
    fake.mkdir(parents=True)
    (fake / "__init__.py").write_text("def __getattr__(name):\n    raise RuntimeError('broken ' + name)\n")
    line = refused(run(tmp_path, "x^2" + P, env={"PYTHONPATH": str(tmp_path / "fake")}),
                   "hamiltonian: internal error in the code generator: RuntimeError: broken ", "(please report)")
    assert "-:" not in line


def codegen(expr):
    spec = f"tubes-expression 1\nkind hamiltonian\nexpr {expr}\ncoordinates x y\nmomenta px py\n"
    return subprocess.run([sys.executable, str(CODEGEN), "--out", os.devnull], input=spec, capture_output=True,
                          text=True, timeout=60 * TIMEOUT_SCALE)


@pytest.mark.parametrize("expr, message", [
    ("x + y + px + py" + " + x" * 10000, "hamiltonian\tis 40015 characters long: a formula has at most 20000"),
    ("-" * 101 + "x + y + px + py", "hamiltonian\tis nested more than 100 levels deep"),
    ("sin(" * 101 + "x" + ")" * 101 + "+ y + px + py", "hamiltonian\tis nested more than 100 levels deep"),
    ("+".join(["x*y"] * 4000) + "+px+py", "hamiltonian\thas more than 20000 terms, operators and numbers"),
    ("1" + "0" * 5000 + "*x + y + px + py", "hamiltonian\thas an integer of more than 4300 digits"),
])
def test_size_limits(expr, message):
    """The limits of a formula's size (the namelist's string is shorter: through codegen directly)."""
    r = codegen(expr)
    assert r.returncode == 1 and r.stderr.count("\n") == 1 and r.stderr.startswith(message), r.stderr[:500]


def test_long_sum_is_not_deep():
    """A sum of 2000 terms is one level of nesting, not 2000 (it was a RecursionError traceback)."""
    r = codegen("+".join(["x*y"] * 2000) + "+px+py")
    assert r.returncode == 0, r.stderr[:500]


@pytest.mark.parametrize("formula", [
    "(x + y + px + py)^30",                 # 175 s in sp.simplify (the reversor), now ~3 s
    # found by tests/fuzz/fuzz_formula.py: 45 s expanding the third derivatives (the naturalness
    # test), and over 120 s working out a rational to a rational power exactly (now at float points)
    "sqrt(x^2 + y^2 + px^2 + y^2^2 + py^2)^-3",
    "sqrt(x^2 + y^2 + px^3 + py^1)^ + px^3 + -3",
    "((x+2^2)/2 + +-+-x / y + px )^34+  py+ +  + py",   # minutes expanding H - V (the naturalness test)
    "sqrt(x^3 + y^1 + px^1 *pi-pi--pi---pi-pi-------pi--pi-- py^3)^-33",   # minutes in expand + simplify
])
def test_no_minutes_in_simplify(tmp_path, formula):
    """Formulas that kept the generator busy for minutes are built within a 30 s code-generation limit."""
    p = run(tmp_path, formula, env={"TUBES_CODEGEN_TIMEOUT": "30"}, timeout=200)
    # built (the equilibria of the fuzzer's odd Hamiltonians may not converge: exit 2, said)
    assert "code generated" in p.stdout and "did not finish" not in p.stderr, p.stderr
    assert p.returncode in (0, 2), p.stderr


def test_a_changed_generator_rebuilds_the_cached_model(tmp_path):
    """The model cache's key holds a hash of the code generator (codegen.py, jetgen.py): a library
    an older generator built (one that let '#' through) is not loaded by a newer one."""
    old = tmp_path / "gen" / "codegen.py"
    old.parent.mkdir()
    old.write_text((ROOT / "python" / "tubes" / "codegen.py").read_text() + "\n# an older generator\n")
    (old.parent / "jetgen.py").write_text((ROOT / "python" / "tubes" / "jetgen.py").read_text())
    p1 = run(tmp_path, "0.7*x^2" + P, env={"TUBES_CODEGEN": str(old)})
    p2 = run(tmp_path, "0.7*x^2" + P)
    assert p1.returncode == 0 and p2.returncode == 0, p1.stderr + p2.stderr
    assert "code generated" in p1.stdout and "code generated" in p2.stdout    # built twice, not a cache hit
    p3 = run(tmp_path, "0.7*x^2" + P)
    assert "loaded from the cache" in p3.stdout                              # the same generator: a hit


def test_a_deep_formula_found_by_the_fuzzer_is_refused_not_a_traceback():
    """tests/fuzz/fuzz_formula.py: the depth check named the column of an operator node, which
    has none (AttributeError: 'Load' object has no attribute 'col_offset')."""
    import sympy as sp
    sys.path.insert(0, str(ROOT / "python" / "tubes"))
    import codegen
    text = (ROOT / "tests" / "fuzz" / "corpus-formula" / "crash-deep-unary-column").read_text()
    syms = {n: sp.Symbol(n) for n in ("x", "y", "px", "py")}
    with pytest.raises(codegen.FormulaError, match=r"nested more than 100 levels deep at column \d+"):
        codegen.parse(text, "hamiltonian", syms, sp)
