"""Code generation for models written as formulas (docs/models.md, "Models from the input file").

tubes turns ``&model system = 'expression', hamiltonian = '...'`` (or a rolling ball's
``height = '...'``) into C: SymPy parses nothing here; this module parses the formula with Python's
own ``ast`` (a whitelist of operators and functions, columns for every message), builds the SymPy
expression, differentiates it (gradient, Hessian; the surface's third derivatives), shares common
subexpressions (``sympy.cse``) and prints C99. The C driver (src/io/tubes_expr.c) compiles the
result into a shared object, caches it and loads it; this module is run as a script by path,
``python codegen.py --out FILE < SPEC``, so it needs SymPy and nothing else from tubes.

SPEC (built by src/io/tubes_nml.f90, one item a line)::

    tubes-expression 1
    kind hamiltonian            (or: kind surface)
    expr <the formula>
    coordinates x y
    momenta px py               (hamiltonian only)
    constant a = 0.07           (any number, in order; a constant may use the earlier ones)

On a bad formula it writes ``<variable>\\t<message>`` lines on stderr (variable: hamiltonian,
height, coordinates, momenta, constants) and exits 1; the driver adds the file and line.
"""
import ast
import keyword
import re
import sys
import warnings

ABI = 1
MAX_DOF = 3

#: functions allowed in a formula, with their number of arguments
FUNCTIONS = {"sqrt": 1, "exp": 1, "log": 1, "sin": 1, "cos": 1, "tan": 1, "atan2": 2, "sinh": 1,
             "cosh": 1, "tanh": 1, "asin": 1, "acos": 1, "atan": 1}
#: functions refused, with the reason
REFUSED = {name: "is not differentiable where it switches (tubes needs the Hessian everywhere)"
           for name in ("abs", "Abs", "sign", "min", "max", "Min", "Max", "floor", "ceil", "round",
                        "heaviside", "Heaviside", "mod")}
NAMED = {"pi"}
#: words the formula parser (Python's ast) keeps for itself
RESERVED = set(keyword.kwlist)
NAME_RE = re.compile(r"[A-Za-z][A-Za-z0-9_]*\Z")

#: bounds on the work a formula may ask for (docs/models.md, "Limits"): its length in characters,
#: the nodes of its syntax tree and their nesting depth, the magnitude of a numeric exponent of a
#: non-constant base (SymPy expands such powers symbolically), log2 of a constant power's value
#: (about the largest double, 2^1024: a larger power is refused before it is computed), and the
#: nodes of the expressions after differentiation (counted before sharing subexpressions), and the
#: terms of a polynomial Hamiltonian once expanded (estimated before expanding)
MAX_CHARS = 20000
MAX_NODES = 20000
MAX_DEPTH = 100
MAX_POWER = 100
MAX_LOG2 = 1100
MAX_TREE = 2000000
MAX_TERMS = 20000


class FormulaError(Exception):
    """A message about one namelist variable."""

    def __init__(self, var, msg):
        super().__init__(f"{var}: {msg}")
        self.var = var
        self.msg = msg


def _caret(text):
    """The formula with ^ as ** and a map from its columns back to the user's (1-based)."""
    out, cols = [], []
    for i, ch in enumerate(text):
        if ch == "^":
            out.append("**")
            cols += [i + 1, i + 1]
        else:
            out.append(ch)
            cols.append(i + 1)
    cols.append(len(text) + 1)
    return "".join(out), cols


def _check_size(tree, var, col):
    """Refuse a syntax tree of more than MAX_NODES nodes or deeper than MAX_DEPTH (no recursion)."""
    stack, nodes = [(tree, 0, 0)], 0
    while stack:
        node, depth, off = stack.pop()
        off = getattr(node, "col_offset", off)   # an operator or a context node: its parent's column
        nodes += 1
        if nodes > MAX_NODES:
            raise FormulaError(var, f"has more than {MAX_NODES} terms, operators and numbers: a formula has at "
                                    f"most {MAX_NODES}")
        if depth > MAX_DEPTH:
            raise FormulaError(var, f"is nested more than {MAX_DEPTH} levels deep at column {col(off)}: a "
                                    f"formula nests at most {MAX_DEPTH}")
        for c in ast.iter_child_nodes(node):     # a chain a + b - c ... (or * /) is one level
            chain = (isinstance(node, ast.BinOp) and isinstance(c, ast.BinOp) and c is node.left
                     and _CHAIN.get(type(c.op), 0) == _CHAIN.get(type(node.op), -1))
            stack.append((c, depth if chain else depth + 1, off))


_CHAIN = {ast.Add: 1, ast.Sub: 1, ast.Mult: 2, ast.Div: 2}


#: the functions on floats, for the constant parts of a formula
_MATH = {"sqrt": "sqrt", "exp": "exp", "log": "log", "sin": "sin", "cos": "cos", "tan": "tan",
         "atan2": "atan2", "sinh": "sinh", "cosh": "cosh", "tanh": "tanh", "asin": "asin", "acos": "acos",
         "atan": "atan"}
_DOMAIN = {"sqrt": "an argument >= 0", "log": "an argument > 0", "asin": "an argument in [-1, 1]",
           "acos": "an argument in [-1, 1]", "atan2": "arguments not both 0"}


