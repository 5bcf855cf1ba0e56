"""Fuzz the formula front end (python/tubes/codegen.py: parse, the checks of issue 39, the SymPy
expression, its derivatives and the C text) with Atheris; the C compiler is not run. Only
codegen.FormulaError may escape a formula: anything else (a traceback, a hang) is a finding.

    .venv/bin/python tests/fuzz/fuzz_formula.py -atheris_runs=1000000 tests/fuzz/corpus-formula

The input's bytes (at most 200, UTF-8) are the Hamiltonian of x, y, px, py with the constant
a = 0.5; an input whose first byte is '!' is a rolling ball's height h(x, y) instead. Each
distinct SymPy expression is checked once (SEEN), and one in 16 (FUZZ_FORMULA_DEEP) is differentiated
and printed too: that makes 10^6 runs practical (docs/development.md, "Fuzzing")."""
import os
import sys
import zlib

import atheris

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "python", "tubes"))
import sympy  # noqa: E402,F401  (not instrumented: the target is our front end, not SymPy)

with atheris.instrument_imports():
    import codegen

MAX_BYTES = 200
SEEN = set()
DEEP = int(os.environ.get("FUZZ_FORMULA_DEEP", "16"))


def TestOneInput(data: bytes) -> None:
    if len(data) > MAX_BYTES:
        return
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        return
    if "\n" in text or "\r" in text or "\0" in text:   # one spec line; the namelist reader keeps one line
        return
    if text.startswith("!"):
        spec = {"kind": "surface", "expr": text[1:], "coordinates": ["x", "y"], "constants": ["a = 0.5"]}
    else:
        spec = {"kind": "hamiltonian", "expr": text, "coordinates": ["x", "y"], "momenta": ["px", "py"],
                "constants": ["a = 0.5"]}
    try:
        h = codegen.build(dict(spec), sympy)[1]     # parse and check: every input
        if h in SEEN:      # the same SymPy expression (mutants differing in spaces or parentheses)
            return
        if len(SEEN) < 100000:
            SEEN.add(h)
        # derivatives and C text: each expression once, and only for one input in DEEP (chosen by
        # its bytes: the same input, the same path), since they cost 10-100 ms where the front end
        # costs well under 1 ms; FUZZ_FORMULA_DEEP=1 differentiates every new expression
        if zlib.crc32(data) % DEEP == 0:
            codegen.generate(spec)
    except codegen.FormulaError:
        pass


if __name__ == "__main__":
    atheris.Setup(sys.argv, TestOneInput)
    atheris.Fuzz()