def _check_numbers(tree, var, col, segment, symbols, values):
    """Evaluate the constant parts of the formula (numbers, pi, constants) in floating point, before
    SymPy sees them: refuse a number that overflows, a division by zero, a function outside its
    domain (a complex value), and a power too large to compute (log2 of its value above MAX_LOG2,
    checked before computing it); refuse a numeric exponent above MAX_POWER of a non-constant base.
    Returns nothing; raises FormulaError naming the column."""
    import math

    def bad(node, what, allowed):
        raise FormulaError(var, f"'{segment(node)}' at column {col(node)} {what}: {allowed}")

    fin = "the constant parts of a formula must be finite real numbers"

    def ev(node):   # a float, or None where the value depends on a coordinate or momentum
        if isinstance(node, ast.Expression):
            return ev(node.body)
        if isinstance(node, ast.Constant):
            if type(node.value) not in (int, float):
                return None          # refused by build, with its message
            try:
                v = float(node.value)
            except OverflowError:
                v = math.inf
            if not math.isfinite(v):
                bad(node, "overflows a double (above 1.8e308)", fin)
            return v
        if isinstance(node, ast.Name):
            if node.id in values:
                return values[node.id]
            return math.pi if node.id == "pi" and node.id not in symbols else None
        if isinstance(node, ast.UnaryOp):
            v = ev(node.operand)
            return -v if v is not None and isinstance(node.op, ast.USub) else v
        if isinstance(node, ast.BinOp):
            a, b = ev(node.left), ev(node.right)
            if isinstance(node.op, ast.Pow):
                if a is None and b is not None and abs(b) > MAX_POWER:
                    bad(node, f"raises a formula to the power {b:g}",
                        f"the exponent of a non-constant base is at most {MAX_POWER} in magnitude (SymPy "
                        "expands such powers symbolically)")
                if a is None or b is None:
                    return None
                if a == 0 and b < 0:
                    bad(node, "divides by zero (0 to a negative power)", fin)
                if a < 0 and b != int(b):
                    bad(node, "is not a real number (a negative number to a non-integer power)", fin)
                if a != 0 and abs(b * math.log2(abs(a))) > MAX_LOG2:
                    e2 = b * math.log2(abs(a))
                    bad(node, f"is about 2^{e2:.3g}, too {'large' if e2 > 0 else 'small'}",
                        f"a constant power lies between 2^-{MAX_LOG2} and 2^{MAX_LOG2} (a double ends at "
                        "2^1024)")
                try:
                    v = a ** b
                except (OverflowError, ZeroDivisionError):
                    v = math.inf
            else:
                if a is None or b is None:
                    return None
                if isinstance(node.op, ast.Div) and b == 0:
                    bad(node, "divides by zero", fin)
                op = {ast.Add: lambda: a + b, ast.Sub: lambda: a - b, ast.Mult: lambda: a * b,
                      ast.Div: lambda: a / b}.get(type(node.op))
                if op is None:
                    return None      # refused by build, with its message
                v = op()
            if isinstance(v, complex) or not math.isfinite(v):
                bad(node, "overflows a double (above 1.8e308)", fin)
            return v
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in _MATH:
            args = [ev(a) for a in node.args]
            if node.keywords or len(args) != FUNCTIONS[node.func.id] or any(a is None for a in args):
                return None
            name = node.func.id
            if name == "atan2" and args[0] == 0 and args[1] == 0:
                bad(node, "is undefined (atan2(0, 0))", fin)
            try:
                v = getattr(math, _MATH[name])(*args)
            except ValueError:
                bad(node, "is not a real number", f"{name} needs {_DOMAIN.get(name, 'a finite argument')}; " + fin)
            except OverflowError:
                v = math.inf
            if not math.isfinite(v):
                bad(node, "overflows a double (above 1.8e308)", fin)
            return v
        for c in ast.iter_child_nodes(node):   # anything else: refused by build; check its parts
            ev(c)
        return None

    ev(tree)


def parse(text, var, symbols, sp, values=None):
    """The SymPy expression of formula `text`; symbols: name -> SymPy symbol or value; values: the
    constants' floating-point values (for checking the formula's constant parts)."""
    if not text.strip():
        raise FormulaError(var, "is empty: write the formula")
    if len(text) > MAX_CHARS:
        raise FormulaError(var, f"is {len(text)} characters long: a formula has at most {MAX_CHARS}")
    if "#" in text:    # Python's ast would read the rest as a comment and drop it
        raise FormulaError(var, f"'#' at column {text.index('#') + 1} is not allowed: a formula uses numbers, "
                                "names, ( ) + - * / ^ ** and the functions " + ", ".join(FUNCTIONS))
    src, cols = _caret(text)

    def col(node_or_offset):
        off = node_or_offset if isinstance(node_or_offset, int) else node_or_offset.col_offset
        return cols[min(max(off, 0), len(cols) - 1)]

    # a sum of n terms is a tree n deep: parsing it (and our recursive walks) needs a recursion limit
    # above MAX_NODES (Python 3.11 does not use the C stack for these)
    sys.setrecursionlimit(max(sys.getrecursionlimit(), 3 * MAX_NODES))
    try:
        with warnings.catch_warnings():   # a SyntaxWarning ("invalid decimal literal") on stderr would
            warnings.simplefilter("ignore")   # come before the message line the driver reads
            tree = ast.parse(src.strip() and src, mode="eval")
    except SyntaxError as e:
        if "digits" in (e.msg or ""):   # Python's advice (sys.set_int_max_str_digits) is not the user's
            raise FormulaError(var, "has an integer of more than 4300 digits: a number in a formula is at most "
                                    "1.8e308 (a double)")
        off = (e.offset or 1) - 1
        what = (e.msg or "invalid syntax").replace("invalid syntax. Perhaps you forgot a comma?",
                                                   "invalid syntax")
        raise FormulaError(var, f"syntax error at column {col(off)}: {what} (in '{text.strip()}')")
    except ValueError:     # an integer literal of more than 4300 digits (older Pythons)
        raise FormulaError(var, "has an integer of more than 4300 digits: a number in a formula is at most "
                                "1.8e308 (a double)")
    except (RecursionError, MemoryError):
        raise FormulaError(var, f"is nested too deeply: a formula nests at most {MAX_DEPTH} levels")
    _check_size(tree, var, col)
    def segment(node):   # the user's text of node
        return text[col(node) - 1:col(node.end_col_offset) - 1]

    _check_numbers(tree, var, col, segment, symbols, values or {})

    ops = {ast.Add: lambda a, b: a + b, ast.Sub: lambda a, b: a - b, ast.Mult: lambda a, b: a * b,
           ast.Div: lambda a, b: a / b, ast.Pow: lambda a, b: a**b}

    def build(node):
        if isinstance(node, ast.Expression):
            return build(node.body)
        if isinstance(node, ast.BinOp) and type(node.op) in ops:
            return ops[type(node.op)](build(node.left), build(node.right))
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
            v = build(node.operand)
            return -v if isinstance(node.op, ast.USub) else v
        if isinstance(node, ast.Constant) and type(node.value) in (int, float):
            return sp.Integer(node.value) if isinstance(node.value, int) else sp.Rational(repr(node.value))
        if isinstance(node, ast.Name):
            if node.id in symbols:
                return symbols[node.id]
            if node.id == "pi":
                return sp.pi
            if node.id in FUNCTIONS or node.id in REFUSED:
                raise FormulaError(var, f"'{node.id}' at column {col(node)} is a function: write {node.id}(...)")
            known = ", ".join(k for k in symbols) or "none"
            raise FormulaError(var, f"unknown symbol '{node.id}' at column {col(node)}: the symbols are "
                                    f"{known} (and pi)")
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name):
            name = node.func.id
            if name in REFUSED:
                raise FormulaError(var, f"function '{name}' at column {col(node)} {REFUSED[name]}: refused")
            if name not in FUNCTIONS:
                raise FormulaError(var, f"unknown function '{name}' at column {col(node)}: allowed "
                                        + ", ".join(FUNCTIONS) + "; powers are written ^ or **")
            if node.keywords or len(node.args) != FUNCTIONS[name]:
                raise FormulaError(var, f"{name} at column {col(node)} takes {FUNCTIONS[name]} argument"
                                        f"{'s' if FUNCTIONS[name] > 1 else ''}")
            args = [build(a) for a in node.args]
            return getattr(sp, name)(*args)
        what = {ast.Compare: "a comparison", ast.IfExp: "a conditional", ast.BoolOp: "a logical operator",
                ast.Attribute: "an attribute", ast.Subscript: "an index", ast.Lambda: "a lambda"}.get(
                    type(node), f"'{ast.unparse(node)}'")
        if isinstance(node, ast.BinOp):
            what = "the operator " + {ast.Mod: "%", ast.FloorDiv: "//", ast.BitXor: "^", ast.BitAnd: "&",
                                      ast.BitOr: "|", ast.MatMult: "@", ast.LShift: "<<",
                                      ast.RShift: ">>"}.get(type(node.op), "?")
        if isinstance(node, ast.Constant):
            what = f"the literal {node.value!r}"
        raise FormulaError(var, f"{what} at column {col(node)} is not allowed: a formula uses numbers, "
                                "names, + - * / ^ ** and the functions " + ", ".join(FUNCTIONS))

    return build(tree)


def _f64(text, sp):
    """A number written by the program as its exact bits, 'f64:' and 16 hex digits
    (src/models/tubes_models.f90 f64): the double, exactly, as a SymPy rational."""
    import struct
    try:
        v = struct.unpack(">d", bytes.fromhex(text[4:].strip()))[0]
    except ValueError:
        raise FormulaError("constants", f"'{text}' is not a number")
    return sp.Rational(v)


def read_spec(lines):
    spec = {"constants": []}
    if not lines or lines[0].strip() != f"tubes-expression {ABI}":
        raise SystemExit("codegen: the input is not a tubes-expression spec")
    for line in lines[1:]:
        key, _, rest = line.partition(" ")
        if key == "constant":
            spec["constants"].append(rest)
        elif key in ("coordinates", "momenta"):
            spec[key] = rest.split()
        elif key in ("kind", "expr", "gravity"):
            spec[key] = rest
        elif key == "jet":
            spec["jet"] = rest.split()
        elif key == "rolling":       # rolling resistance: sigma, v_reg^2 (src/models/tubes_hamiltonian.f90)
            spec["rolling"] = rest.split()
    return spec


def check_names(spec):
    """Names are identifiers, not functions or C words, and each is used once."""
    seen = {}
    items = [("coordinates", n) for n in spec["coordinates"]]
    items += [("momenta", n) for n in spec.get("momenta", [])]
    consts = []
    for k, c in enumerate(spec["constants"]):
        name, eq, value = c.partition("=")
        name = name.strip()
        if not eq or not value.strip():
            raise FormulaError("constants", f"constants({k + 1}) = '{c}' is not 'name = value'")
        items.append(("constants", name))
        consts.append((name, value.strip(), k + 1))
    for var, name in items:
        if not NAME_RE.match(name):
            raise FormulaError(var, f"'{name}' is not a name (a letter, then letters, digits or _)")
        if name in FUNCTIONS or name in REFUSED or name in NAMED:
            raise FormulaError(var, f"'{name}' is the name of a function or constant of formulas: choose another")
        if name in RESERVED:
            raise FormulaError(var, f"'{name}' is a reserved word of formulas (as in Python): choose "
                                    f"another, e.g. '{name}_'")
        if name in seen:
            raise FormulaError(var, f"'{name}' is named twice (in {seen[name]} and {var})")
        seen[name] = var
    return consts


class Printer:
    """SymPy's C99 printer, with small integer and half-integer powers as products and sqrt."""

    def __init__(self, sp):
        from sympy.printing.c import C99CodePrinter

        class P(C99CodePrinter):
            def _print_Pow(self, expr):
                b, e = expr.base, expr.exp
                if e.is_Integer and 2 <= abs(int(e)) <= 8:
                    prod = "*".join([self.parenthesize(b, 100)] * abs(int(e)))
                    return f"({prod})" if e > 0 else f"(1.0/({prod}))"
                if e == -1:
                    return f"(1.0/{self.parenthesize(b, 100)})"
                if e.is_Rational and e.q == 2 and abs(e.p) <= 9 and e != sp.Rational(1, 2):
                    n = abs(e.p) // 2
                    base = f"sqrt({self._print(b)})" + "".join(f"*{self.parenthesize(b, 100)}" for _ in range(n))
                    return f"({base})" if e > 0 else f"(1.0/({base}))"
                return super()._print_Pow(expr)

            def _print_Rational(self, expr):
                return f"({expr.p}.0/{expr.q}.0)"

            def _print_Integer(self, expr):
                return f"{int(expr)}.0"

        self.p = P()

    def __call__(self, e):
        return self.p.doprint(e)


def function(sp, pr, name, inputs, consts, outputs, comment):
    """One C function `void name(const double *in, double *out)`: out[k] = outputs[k]."""
    temps, reduced = sp.cse(outputs, symbols=sp.numbered_symbols("t_"), order="none")
    lines = [f"/* {comment} */", f"void {name}(const double *restrict in, double *restrict out) {{"]
    for k, s in enumerate(inputs):
        lines.append(f"  const double {s} = in[{k}];")
    for s, v in consts:
        lines.append(f"  const double {s} = {v!r};")
    for s, e in temps:
        lines.append(f"  const double {s} = {pr(e)};")
    for k, e in enumerate(reduced):
        lines.append(f"  out[{k}] = {pr(e)};")
    lines.append("}")
    return "\n".join(lines)


def _terms(sp, e, x):
    """An upper bound of the number of terms of sp.expand(e), without expanding it: the multinomial
    count of sums, products and positive integer powers; any other node (a function, a negative or
    fractional power) is one term, its arguments counted on their own (expand goes inside them);
    the largest count anywhere. For a polynomial, also at most the number of monomials of its degree."""
    from math import comb
    worst = [0]

    def walk(e):   # (terms, degree or None when not a polynomial)
        if not e.free_symbols & set(x):
            return 1, 0
        if e in x:
            return 1, 1
        if e.is_Add or e.is_Mul:
            parts = [walk(a) for a in e.args]
            if e.is_Add:
                t = sum(t for t, _ in parts)
                d = None if any(d is None for _, d in parts) else max(d for _, d in parts)
            else:
                t, d = 1, 0
                for ta, da in parts:
                    t, d = t * ta, (None if d is None or da is None else d + da)
        elif e.is_Pow and e.exp.is_Integer and e.exp > 0:
            tb, db = walk(e.base)
            k = int(e.exp)
            t, d = comb(tb + k - 1, k), (None if db is None else db * k)
        else:
            for a in e.args:
                walk(a)
            t, d = 1, None
        worst[0] = max(worst[0], t if d is None else min(t, comb(d + len(x), len(x))))
        return t, d

    walk(e)
    return worst[0]


def _is_zero(sp, e):
    """Whether e is identically zero, numerically: at 4 fixed points of its symbols (the
    coordinates, momenta and constants; points where e is singular are skipped), to 30 digits. A
    value clearly off zero proves it nonzero; zero at all four is taken as zero (a nonzero analytic
    function vanishes on a set of measure zero). Expanding it or sp.simplify, as before, took
    minutes on (x + y + px + py)^30, sqrt(x^2 + y^2 + px^2 + y^4 + py^2)^-3's third derivatives and
    sqrt(x^3 + y + px*pi + py^3)^-33 (the last two found by the fuzz target)."""
    import random
    if e == 0:
        return True
    syms = sorted(e.free_symbols, key=str)
    rng = random.Random(20261129)             # the same points in every run
    tried = 0
    for _ in range(12):
        # floats of 30 digits, not rationals: a rational to a rational power is worked out exactly
        # (its roots sought), which took minutes on (px^3 + ...)^(px^3/2)
        pt = {v: sp.Float(rng.randint(-997, 997), 30) / 1009 for v in syms}
        try:
            val = sp.N(e.subs(pt), 30)
            parts = [abs(sp.N(t.subs(pt), 30)) for t in (e.args if e.is_Add else (e,))]
        except (ZeroDivisionError, ValueError, TypeError):
            continue
        if not (val.is_real and val.is_finite and all(q.is_real and q.is_finite for q in parts)):
            continue                          # a singular point: inconclusive, take another
        tried += 1
        if abs(val) > sp.Float("1e-20") * (1 + sum(parts)):
            return False
        if tried == 4:
            break
    # zero at every point: zero (no sp.expand or sp.simplify: a small expression such as
    # sqrt(x^3 + y + px*pi + py^3)^-33 expands without bound, found by the fuzz target); no point
    # where it could be evaluated: not zero, the safe side
    return tried > 0


def reversor(sp, h, qs, ps, mons=None):
    """Signs r (2N) of a reversor x -> r x (q_i -> s_i q_i, p_i -> -s_i p_i) with H(r x) = H(x),
    the one with the most s_i = +1 (a natural system's (q, -p) first); zeros if none: symmetric
    periodic orbits are found with it (src/orbits/tubes_orbits.f90). mons: the exponents of a
    polynomial H's monomials in (q, p), if it is one (then H(r x) = H(x) when every monomial keeps
    its sign)."""
    from itertools import product
    n = len(qs)
    for signs in sorted(product((1, -1), repeat=n), key=lambda s: (s.count(-1), [-v for v in s])):
        if mons is not None:
            r = list(signs) + [-s for s in signs]
            if all(sum(e for e, ri in zip(m, r) if ri < 0) % 2 == 0 for m in mons):
                return r
            continue
        sub = {q: s * q for q, s in zip(qs, signs)}
        sub.update({p: -s * p for p, s in zip(ps, signs)})
        if _is_zero(sp, h.subs(sub, simultaneous=True) - h):
            return list(signs) + [-s for s in signs]
    return [0] * (2 * n)


def _check_expression(sp, h, var, names):
    """Refuse what SymPy made of the formula when it is not finite and real for real inputs (zoo,
    oo, nan, I: e.g. tan(pi/2), x/(x - x)) or has a power of a non-constant base above MAX_POWER
    (e.g. ((x + y)^30)^30, which SymPy folds into one power)."""
    for bad, what in ((sp.zoo, "an infinity of unknown sign (zoo)"), (sp.nan, "an undefined value (nan)"),
                      (sp.oo, "an infinity"), (-sp.oo, "an infinity"), (sp.I, "the imaginary unit")):
        if h.has(bad):
            raise FormulaError(var, f"is not finite and real: SymPy reduces it to an expression with {what}, "
                                    f"e.g. from a division by zero or tan(pi/2); a formula must be finite and "
                                    f"real for real coordinates and momenta")
    allowed = {getattr(sp, name) for name in FUNCTIONS if name != "sqrt"}
    for f in sorted(h.atoms(sp.Function), key=str):
        if f.func not in allowed:   # e.g. Abs: SymPy writes sqrt(u^2) as |u| for a real u
            shown = f.subs({s: sp.Symbol(n) for n, s in names.items()}, simultaneous=True)
            raise FormulaError(var, f"becomes {shown} in SymPy ({f.func.__name__}, e.g. |u| from sqrt(u^2)), which is "
                                    "not differentiable everywhere (tubes needs the Hessian everywhere): write "
                                    "the formula without it, e.g. sqrt(u^2 + eps^2) or u itself")
    for e in sp.preorder_traversal(h):
        if e.is_Pow and e.exp.is_Number and not e.base.is_Number and abs(e.exp) > MAX_POWER:
            raise FormulaError(var, f"has the power {e.exp} of a non-constant base: the exponent of a "
                                    f"non-constant base is at most {MAX_POWER} in magnitude (SymPy expands "
                                    "such powers symbolically)")


def _check_tree(outputs, var, what):
    """Refuse derivatives of more than MAX_TREE nodes in all (counted before SymPy shares their common
    subexpressions, and the count stops there: bounded work)."""
    import sympy as sp
    n = 0
    for e in outputs:
        for _ in sp.preorder_traversal(e):
            n += 1
            if n > MAX_TREE:
                raise FormulaError(var, f"is too large after differentiation: its {what} have more than "
                                        f"{MAX_TREE} nodes (the limit; write a smaller formula)")
    return n


def build(spec, sp):
    """The model of spec as SymPy: (kind, h, qs, ps, csyms, cvals); raises FormulaError."""
    kind = spec.get("kind")
    var = "height" if kind == "surface" else "hamiltonian"
    coords = spec.get("coordinates", [])
    moms = spec.get("momenta", [])
    if kind == "surface":
        if len(coords) != 2:
            raise FormulaError("coordinates", "a surface z = h(x, y) has two coordinates")
    else:
        if not 1 <= len(coords) <= MAX_DOF:
            raise FormulaError("coordinates", f"{len(coords)} coordinates: a model has 1 to {MAX_DOF} "
                                              "degrees of freedom")
        if len(moms) != len(coords):
            raise FormulaError("momenta", f"{len(moms)} momenta for {len(coords)} coordinates: give one "
                                          "momentum per coordinate, in the same order")
    consts = check_names(spec)
    # constants: each a number, or a formula of numbers and the constants before it
    csyms, cvals, table = {}, [], {}
    for name, text, k in consts:
        try:
            e = _f64(text, sp) if text.startswith("f64:") else parse(text, "constants", dict(table), sp,
                                                                     {n: float(val) for n, val in cvals})
        except FormulaError as err:
            raise FormulaError("constants", f"constants({k}): {name} = {text}: {err.msg}")
        # finite and of bounded size (parse checked its parts in floating point): sp.N is cheap
        v = sp.N(e.subs({csyms[n]: val for n, val in cvals}), 30)
        if not (v.is_real and v.is_finite):
            raise FormulaError("constants", f"constants({k}): {name} = {text} is not a finite real number")
        c_name = f"k_{name}"
        csyms[name] = sp.Symbol(c_name, real=True)
        cvals.append((name, v))
        table[name] = csyms[name]
    qs = [sp.Symbol(f"q_{k}", real=True) for k in range(len(coords))]
    ps = [sp.Symbol(f"p_{k}", real=True) for k in range(len(moms))]
    names = dict(zip(coords, qs))
    names.update(zip(moms, ps))
    names.update(table)
    h = parse(spec.get("expr", ""), var, names, sp, {n: float(val) for n, val in cvals})
    _check_expression(sp, h, var, names)
    free = h.free_symbols
    for n, s in list(zip(coords, qs)) + list(zip(moms, ps)):
        if s not in free:
            what = "coordinate" if s in qs else "momentum"
            raise FormulaError(var, f"the {what} '{n}' never appears in the formula")
    return kind, h, qs, ps, csyms, cvals


def generate(spec):
    """C source of the model in spec; raises FormulaError."""
    import sympy as sp

    kind, h, qs, ps, csyms, cvals = build(spec, sp)
    cdecl = [(str(csyms[n]), float(v)) for n, v in cvals]
    pr = Printer(sp)
    out = ["/* generated by python/tubes/codegen.py (docs/models.md): do not edit */",
           "#include <math.h>", "#ifndef M_PI", "#define M_PI 3.14159265358979323846", "#endif",
           f"const int tubes_expr_abi = {ABI};"]
    if kind == "surface":
        x = qs
        d1 = [sp.diff(h, a) for a in x]
        d2 = [sp.diff(h, a, b) for b in x for a in x]
        d3 = [sp.diff(h, a, b, c) for c in x for b in x for a in x]
        _check_tree([h] + d1 + d2 + d3, "height", "first, second and third derivatives")
        out += ["const int tubes_expr_kind = 2;", "const int tubes_expr_ndof = 2;",
                "const int tubes_expr_natural = 1;",
                function(sp, pr, "tubes_expr_height", x, cdecl, [h], "h(x, y)"),
                function(sp, pr, "tubes_expr_derivs", x, cdecl, d1 + d2,
                         "h_x, h_y, then the Hessian column by column"),
                function(sp, pr, "tubes_expr_third", x, cdecl, d3, "t3(i, j, k), Fortran order")]
        return "\n".join(out) + "\n", {"natural": True}
    x = qs + ps
    n = len(qs)
    grad = [sp.diff(h, a) for a in x]
    hess = [sp.diff(g, a) for a in x for g in grad]
    _check_tree([h] + grad + hess, "hamiltonian", "gradient and Hessian")
    field = grad[n:] + [-g for g in grad[:n]]
    zero = {p: 0 for p in ps}
    v = h.subs(zero)
    terms = _terms(sp, h, x)
    if terms > MAX_TERMS:
        raise FormulaError("hamiltonian", f"expands to about {terms} terms: a Hamiltonian has at most "
                                          f"{MAX_TERMS} once expanded (the limit; it is expanded to find its "
                                          "symmetry and whether it is natural)")
    if h.is_polynomial(*x):   # from its monomials: SymPy's diff and expand are slow on large sums
        mons = sp.Poly(h, *x).monoms()
        natural = all(sum(m[n:]) in (0, 2) for m in mons)    # H = V(q) + p^T A(q) p / 2
        t = sp.expand(h - v) if natural else None
    else:
        # H's derivatives in p are those of H - V: taken of H as written (expanding H - V first
        # took minutes on ((x + 4)/2 + x/y + px)^34 + py: found by the fuzz target); the kinetic
        # matrix of a natural H from the expansion, as before
        mons = None
        natural = all(_is_zero(sp, sp.diff(h, p).subs(zero)) for p in ps) and all(
            _is_zero(sp, sp.diff(h, a, b, c)) for a in ps for b in ps for c in ps)
        t = sp.expand(h - v) if natural else None
    rev = reversor(sp, h, qs, ps, mons)
    out += ["const int tubes_expr_kind = 1;", f"const int tubes_expr_ndof = {n};",
            f"const int tubes_expr_natural = {int(natural)};",
            "/* a time-reversal symmetry (q_i, p_i) -> (s_i q_i, -s_i p_i) of H, or zeros */",
            "const int tubes_expr_reversor[] = {" + ", ".join(str(r) for r in rev) + "};",
            function(sp, pr, "tubes_expr_energy", x, cdecl, [h], "H(q, p)"),
            function(sp, pr, "tubes_expr_field", x, cdecl, field, "dq/dt = dH/dp, dp/dt = -dH/dq"),
            function(sp, pr, "tubes_expr_gradient", x, cdecl, grad, "dH/dx"),
            function(sp, pr, "tubes_expr_hessian", x, cdecl, hess, "d2H/dx2, column by column")]
    if natural:
        vg = [sp.diff(v, a) for a in qs]
        vh = [sp.diff(g, a) for a in qs for g in vg]
        a = [sp.diff(t, pi, pj) for pj in ps for pi in ps]
        out += [function(sp, pr, "tubes_expr_shape", qs, cdecl, [v], "V(q) = H(q, 0)"),
                function(sp, pr, "tubes_expr_shape_derivs", qs, cdecl, vg + vh,
                         "grad V, then its Hessian column by column"),
                function(sp, pr, "tubes_expr_kinetic", qs, cdecl, a, "A(q) = d2H/dp2")]
    return "\n".join(out) + "\n", {"natural": natural}


class _Series:
    """Truncated power series in nv variables to total degree K, dense over the monomials (by
    degree), float coefficients: the arithmetic of automatic differentiation (Taylor mode).
    Products by degree blocks: the key sum_i e_i (K+1)^i of a product's monomial is the sum of
    the factors' keys (no carries below degree K+1)."""

    def __init__(self, nv, K):
        import itertools
        import numpy as np
        self.np, self.nv, self.K = np, nv, K
        mons = [m for d in range(K + 1) for m in itertools.product(range(d + 1), repeat=nv) if sum(m) == d]
        self.mons = mons
        base = (K + 1) ** np.arange(nv)
        self.keys = np.array([int(np.dot(m, base)) for m in mons], dtype=np.int64)
        self.lookup = np.full((K + 1) ** nv, -1, dtype=np.int64)
        self.lookup[self.keys] = np.arange(len(mons))
        deg = np.array([sum(m) for m in mons])
        self.blocks = [np.nonzero(deg == d)[0] for d in range(K + 1)]
        self.var = [np.eye(len(mons))[mons.index(tuple(int(i == k) for i in range(nv)))] for k in range(nv)]

    def const(self, c):
        v = self.np.zeros(len(self.mons))
        v[0] = c
        return v

    def mul(self, a, b):
        np = self.np
        out = np.zeros(len(self.mons))
        for da, ia in enumerate(self.blocks):
            xa = a[ia]
            if not xa.any():
                continue
            for db in range(self.K + 1 - da):
                ib = self.blocks[db]
                xb = b[ib]
                if not xb.any():
                    continue
                idx = self.lookup[self.keys[ia][:, None] + self.keys[ib][None, :]]
                np.add.at(out, idx.ravel(), np.outer(xa, xb).ravel())
        return out

    def compose(self, derivs, a):
        """f(a) = sum_k f^(k)(a0) / k! h^k, h = a - a0 (nilpotent), derivs = [f(a0), f'(a0), ...]."""
        h = a.copy()
        h[0] = 0.0
        out = self.const(derivs[0])
        p = self.const(1.0)
        fact = 1.0
        for k in range(1, self.K + 1):
            p = self.mul(p, h)
            fact *= k
            if not p.any():
                break
            out = out + (derivs[k] / fact) * p
        return out


def _taylor_ad(sp, h, z, point, order):
    """The Taylor coefficients of the SymPy expression h at point by automatic differentiation:
    h evaluated on truncated power series (exact up to rounding; the derivatives of the elementary
    functions at the point's value from SymPy)."""
    S = _Series(len(z), order)
    x = sp.Symbol("x_")
    cache = {}
    seeds = {zk: S.const(float(v)) + S.var[k] for k, (zk, v) in enumerate(zip(z, point))}

    def derivs(f, x0):
        e = f(x)
        out = []
        for _ in range(order + 1):
            out.append(float(e.subs(x, x0).evalf(30)))
            e = sp.diff(e, x)
        return out

    def ev(e):
        if e in cache:
            return cache[e]
        if e in seeds:
            r = seeds[e]
        elif e.is_Number:
            r = S.const(float(e))
        elif e.is_Add:
            r = sum((ev(a) for a in e.args), S.const(0.0))
        elif e.is_Mul:
            r = S.const(1.0)
            for a in e.args:
                r = S.mul(r, ev(a))
        elif e.is_Pow:
            b, p = e.args
            vb = ev(b)
            if p.is_Integer and p >= 0:
                r = S.const(1.0)
                for _ in range(int(p)):
                    r = S.mul(r, vb)
            else:
                if not (p.is_Number or p.is_NumberSymbol):
                    vp = ev(p)
                    r = ev(sp.exp(p * sp.log(b)))
                    cache[e] = r
                    return r
                pv = sp.nsimplify(p) if p.is_Float else p
                r = S.compose(derivs(lambda t: t ** pv, sp.Rational(repr(float(vb[0])))), vb)
        elif isinstance(e, sp.atan2):
            a, b = (ev(u) for u in e.args)
            a0, b0 = float(a[0]), float(b[0])
            num = S.mul(a, S.const(b0)) - S.mul(b, S.const(a0))
            den = S.mul(b, S.const(b0)) + S.mul(a, S.const(a0))
            inv = S.compose(derivs(lambda t: 1 / t, sp.Rational(repr(float(den[0])))), den)
            q = S.mul(num, inv)
            r = S.compose(derivs(sp.atan, 0), q)
            r[0] += float(sp.atan2(a0, b0))
        elif isinstance(e, sp.Function) and len(e.args) == 1:
            va = ev(e.args[0])
            r = S.compose(derivs(e.func, sp.Rational(repr(float(va[0])))), va)
        else:
            raise SystemExit(f"codegen: no Taylor arithmetic for {e.func}")
        cache[e] = r
        return r

    v = ev(h)
    return [(S.mons[i], float(v[i])) for i in range(len(S.mons)) if v[i] != 0]


def taylor(spec, point, order):
    """The Taylor expansion of the Hamiltonian of spec at point = (q, p) (floats, taken exactly) to
    total degree order: [(exponents of (dq, dp), coefficient)]. A polynomial H is expanded exactly
    (rational arithmetic, then rounded); any other by automatic differentiation (_taylor_ad: power
    series arithmetic on the formula's tree, exact up to rounding). No finite differences (the
    normal form, src/orbits/tubes_normal_form.f90)."""
    import sympy as sp

    kind, h, qs, ps, csyms, cvals = build(spec, sp)
    if kind == "surface":
        raise FormulaError("height", "a normal form needs a Hamiltonian (system = 'expression')")
    z = qs + ps
    if len(point) != len(z):
        raise SystemExit(f"codegen: {len(point)} coordinates given for {len(z)}")
    h = h.subs({csyms[n]: v for n, v in cvals})
    if h.is_polynomial(*z):
        d = [sp.Symbol(f"d_{k}") for k in range(len(z))]
        e = sp.expand(h.subs({zk: sp.Rational(float(x)) + dk for zk, x, dk in zip(z, point, d)}, simultaneous=True))
        out = []
        for mon, c in sp.Poly(e, *d).terms():
            v = float(sp.N(c, 30))
            if v != 0 and sum(mon) <= order:
                out.append((mon, v))
        return out
    return _taylor_ad(sp, h, z, point, order)


def ball_field(sp, h, q, p, g):
    """Hamilton's equations of a ball rolling on z = h(x, y) (src/models/tubes_ball.f90, the
    closed form: docs/theory.md): with s = grad h . p, D = 1 + |grad h|^2, u = s / D and
    v = ROLL (p - u grad h): dq/dt = v, dp/dt = u Hess(h) v - g grad h."""
    roll = sp.Rational(5, 7)
    grad = [sp.diff(h, a) for a in q]
    hess = [[sp.together(sp.diff(h, a, b)) for b in q] for a in q]
    u = sum(gi * pi for gi, pi in zip(grad, p)) / (1 + sum(gi**2 for gi in grad))
    v = [roll * (pi - u * gi) for pi, gi in zip(p, grad)]
    return v + [u * sum(hess[i][j] * v[j] for j in range(2)) - g * grad[i] for i in range(2)]


def ball_field_defs(sp, h, q, p, g):
    """ball_field as a straight-line program, for the fixed-order Taylor kernels: (fields, defs),
    defs [(symbol, expression)] in order: grad h, D, s, u, v (jetgen.decompose keeps the model's
    own quantities instead of SymPy's flattened formula), and Hess(h) v = d/dt grad h (v = dq/dt;
    jetgen's tubes_dt: the series of grad h one order ahead, no Hessian)."""
    roll = sp.Rational(5, 7)
    n = len(q)
    G = [sp.Symbol(f"jg_hx{i}", real=True) for i in range(n)]
    defs = [(G[i], sp.diff(h, q[i])) for i in range(n)]
    D, S, U = sp.symbols("jg_den jg_s jg_u", real=True)
    defs += [(D, 1 + sum(gi**2 for gi in G)), (S, sum(gi * pi for gi, pi in zip(G, p))), (U, S / D)]
    V = [sp.Symbol(f"jg_v{i}", real=True) for i in range(n)]
    defs += [(V[i], roll * (p[i] - U * G[i])) for i in range(n)]
    dt = sp.Function("tubes_dt")
    return V + [U * dt(G[i]) - g * G[i] for i in range(n)], defs


def jet_fields(spec, sp, structured=False):
    """The vector field of spec's model for its Taylor jet: (states, fields, params). The damping
    rate c (dp/dt -= c p, src/models/tubes_hamiltonian.f90 damped_t) is the parameter par[0], and
    with a 'rolling SIGMA VREG2' line the rolling drag's rate k = f sigma par[1];
    with `jet variational` the state transition matrix Phi (column by column) follows x, with
    dPhi/dt = (df/dx) Phi, with `tangent` one vector w, dw/dt = (df/dx) w
    (src/integrators/tubes_variational.f90), with `action` the integral of p . dq/dt. structured
    (fixed-order kernels, no variational or tangent): a ball's field as ball_field_defs, and
    (states, fields, params, defs) returned."""
    kind, h, qs, ps, csyms, cvals = build(spec, sp)
    h = h.subs({csyms[n]: v for n, v in cvals})
    c = sp.Symbol("c_damp", real=True)
    defs = []
    if kind == "surface":
        try:
            g = _f64(spec["gravity"], sp) if spec["gravity"].startswith("f64:") else sp.Rational(spec["gravity"])
        except (KeyError, ValueError, TypeError):
            raise FormulaError("g", "a ball's Taylor jet needs its gravity (spec line 'gravity')")
        ps = [sp.Symbol(f"p_{k}", real=True) for k in range(2)]
        if structured:
            f, defs = ball_field_defs(sp, h, qs, ps, g)
        else:
            f = ball_field(sp, h, qs, ps, g)
    else:
        x = qs + ps
        grad = [sp.diff(h, a) for a in x]
        n = len(qs)
        f = grad[n:] + [-gq for gq in grad[:n]]
    n = len(qs)
    f = f[:n] + [fp - c * pp for fp, pp in zip(f[n:], ps)]
    params = [c]
    if "rolling" in spec:   # dp/dt -= k p / sqrt(sigma p . dq/dt + v_reg^2), k = par[1] (damped_t)
        sig, vr2 = (_f64(v, sp) for v in spec["rolling"])
        k = sp.Symbol("k_roll", real=True)
        r = sp.sqrt(sig * sum(pp * qd for pp, qd in zip(ps, f[:n])) + vr2)
        f = f[:n] + [fp - k * pp / r for fp, pp in zip(f[n:], ps)]
        params = [c, k]
    x = qs + ps
    qdot = f[:n]
    if "variational" in spec.get("jet", []):
        m = len(x)
        phi = [[sp.Symbol(f"phi_{i}_{j}", real=True) for j in range(m)] for i in range(m)]
        jac = [[sp.diff(fi, xj) for xj in x] for fi in f]
        f = f + [sum(jac[i][l] * phi[l][j] for l in range(m) if jac[i][l] != 0)
                 for j in range(m) for i in range(m)]
        x = x + [phi[i][j] for j in range(m) for i in range(m)]
    if "tangent" in spec.get("jet", []):    # src/integrators/tubes_variational.f90 tangent_t
        m = len(x)
        w = [sp.Symbol(f"w_{i}", real=True) for i in range(m)]
        jac = [[sp.diff(fi, xj) for xj in x] for fi in f]
        f = f + [sum(jac[i][l] * w[l] for l in range(m) if jac[i][l] != 0) for i in range(m)]
        x = x + w
    if "action" in spec.get("jet", []):     # src/orbits/tubes_orbits.f90 action_field_t
        x = x + [sp.Symbol("action_", real=True)]
        f = f + [sum(pi * vi for pi, vi in zip(ps, qdot))]
    if structured:
        return x, f, params, defs
    return x, f, params


def generate_jet(spec):
    """C source of the Taylor jet of spec's model (python/tubes/jetgen.py): `jet order P lanes L`
    gives the straight-line kernel of order P for L lanes, `jet loops [variational] [tangent]
    [action]` the kernel of any order of the state and its extras."""
    import sympy as sp
    import jetgen

    words = spec.get("jet", [])
    if "loops" in words or "variational" in words or "tangent" in words:
        states, fields, params = jet_fields(spec, sp)
        d, outs = jetgen.decompose(sp, states, fields, params)
    else:
        states, fields, params, defs = jet_fields(spec, sp, structured=True)
        d, outs = jetgen.decompose(sp, states, fields, params, defs)
    head = ["/* generated by python/tubes/codegen.py --jet (docs/integrators-taylor.md): do not edit */",
            "#include <math.h>", "#ifndef M_PI", "#define M_PI 3.14159265358979323846", "#endif",
            f"const int tubes_jet_abi = {ABI};", f"const int tubes_jet_dim = {len(states)};"]
    if "loops" in words:
        src, info = jetgen.generate_loops(d, outs, "tubes_jet_loops", lanes=(1,))
        head += ["const int tubes_jet_order = 0;", "const int tubes_jet_lanes = 1;",
                 f"const int tubes_jet_nwork = {info['nodes']};"]
        src += ("int tubes_jet(int order, const double *restrict par, double *restrict tc, double *restrict w) "
                "{ return tubes_jet_loops_L1(order, par, tc, w); }\n")
    else:
        try:
            order = int(words[words.index("order") + 1])
            lanes = int(words[words.index("lanes") + 1])
        except (ValueError, IndexError):
            raise SystemExit("codegen: the jet spec needs 'jet order P lanes L' or 'jet loops [variational] [tangent] [action]'")
        if not (1 <= order <= 60 and lanes in (1, 2, 4, 8)):
            raise SystemExit(f"codegen: jet order {order} lanes {lanes}: order 1..60, lanes 1, 2, 4 or 8")
        src, info = jetgen.generate_scheduled(d, outs, "tubes_jet_fixed", order, lanes)
        head += [f"const int tubes_jet_order = {order};", f"const int tubes_jet_lanes = {lanes};",
                 "const int tubes_jet_nwork = 0;"]
        src += ("int tubes_jet(int order, const double *restrict par, double *restrict tc, double *restrict w) "
                f"{{ (void)w; return order == {order} ? tubes_jet_fixed(par, tc) : -2; }}\n")
    head.append(f"/* nodes: {info['nodes']} ({info['convolutions']} of O(k) per order, {info['linear']} linear) */")
    return "\n".join(head) + "\n" + src


def main(argv):
    """codegen.py --out FILE < SPEC (a model's library source), --jet FILE < SPEC (a Taylor kernel),
    --taylor FILE ORDER z1 .. z2N < SPEC ("e1 .. e2N coefficient" lines). Exit 0; 1 the formula
    (stderr "variable<TAB>message"); 2 usage; 3 no SymPy."""
    if len(argv) == 3 and argv[1] in ("--out", "--jet"):
        mode = argv[1]
    elif len(argv) >= 5 and argv[1] == "--taylor":
        mode = "--taylor"
    else:
        sys.stderr.write("usage: codegen.py --out FILE < SPEC, codegen.py --jet FILE < SPEC, "
                         "or codegen.py --taylor FILE ORDER z1 .. z2N < SPEC\n")
        return 2
    try:
        import sympy  # noqa: F401
    except ImportError:
        sys.stderr.write("-\tSymPy is not installed for this Python (" + sys.executable + "): run make deps\n")
        return 3
    try:
        return _main(argv, mode)
    except Exception as e:      # never a traceback: one line the driver prints (src/io/tubes_expr.c)
        msg = " ".join(str(e).split())[:300]
        sys.stderr.write(f"-\tinternal error in the code generator: {type(e).__name__}: {msg} (please report)\n")
        return 1


def _main(argv, mode):
    text = sys.stdin.read()
    spec = read_spec(text.splitlines())
    try:
        if mode == "--jet":
            out = generate_jet(spec) + f'const char tubes_jet_text[] = "{_c_string(text)}";\n'
        elif mode == "--taylor":
            terms = taylor(spec, [float(v) for v in argv[4:]], int(argv[3]))
            out = "".join(" ".join(str(m) for m in mon) + f" {c!r}\n" for mon, c in terms)
        else:
            # the whole spec, to tell a cached library from another model's (src/io/tubes_expr.c)
            out = generate(spec)[0] + f'const char tubes_expr_text[] = "{_c_string(text)}";\n'
    except FormulaError as e:
        sys.stderr.write(f"{e.var}\t{e.msg}\n")
        return 1
    except ValueError as e:
        if mode != "--jet":
            raise
        sys.stderr.write(f"-\t{e}\n")     # an operation without a recurrence
        return 1
    with open(argv[2], "w") as f:
        f.write(out)
    return 0


def _c_string(text):
    """text as the body of a C string literal (octal escapes for all but printable ASCII)."""
    return "".join(c if c.isascii() and c.isprintable() and c not in '"\\?' else f"\\{ord(c):03o}"
                   for c in text.encode("utf-8").decode("latin-1"))


if __name__ == "__main__":
    sys.exit(main(sys.argv))
