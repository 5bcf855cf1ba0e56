"""Taylor-series code from a model's formula (docs/integrators-taylor.md): the recurrences of
automatic differentiation in time, generated as C.

A vector field dx/dt = f(x) written with SymPy is decomposed into elementary operations (the
nodes, class Decomposition: linear combinations, products, squares, quotients, reciprocals,
square roots, real powers, exp, log, the trigonometric and hyperbolic functions and their
inverses, atan2, and the time derivative of a series one order ahead); each node's recurrence
for its k-th normalised Taylor coefficient u_k (u(t0 + s) = sum_k u_k s^k) from the lower ones is
written once per kernel kind below (_emit_node for the loop kernels, _sched_node for the
straight-line ones), and the kernel computes, order by order, every node's coefficient k and then
x_{k+1} = f_k / (k + 1). Sub-expressions are shared (sympy.cse, the model's own definitions, and
hash-consing of the nodes), expressions of the parameters alone are computed once per call, and a
quotient's and a power's division by the operand's constant term is a multiplication by its
reciprocal, computed once per call.

Two kernels (python/tubes/codegen.py --jet wraps either as tubes_jet(order, par, tc, w)):
- generate_scheduled: one order, L lanes, straight-line code, NAME(par, tc);
- generate_loops: any order, one lane, NAME_L1(order, par, tc, w) with w scratch of
  NAME_nwork * (order + 1) doubles (the extended states: variational, tangent, action).
tc holds x's coefficients, tc[(i*(order+1) + k)*L + l] for variable i, order k, lane l; the
caller fills k = 0 with the state, the kernel fills k = 1..order. par: the parameters (par[0] the
damping rate). Both return 0, or -1 if a coefficient is not finite.

Lanes: L trajectories at once, in lockstep; every lane does exactly the arithmetic of L = 1
(explicit fused multiply-adds, no other contraction, the same order of every sum), so a
trajectory's coefficients do not depend on the lane it is in or on L (tests/test_lanes.f90 and
tests/test_taylor.py check it bit for bit through the integrator).
"""

#: the loop kernels' (the variational equations') accumulators of a convolution sum: one (their
#: compile time matters more than their speed: they serve the orbits' few Newton iterations;
#: two independent fma chains ran ~1.5x faster and took 2.5x longer to compile)
NACC = 1


class Node:
    """One operation: kind, operands (node indices or constant names), and its own data."""

    def __init__(self, kind, args, data=None):
        self.kind, self.args, self.data = kind, tuple(args), data

    def key(self):
        return (self.kind, self.args, self.data if not isinstance(self.data, list) else tuple(self.data))


class Decomposition:
    """The nodes of a vector field: states are series 0..n-1 (in tc), nodes n.. are in w."""

    def __init__(self, sp, states, params):
        self.sp = sp
        self.states = list(states)
        self.stateset = set(states)
        self.params = list(params)
        self.nodes = []          # Node, index n + position
        self.node_memo = {}      # Node.key() -> series index
        self.expr_memo = {}      # SymPy expression -> ref
        self.consts = []         # (C name, C expression)
        self.const_memo = {}
        self.sym_ref = {}        # a cse symbol -> its ref
        self.series_syms = set(states)
        from sympy.printing.c import C99CodePrinter
        parsyms = {p: sp.Symbol(f"par[{i}]") for i, p in enumerate(self.params)}
        self.parsub = parsyms

        class P(C99CodePrinter):
            def _print_Rational(self, expr):
                return f"({expr.p}.0/{expr.q}.0)"

            def _print_Integer(self, expr):
                return f"{int(expr)}.0"

            def _print_Symbol(self, expr):
                return expr.name

        self.printer = P()

    # ------------------------------------------------------------ refs
    # a ref is ('s', index) for a series, ('c', C expression) for a constant of the call

    def n(self):
        return len(self.states)

    def const(self, e):
        """A constant of the call (no state in it) as a ref."""
        sp = self.sp
        if e.is_Number:
            v = float(e)
            return ("c", repr(v) if v != int(v) or abs(v) > 2**52 else f"{int(v)}.0")
        if e in self.const_memo:
            return self.const_memo[e]
        if e in self.sym_ref:
            return self.sym_ref[e]
        name = f"c{len(self.consts)}"
        csub = {s: sp.Symbol(r[1]) for s, r in self.sym_ref.items() if r[0] == "c"}
        self.consts.append((name, self.printer.doprint(e.subs(csub).subs(self.parsub))))
        r = ("c", name)
        self.const_memo[e] = r
        return r

    def add_node(self, kind, args, data=None):
        node = Node(kind, args, data)
        k = node.key()
        if k in self.node_memo:
            return ("s", self.node_memo[k])
        idx = self.n() + len(self.nodes)
        self.nodes.append(node)
        self.node_memo[k] = idx
        return ("s", idx)

    # ------------------------------------------------------------ conversion
    def is_const(self, e):
        return not (e.free_symbols & self.series_syms)

    def define(self, sym, e):
        """A shared sub-expression (sympy.cse's symbol) and its definition."""
        r = self.conv(e)
        self.sym_ref[sym] = r
        if r[0] == "s":
            self.series_syms.add(sym)

    def conv(self, e):
        if e in self.expr_memo:
            return self.expr_memo[e]
        r = self._conv(e)
        self.expr_memo[e] = r
        return r

    def lin(self, terms, offset=None):
        """sum coef * series (+ offset): terms [(coef ref or None, series ref)]."""
        terms = [(c, s) for c, s in terms]
        if not terms:
            return offset if offset is not None else ("c", "0.0")
        if len(terms) == 1 and terms[0][0] is None and offset is None:
            return terms[0][1]
        return self.add_node("lin", [s[1] for _, s in terms],
                             [c[1] if c is not None else None for c, _ in terms] + [offset[1] if offset else None])

    def scale(self, c, s):
        return self.lin([(c, s)])

    def mul2(self, a, b):
        if a == b:
            return self.add_node("sqr", [a[1]])
        x, y = sorted([a[1], b[1]])
        return self.add_node("mul", [x, y])

    def product(self, factors):
        """Product of series refs (a balanced tree)."""
        fs = sorted(factors, key=lambda r: r[1])
        while len(fs) > 1:
            nxt = [self.mul2(fs[i], fs[i + 1]) for i in range(0, len(fs) - 1, 2)]
            if len(fs) % 2:
                nxt.append(fs[-1])
            fs = nxt
        return fs[0]

    def ipow(self, s, n):
        """s^n, n >= 1, by squaring."""
        if n == 1:
            return s
        if n % 2 == 0:
            h = self.ipow(s, n // 2)
            return self.add_node("sqr", [h[1]])
        return self.mul2(self.ipow(s, n - 1), s)

    def _half_power(self, sb, m):
        """The factors of b^(m/2), m odd: sqrt(b) and b^((m-1)/2) (one sqrt for all the
        half-integer powers of b, instead of a pow node each)."""
        fs = [self.add_node("sqrt", [sb[1]])]
        if m > 1:
            fs.append(self.ipow(sb, (m - 1) // 2))
        return fs

    def _conv(self, e):
        sp = self.sp
        if self.is_const(e):
            return self.const(e)
        if e in self.stateset:
            return ("s", self.states.index(e))
        if e in self.sym_ref:
            return self.sym_ref[e]
        if e.is_Add:
            cpart = [a for a in e.args if self.is_const(a)]
            terms = []
            for a in e.args:
                if self.is_const(a):
                    continue
                c, rest = a.as_independent(*self.series_syms, as_Add=False)
                terms.append((None if c == 1 else self.const(c), self.conv(rest)))
            off = self.const(sp.Add(*cpart)) if cpart else None
            return self.lin(terms, off)
        if e.is_Mul:
            c, rest = e.as_independent(*self.series_syms, as_Add=False)
            num, den = [], []
            for a in sp.Mul.make_args(rest):
                if a.is_Pow and a.exp.is_Integer and a.exp < 0:
                    den.append(self.ipow(self.conv(a.base), int(-a.exp)))
                elif a.is_Pow and a.exp.is_Rational and a.exp.q == 2 and a.exp < 0 and not self.is_const(a.base):
                    den += self._half_power(self.conv(a.base), int(-a.exp.p))
                else:
                    num.append(self.conv(a))
            if den:
                d = self.product(den)
                if num:
                    r = self.add_node("div", [self.product(num)[1], d[1]])
                else:
                    return self.add_node("recip", [d[1]], self.const(c)[1])
            else:
                r = self.product(num)
            return r if c == 1 else self.scale(self.const(c), r)
        if e.is_Pow:
            b, x = e.args
            if self.is_const(x):
                sb = self.conv(b)
                if x.is_Integer and x > 0:
                    return self.ipow(sb, int(x))
                if x.is_Integer and x < 0:
                    return self.add_node("recip", [self.ipow(sb, int(-x))[1]], "1.0")
                if x == sp.Rational(1, 2):
                    return self.add_node("sqrt", [sb[1]])
                if x.is_Rational and x.q == 2:
                    fs = self._half_power(sb, abs(int(x.p)))
                    if x > 0:
                        return self.product(fs)
                    return self.add_node("recip", [self.product(fs)[1]], "1.0")
                return self.add_node("pow", [sb[1]], self.const(x)[1])
            return self.conv(sp.exp(x * sp.log(b)))
        if isinstance(e, sp.Function) and e.func.__name__ == "tubes_dt":
            # d/dt of a series (codegen's ball: Hess(h) v = d/dt grad h): coefficient k is
            # (k + 1) times the series' coefficient k + 1 (fixed-order kernels only)
            return self.add_node("deriv", [self.conv(e.args[0])[1]])
        if isinstance(e, sp.exp):
            return self.add_node("exp", [self.conv(e.args[0])[1]])
        if isinstance(e, sp.log):
            return self.add_node("log", [self.conv(e.args[0])[1]])
        if isinstance(e, (sp.sin, sp.cos)):
            a = self.conv(e.args[0])[1]
            s = self.add_node("sin", [a])
            c = self.add_node("cos", [a, s[1]])
            self.nodes[s[1] - self.n()].data = c[1]      # the pair: sin knows its cos
            return s if isinstance(e, sp.sin) else c
        if isinstance(e, (sp.sinh, sp.cosh)):
            a = self.conv(e.args[0])[1]
            s = self.add_node("sinh", [a])
            c = self.add_node("cosh", [a, s[1]])
            self.nodes[s[1] - self.n()].data = c[1]
            return s if isinstance(e, sp.sinh) else c
        if isinstance(e, (sp.tan, sp.tanh)):
            a = self.conv(e.args[0])[1]
            t = self.add_node(e.func.__name__, [a])
            w = self.add_node("aux", [t[1]], e.func.__name__)    # 1 + t^2 (tan), 1 - t^2 (tanh)
            self.nodes[t[1] - self.n()].data = w[1]
            return t
        if isinstance(e, (sp.atan, sp.asin, sp.acos)):
            a = e.args[0]
            w = {sp.atan: 1 + a**2, sp.asin: sp.sqrt(1 - a**2), sp.acos: sp.sqrt(1 - a**2)}[e.func]
            return self.add_node(e.func.__name__, [self.conv(a)[1], self.conv(w)[1]])
        if isinstance(e, sp.atan2):
            y, x = e.args
            sy, sx = self.conv(y), self.conv(x)
            if sy[0] == "c":          # a constant as a series (its higher coefficients are 0)
                sy = self.add_node("lin", [], [sy[1]])
            if sx[0] == "c":
                sx = self.add_node("lin", [], [sx[1]])
            return self.add_node("atan2", [sy[1], sx[1], self.conv(x**2 + y**2)[1]])
        raise ValueError(f"no Taylor recurrence for {e.func}")

    # ------------------------------------------------------------ cost
    def cost(self):
        """Convolution-type nodes (O(k) per order) and linear ones (O(1))."""
        conv = sum(1 for nd in self.nodes if nd.kind not in ("lin", "aux", "deriv"))
        return conv, len(self.nodes) - conv


def _emit_node(d, idx, nd, L):
    """C statements computing coefficient k of node idx (names U<i> are the series' pointers)."""
    u = f"U{idx}"
    A = lambda i, j: f"U{i}[({j})*{L} + l]"          # noqa: E731
    out = []
    loop = f"for (int l = 0; l < {L}; l++)"
    inv = f"R{idx}"                                   # a reciprocal kept by div, sqrt, pow, log, atan, ...
    acc_init = " ".join(f"double s{a} = 0.0;" for a in range(NACC))
    acc_sum = " + ".join(f"s{a}" for a in range(NACC))

    def conv_sum(lo, hi, term, step_var="j"):
        """s = sum_{j=lo}^{hi} term(j) with NACC accumulators (C code; lo, hi C expressions)."""
        lines = [f"{acc_init}", f"int {step_var} = {lo};"]
        body = " ".join(f"s{a} = {term(f'{step_var} + {a}', f's{a}')};" for a in range(NACC))
        if NACC > 1:
            lines.append(f"for (; {step_var} + {NACC - 1} <= {hi}; {step_var} += {NACC}) {{ {body} }}")
        lines.append(f"for (; {step_var} <= {hi}; {step_var}++) s0 = {term(step_var, 's0')};")
        lines.append(f"const double s = {acc_sum};")
        return lines

    def square_sum(t):
        """v = sum_{j=0}^{k} t_j t_{k-j} from s, the sum over j < k/2 (C code)."""
        return f"double v = 2.0*s; if ((k & 1) == 0) v = fma({A(t, 'k/2')}, {A(t, 'k/2')}, v);"

    def series(first, lo, hi, term, last):
        """Coefficient 0 by the C statement first, coefficient k > 0 by s = conv_sum(lo, hi, term)
        and then the statements last."""
        out.append(f"if (k == 0) {loop} {first}")
        out.append(f"else {loop} {{ " + " ".join(conv_sum(lo, hi, term)) + f" {last} }}")
        return out

    k = nd.kind
    a = nd.args
    if k == "lin":
        coefs = nd.data
        terms = []
        for c, s in zip(coefs[:-1], a):
            terms.append(A(s, "k") if c is None else f"{c} * {A(s, 'k')}")
        expr = " + ".join(terms) if terms else "0.0"
        out.append(f"{loop} {u}[k*{L} + l] = {expr};")
        if coefs[-1] is not None:
            out.append(f"if (k == 0) {loop} {u}[l] += {coefs[-1]};")
        return out
    if k == "mul":
        x, y = a
        body = conv_sum("0", "k", lambda j, s: f"fma({A(x, j)}, {A(y, f'k - ({j})')}, {s})")
        out.append(f"{loop} {{ " + " ".join(body) + f" {u}[k*{L} + l] = s; }}")
        return out
    if k == "sqr":
        x, = a
        body = conv_sum("0", "(k - 1) >> 1", lambda j, s: f"fma({A(x, j)}, {A(x, f'k - ({j})')}, {s})")
        out.append(f"{loop} {{ " + " ".join(body) + f" {square_sum(x)} {u}[k*{L} + l] = v; }}")
        return out
    if k in ("div", "recip"):
        if k == "div":
            x, y = a
            num0 = A(x, "k")
        else:
            y, = a
            num0 = None
        return series(f"{{ {inv}[l] = 1.0 / {A(y, 0)}; {u}[l] = {num0 if num0 else nd.data} * {inv}[l]; }}", "1", "k",
                      lambda j, s: f"fma(-{A(y, j)}, {A(idx, f'k - ({j})')}, {s})",
                      f"{u}[k*{L} + l] = ({num0 + ' + s' if num0 else 's'}) * {inv}[l];")
    if k == "sqrt":
        x, = a
        return series(f"{{ {u}[l] = sqrt({A(x, 0)}); {inv}[l] = 0.5 / {u}[l]; }}", "1", "(k - 1) >> 1",
                      lambda j, s: f"fma({A(idx, j)}, {A(idx, f'k - ({j})')}, {s})",
                      f"{square_sum(idx)} {u}[k*{L} + l] = ({A(x, 'k')} - v) * {inv}[l];")
    if k == "pow":
        x, = a
        al = nd.data
        return series(f"{{ {u}[l] = pow({A(x, 0)}, {al}); {inv}[l] = 1.0 / {A(x, 0)}; }}", "0", "k - 1",
                      lambda j, s: f"fma(({al}*(double)(k - ({j})) - (double)({j})) * {A(x, f'k - ({j})')}, {A(idx, j)}, {s})",
                      f"{u}[k*{L} + l] = s * {inv}[l] * RK[k];")
    if k in ("exp", "sin", "sinh", "cos", "cosh", "tan", "tanh"):
        # u' = v x': k u_k = sum_{j=1}^{k} j x_j v_{k-j}, v = u (exp), the partner sinh/cosh, sin/cos
        # (-sin for cos), w = 1 +- u^2 (tan, tanh)
        x = a[0]
        v = idx if k == "exp" else a[1] if k in ("cos", "cosh") else nd.data
        sign = "-" if k == "cos" else ""
        return series(f"{u}[l] = {k}({A(x, 0)});", "1", "k",
                      lambda j, s: f"fma((double)({j}) * {A(x, j)}, {A(v, f'k - ({j})')}, {s})",
                      f"{u}[k*{L} + l] = {sign}s * RK[k];")
    if k == "aux":   # w = 1 +- t^2 of tan/tanh t
        t, = a
        sign = "+" if nd.data == "tan" else "-"
        return series(f"{u}[l] = 1.0 {sign} {A(t, 0)}*{A(t, 0)};", "0", "(k - 1) >> 1",
                      lambda j, s: f"fma({A(t, j)}, {A(t, f'k - ({j})')}, {s})",
                      f"{square_sum(t)} {u}[k*{L} + l] = {sign}v;")
    if k in ("log", "atan", "asin", "acos"):
        # w u' = x': k u_k w_0 = k x_k - sum_{j=1}^{k-1} j u_j w_{k-j}, w = x (log), 1 + x^2 (atan),
        # sqrt(1 - x^2) (asin; acos = -asin + const)
        x, w = (a[0], a[0]) if k == "log" else a
        sign = "-" if k == "acos" else ""
        return series(f"{{ {u}[l] = {k}({A(x, 0)}); {inv}[l] = 1.0 / {A(w, 0)}; }}", "1", "k - 1",
                      lambda j, s: f"fma((double)({j}) * {A(idx, j)}, {A(w, f'k - ({j})')}, {s})",
                      f"{u}[k*{L} + l] = ({sign}{A(x, 'k')} - s * RK[k]) * {inv}[l];")
    if k == "atan2":
        y, x, w = a
        out.append(f"if (k == 0) {loop} {{ {u}[l] = atan2({A(y, 0)}, {A(x, 0)}); {inv}[l] = 1.0 / {A(w, 0)}; }}")
        # k c_k w_0 = sum_{j=0}^{k-1} (k-j) (x_j y_{k-j} - y_j x_{k-j}) - sum_{j=1}^{k-1} j c_j w_{k-j}
        body = conv_sum("0", "k - 1", lambda j, s: f"fma((double)(k - ({j})), {A(x, j)}*{A(y, f'k - ({j})')} - {A(y, j)}*{A(x, f'k - ({j})')}, {s})")
        body2 = [b.replace("const double s =", "const double r =").replace("s0", "t0").replace("s1", "t1")
                 for b in conv_sum("1", "k - 1", lambda j, s: f"fma((double)({j}) * {A(idx, j)}, {A(w, f'k - ({j})')}, {s})", "i")]
        out.append(f"else {loop} {{ " + " ".join(body) + " " + " ".join(body2) + f" {u}[k*{L} + l] = (s - r) * RK[k] * {inv}[l]; }}")
        return out
    raise ValueError(k)


def _cancel_powers(sp, e):
    """A sum times a negative power b^-a of a base b that the sum's terms have a positive power of:
    distributed, so that the powers of b combine ((c b^(3/2) - d) b^(-3/2) = c - d b^(-3/2))."""
    if not e.args or e.is_Atom:
        return e
    args = [_cancel_powers(sp, a) for a in e.args]
    e = e.func(*args) if any(a is not b for a, b in zip(args, e.args)) else e
    if not e.is_Mul:
        return e
    bases = [f.base for f in e.args if f.is_Pow and f.exp.is_Number and f.exp < 0]
    if not bases:
        return e
    for f in e.args:
        if f.is_Add and any(p.is_Pow and p.base in bases and p.exp.is_Number and p.exp > 0
                            for t in f.args for p in sp.Mul.make_args(t)):
            rest = sp.Mul(*[g for g in e.args if g is not f])
            return sp.Add(*[_cancel_powers(sp, t * rest) for t in f.args])
    return e


def decompose(sp, states, fields, params, defs=()):
    """The decomposition of dx/dt = fields(states; params) and the refs of the fields. defs: the
    model's own intermediate quantities [(symbol, expression)], in order, that the fields are
    written with (codegen.ball_field_defs): their structure is kept (no sympy.cse; common
    sub-expressions are shared by hash-consing)."""
    d = Decomposition(sp, states, params)
    fields = [_cancel_powers(sp, f) for f in fields]
    if defs:
        for s, e in defs:
            d.define(s, _cancel_powers(sp, e))
        return d, [d.conv(f) for f in fields]
    reps, reduced = sp.cse(fields, symbols=sp.numbered_symbols("cse_"), order="none")
    for s, e in reps:
        d.define(s, e)
    outs = [d.conv(f) for f in reduced]
    return d, outs


def generate_loops(d, outs, name, lanes=(1,)):
    """C source of NAME_L<L>(order, par, tc, w) for any order (loops over the orders and the
    convolutions), and NAME_nwork. Returns (source, info)."""
    n = d.n()
    m = len(d.nodes)
    inv_nodes = [n + i for i, nd in enumerate(d.nodes) if nd.kind in ("div", "recip", "sqrt", "pow", "log", "atan", "asin", "acos", "atan2")]
    src = []
    for L in lanes:
        fn = f"{name}_L{L}"
        src.append(f"int {fn}(int order, const double *restrict par, double *restrict tc, double *restrict w) {{")
        src.append("  const int S = order + 1;")
        src.append("  double RK[64];   /* 1/k */")
        src.append("  if (order < 1 || order > 62) return -2;")
        src.append("  RK[0] = 0.0; for (int k = 1; k <= order; k++) RK[k] = 1.0 / (double)k;")
        for cn, ce in d.consts:
            src.append(f"  const double {cn} = {ce};")
        for i in range(n):
            src.append(f"  double *restrict U{i} = tc + {i}*S*{L};")
        for i in range(m):
            src.append(f"  double *restrict U{n + i} = w + {i}*S*{L};")
        for i in inv_nodes:
            src.append(f"  double R{i}[{L}];")
        src.append("  for (int k = 0; k < order; k++) {")
        for i, nd in enumerate(d.nodes):
            for line in _emit_node(d, n + i, nd, L):
                src.append("    " + line)
        for i, r in enumerate(outs):
            if r[0] == "s":
                src.append(f"    for (int l = 0; l < {L}; l++) U{i}[(k + 1)*{L} + l] = U{r[1]}[k*{L} + l] * RK[k + 1];")
            else:
                src.append(f"    for (int l = 0; l < {L}; l++) U{i}[(k + 1)*{L} + l] = k == 0 ? {r[1]} : 0.0;")
        src.append("  }")
        src.append(f"  for (int i = 0; i < {n}; i++) for (int k = order - 1; k <= order; k++) for (int l = 0; l < {L}; l++)")
        src.append(f"    if (!isfinite(tc[(i*S + k)*{L} + l])) return -1;")
        src.append("  return 0;")
        src.append("}")
    src.append(f"const int {name}_nwork = {m};")
    conv, lin = d.cost()
    return "\n".join(src) + "\n", {"nodes": m, "convolutions": conv, "linear": lin}


# ---------------------------------------------------------------- scheduled (one order)

#: latencies of the operations [cycles], for the shape of the sums only (a model of a current x86
#: core; the emitted order is a topological order whatever the numbers)
LAT = {"fma": 4, "mul": 4, "add": 3, "neg": 1, "div": 13, "sqrt": 18, "call": 60, "mov": 0,
       "load": 4, "const": 0, "vdot": 16, "st": 0, "str": 0, "bar": 0}

#: a sum's terms whose coefficients are all at least SIMD_AGE orders old go 4 at a time (VDOT), if
#: there are at least SIMD_MIN of them (0: never)
SIMD_AGE = 1
SIMD_MIN = 4

#: one lane: the ops of two nodes of the same shape (x and y of a symmetric model) go together in
#: the two halves of a vector register
PAIRS = True


def _num(x):
    """The value of a numeric constant CST(<float>), or None."""
    if isinstance(x, str) and x.startswith("CST(") and x.endswith(")"):
        try:
            return float(x[4:-1])
        except ValueError:
            return None
    return None


def _cst(v):
    return f"CST({float(v)!r})"


def _is_const(x):
    return x == "ZERO" or x.startswith("CST(")


def _is_mem(x):
    return x.startswith("M:")


def _mem(x):
    _, i, j = x.split(":")
    return int(i), int(j)


class Op:
    """One operation: kind, destination name (or None), operands (names, M:<series>:<order>
    memory references, CST(..) constants; ints for vdot and the stores)."""
    __slots__ = ("kind", "dst", "args", "node", "seg")

    def __init__(self, kind, dst, args, node, seg):
        self.kind, self.dst, self.args, self.node, self.seg = kind, dst, list(args), node, seg


class Ops:
    """Straight-line code in program order, with ready times (LAT). Every product that is added is
    an explicit FMA and no product is an operand of an addition, so that the compiler has nothing
    to contract (the same numbers with -ffp-contract=fast or off), and every lane of L > 1 does the
    arithmetic of L = 1."""

    def __init__(self):
        self.ops = []
        self.ready = {}
        self.prod = {}       # name -> (a, b) for the products
        self.seq = 0
        self.node = None
        self.seg = 0

    def rt(self, x):
        return self.ready.get(x, 0)

    def emit(self, kind, args, dst=None, lat=None):
        if dst is None:
            dst = f"t{self.seq}"
            self.seq += 1
        names = [a for a in args if isinstance(a, str)]
        self.ready[dst] = max([self.rt(a) for a in names], default=0) + LAT[lat or kind]
        self.ops.append(Op(kind, dst, args, self.node, self.seg))
        return dst

    def store(self, kind, i, j, v):
        self.ops.append(Op(kind, None, [i, j, v], self.node, self.seg))

    def barrier(self):
        self.ops.append(Op("bar", None, [], None, self.seg))
        self.seg += 1

    def mul(self, a, b, dst=None):
        v = self.emit("mul", [a, b], dst)
        self.prod[v] = (a, b)
        return v

    def fma(self, a, b, c, dst=None):
        return self.emit("fma", [a, b, c], dst)

    def add(self, a, b, dst=None):
        for x, y in ((a, b), (b, a)):       # a product is never an operand of an addition
            if x in self.prod:
                return self.fma(self.prod[x][0], self.prod[x][1], y, dst)
        return self.emit("add", [a, b], dst)

    def neg(self, a, dst=None):
        return self.emit("neg", [a], dst)

    def mov(self, a, dst):
        v = self.emit("mov", [a], dst)
        if a in self.prod:
            self.prod[v] = self.prod[a]
        return v

    def once(self, name, fn):
        """A number of the call, defined once (fn(name) emits it)."""
        if name not in self.ready:
            fn(name)
        return name

    # a partial sum: ("v", name) or ("p", a, b), a product not yet emitted
    def mat(self, acc):
        return acc[1] if acc[0] == "v" else self.mul(acc[1], acc[2])

    def acc_ready(self, acc):
        return self.rt(acc[1]) if acc[0] == "v" else max(self.rt(acc[1]), self.rt(acc[2])) + LAT["mul"]

    def addacc(self, x, y):
        if x[0] == "p" and y[0] == "p":
            y = ("v", self.mat(y))
        if x[0] == "p":
            x, y = y, x
        if y[0] == "p":
            return ("v", self.fma(y[1], y[2], x[1]))
        return ("v", self.add(x[1], y[1]))

    def dot(self, terms, init=None, dst=None):
        """sum of products a*b (+ init): one chain of fma from the oldest terms to the newest (a
        term with the factor CST(1.0) is an addition). Returns a name, or None for an empty sum."""
        items = sorted(terms, key=lambda t: max(self.rt(t[0]), self.rt(t[1])))
        acc = ("v", init) if init is not None else None
        for a, b in items:
            if _num(a) == 1.0:
                a, b = b, a
            if _num(b) == 1.0:
                acc = ("v", a) if acc is None else self.addacc(acc, ("v", a))
            elif acc is None:
                acc = ("p", a, b)
            else:
                acc = ("v", self.fma(a, b, self.mat(acc)))
        if acc is None:
            return self.emit("const", ["ZERO"], dst) if dst else None
        v = self.mat(acc)
        return self.mov(v, dst) if dst else v

    def twice(self, init, terms, mid=None):
        """2 (init + sum a*b) (+ mid^2): a square's sum from its symmetric half."""
        h = self.dot(terms, init=init)
        s = self.mul(h, _cst(2.0)) if h else None
        if mid is not None:
            s = self.fma(mid, mid, s) if s else self.mul(mid, mid)
        return s


def _sched_node(o, idx, nd, k, V, dst, cv):
    """Ops for coefficient k of node idx, named dst. V(i, j) is coefficient j of series i (a name,
    or a memory reference for the older orders); cv(A, B, lo, hi, k) is sum_{j=lo}^{hi} A_j
    B_{k-j} as (a partial sum of its older terms or None, the other terms)."""
    kind, a = nd.kind, nd.args
    R = f"R{idx}"
    C = lambda v: f"CST({v})"                          # noqa: E731

    def fin(v):
        return o.mov(v, dst) if v is not None else o.emit("const", ["ZERO"], dst)

    if kind == "deriv":                                  # u_k = (k + 1) x_{k+1}
        x, = a
        o.mul(V(x, k + 1), _cst(k + 1), dst)
        return
    if kind == "lin":
        coefs = nd.data
        terms = [(V(s, k), C(c) if c is not None else _cst(1.0)) for c, s in zip(coefs[:-1], a)]
        fin(o.dot(terms, init=C(coefs[-1]) if coefs[-1] is not None and k == 0 else None))
        return
    if kind == "mul":
        x, y = a
        init, terms = cv(x, y, 0, k, k)
        fin(o.dot(terms, init=init))
        return
    if kind in ("sqr", "aux"):
        x, = a
        if k == 0:
            x0 = V(x, 0)
            o.once(f"D{idx}", lambda nm: o.add(x0, x0, nm))
            if kind == "sqr":
                o.mul(x0, x0, dst)
            elif nd.data == "tan":
                o.fma(x0, x0, C("1.0"), dst)
            else:
                o.fma(o.neg(x0), x0, C("1.0"), dst)
            return
        s = o.twice(*cv(x, x, 1, (k - 1) // 2, k), V(x, k // 2) if k % 2 == 0 else None)
        if kind == "aux" and nd.data == "tanh":      # - (s + 2 x_0 x_k)
            E = o.once(f"E{idx}", lambda nm: o.neg(f"D{idx}", nm))
            fin(o.dot([(V(x, k), E)], init=o.neg(s) if s else None))
        else:
            fin(o.dot([(V(x, k), f"D{idx}")], init=s))
        return
    if kind in ("div", "recip"):
        y = a[-1]
        if k == 0:
            y0 = V(y, 0)
            o.emit("div", [C("1.0"), y0], R)
            num = V(a[0], 0) if kind == "div" else C(nd.data)
            o.mul(num, R, dst)
            o.once(f"N{idx}", lambda nm: o.neg(R, nm))
            o.once(f"M{idx}", lambda nm: o.neg(o.mul(dst, R), nm))     # -u_0 / y_0
            return
        # u_k = (a_k - sum_{j=1}^{k} y_j u_{k-j}) / y_0: the old terms, then a_k and y_k
        init, terms = cv(y, idx, 1, k - 1, k)
        s = o.dot(terms, init=init)
        pre = o.mul(s, f"N{idx}") if s else None
        terms = [(V(y, k), f"M{idx}")] + ([(V(a[0], k), R)] if kind == "div" else [])
        fin(o.dot(terms, init=pre))
        return
    if kind == "sqrt":
        x, = a
        if k == 0:
            o.emit("sqrt", [V(x, 0)], dst)
            o.emit("div", [C("0.5"), dst], R)
            o.once(f"N{idx}", lambda nm: o.neg(R, nm))
            return
        s = o.twice(*cv(idx, idx, 1, (k - 1) // 2, k), V(idx, k // 2) if k % 2 == 0 else None)
        pre = o.mul(s, f"N{idx}") if s else None
        fin(o.dot([(V(x, k), R)], init=pre))
        return
    if kind == "pow":
        x, = a
        al = nd.data
        if k == 0:
            o.emit("call", ["POW", V(x, 0), C(al)], dst)
            o.emit("div", [C("1.0"), V(x, 0)], R)
            o.once(f"A{idx}", lambda nm: o.mul(o.mul(C(al), dst), R, nm))          # alpha u_0 / x_0
            return
        # k x_0 u_k = sum_{j=0}^{k-1} (alpha (k-j) - j) x_{k-j} u_j; j = 0 (x_k) last
        terms = [(o.mul(C(f"{al}*{float(k - j)!r} - {float(j)!r}"), V(x, k - j)), V(idx, j)) for j in range(1, k)]
        s = o.dot(terms)
        pre = o.mul(s, o.mul(R, _cst(1.0 / k))) if s else None
        fin(o.dot([(V(x, k), f"A{idx}")], init=pre))
        return
    if kind in ("exp", "sin", "sinh", "cos", "cosh", "tan", "tanh"):
        x = a[0]
        other = {"exp": idx, "cos": a[-1], "cosh": a[-1]}.get(kind, nd.data)
        if k == 0:
            o.emit("call", [kind.upper(), V(x, 0)], dst)
            return
        sg = -1.0 if kind == "cos" else 1.0
        # u_k = (1/k) sum_{j=1}^{k} j x_j o_{k-j} (cos: minus); j = k (x_k o_0) last
        terms = [(o.mul(_cst(sg * j / k), V(x, j)), V(other, k - j)) for j in range(1, k)]
        pre = o.dot(terms)
        o0 = V(other, 0)
        if sg < 0:
            o0 = o.once(f"N{idx}", lambda nm: o.neg(V(other, 0), nm))
        fin(o.dot([(V(x, k), o0)], init=pre))
        return
    if kind in ("log", "atan", "asin", "acos"):
        x = a[0]
        w = x if kind == "log" else a[1]
        if k == 0:
            o.emit("call", [kind.upper(), V(x, 0)], dst)
            o.emit("div", [C("1.0"), V(w, 0)], R)
            o.once(f"N{idx}", lambda nm: o.neg(R, nm))
            return
        # w_0 u_k = (+-) x_k - (1/k) sum_{j=1}^{k-1} j u_j w_{k-j}
        terms = [(o.mul(_cst(-j / k), V(idx, j)), V(w, k - j)) for j in range(1, k)]
        s = o.dot(terms)
        pre = o.mul(s, R) if s else None
        fin(o.dot([(V(x, k), f"N{idx}" if kind == "acos" else R)], init=pre))
        return
    if kind == "atan2":
        y, x, w = a
        if k == 0:
            o.emit("call", ["ATAN2", V(y, 0), V(x, 0)], dst)
            o.emit("div", [C("1.0"), V(w, 0)], R)
            return
        # k u_k w_0 = sum_{j=0}^{k-1} (k-j) (x_j y_{k-j} - y_j x_{k-j}) - sum_{j=1}^{k-1} j u_j w_{k-j}
        terms = []
        for j in range(k):
            terms += [(o.mul(_cst((k - j) / k), V(x, j)), V(y, k - j)),
                      (o.mul(_cst(-(k - j) / k), V(y, j)), V(x, k - j))]
        for j in range(1, k):
            terms.append((o.mul(_cst(-j / k), V(idx, j)), V(w, k - j)))
        o.mul(o.dot(terms), R, dst)
        return
    raise ValueError(kind)


def _series_args(nd):
    """(series needed at orders <= k, series needed at orders < k, series needed at order k+1) by
    a node's coefficient k."""
    kind, a = nd.kind, list(nd.args)
    if kind == "deriv":
        return [], [], a
    if kind in ("sin", "sinh", "tan", "tanh"):
        return a, [nd.data], []
    return a, [], []


def _rev_operand(d, i, nd):
    """The series of a node's sum read backwards (B of sum_j A_j B_{k-j}), or None."""
    if nd.kind == "mul":
        return nd.args[1]
    if nd.kind in ("sqr", "aux"):
        return nd.args[0]
    if nd.kind in ("div", "recip", "sqrt"):
        return d.n() + i
    return None


def _partners(d, outs):
    """Series that can go in pairs: two series of the same shape (colour refinement on the graph of
    the nodes and the states' fields), each pair's arguments position by position the same series
    or partners. {series: partner}."""
    n = d.n()
    tot = n + len(d.nodes)

    def base(i):
        if i < n:
            r = outs[i]
            return ("state", r[0], r[1] if r[0] == "c" else None)
        nd = d.nodes[i - n]
        return (nd.kind, repr(nd.data) if nd.kind not in ("sin", "sinh", "tan", "tanh", "cos", "cosh") else None)

    def deps(i):
        if i < n:
            r = outs[i]
            return [r[1]] if r[0] == "s" else []
        nd = d.nodes[i - n]
        le, lt, nx = _series_args(nd)
        return le + lt + nx

    col = {i: hash(base(i)) for i in range(tot)}
    for _ in range(tot):
        new = {i: hash((col[i], tuple(col[j] for j in deps(i)))) for i in range(tot)}
        if len(set(new.values())) == len(set(col.values())):
            col = new
            break
        col = new
    groups = {}
    for i in range(tot):
        groups.setdefault(col[i], []).append(i)
    part = {}
    for g in groups.values():
        if len(g) == 2:
            part[g[0]], part[g[1]] = g[1], g[0]
    # each pair's arguments: the same series or partners (else the pair is dropped), to a fixpoint
    changed = True
    while changed:
        changed = False
        for a in list(part):
            b = part.get(a)
            if b is None or a > b:
                continue
            da, db = deps(a), deps(b)
            ok = len(da) == len(db) and all(x == y or part.get(x) == y for x, y in zip(da, db))
            if a >= n and ok:
                na, nb = d.nodes[a - n], d.nodes[b - n]
                if na.kind in ("sin", "sinh", "tan", "tanh", "cos", "cosh"):
                    ok = False           # (their pairs' data refer to each other; not paired)
            if not ok:
                del part[a], part[b]
                changed = True
    return part


def _types(L):
    """The vector types and their fused multiply-add (each lane rounded as fma() rounds): vd2 for
    one lane's pairs, vdL for L lanes (L = 8 without AVX-512: two 4-lane halves)."""
    out = ["#include <math.h>"]
    ws = [2] if L == 1 else [L]
    for w in ws:
        out += [f"#ifndef TUBES_JET_VD{w}", f"#define TUBES_JET_VD{w}"]
        out += [f"typedef double vd{w} __attribute__((vector_size({8 * w})));"] + \
            (["typedef double vd4_ __attribute__((vector_size(32)));"] if w == 8 else [])
        out += [
                f"typedef double vd{w}u __attribute__((vector_size({8 * w}), aligned(8)));"]
        lane = f"{{ vd{w} r; for (int l = 0; l < {w}; l++) r[l] = fma(a[l], b[l], c[l]); return r; }}"
        if w == 2:
            out += ["static inline vd2 vsqrt2_(vd2 a) { return (vd2){sqrt(a[0]), sqrt(a[1])}; }"]
            out += ["#if defined(__FMA__)", "#include <immintrin.h>",
                    "static inline vd2 vfma2(vd2 a, vd2 b, vd2 c) { return (vd2)_mm_fmadd_pd((__m128d)a, (__m128d)b, (__m128d)c); }",
                    "#else", f"static inline vd2 vfma2(vd2 a, vd2 b, vd2 c) {lane}", "#endif"]
        elif w == 4:
            out += ["#if defined(__FMA__)", "#include <immintrin.h>",
                    "static inline vd4 vfma4(vd4 a, vd4 b, vd4 c) { return (vd4)_mm256_fmadd_pd((__m256d)a, (__m256d)b, (__m256d)c); }",
                    "#else", f"static inline vd4 vfma4(vd4 a, vd4 b, vd4 c) {lane}", "#endif"]
        else:
            out += ["#if defined(__AVX512F__)", "#include <immintrin.h>",
                    "static inline vd8 vfma8(vd8 a, vd8 b, vd8 c) { return (vd8)_mm512_fmadd_pd((__m512d)a, (__m512d)b, (__m512d)c); }",
                    "#elif defined(__FMA__) && defined(__GNUC__) && __GNUC__ >= 12", "#include <immintrin.h>",
                    "#define vfma8h_(x, h) ((__m256d)__builtin_shufflevector(x, x, 4 * (h), 4 * (h) + 1, 4 * (h) + 2, 4 * (h) + 3))",
                    "static inline void vfma8p_(vd8 *r, const vd8 *a, const vd8 *b, const vd8 *c) {"
                    " __m256d lo = _mm256_fmadd_pd(vfma8h_(*a, 0), vfma8h_(*b, 0), vfma8h_(*c, 0)),"
                    " hi = _mm256_fmadd_pd(vfma8h_(*a, 1), vfma8h_(*b, 1), vfma8h_(*c, 1));"
                    " *r = __builtin_shufflevector((vd4_)lo, (vd4_)hi, 0, 1, 2, 3, 4, 5, 6, 7); }",
                    "#define vfma8(a, b, c) ({ vd8 a_v_ = (a), b_v_ = (b), c_v_ = (c), o_v_; vfma8p_(&o_v_, &a_v_, &b_v_, &c_v_); o_v_; })",
                    "#elif defined(__FMA__)", "#include <immintrin.h>",
                    "typedef union { vd8 v; __m256d h[2]; } vd8h_;",
                    "#define vfma8(a, b, c) ({ vd8h_ x_v_ = {(a)}, y_v_ = {(b)}, z_v_ = {(c)}, o_v_;"
                    " o_v_.h[0] = _mm256_fmadd_pd(x_v_.h[0], y_v_.h[0], z_v_.h[0]); o_v_.h[1] = _mm256_fmadd_pd(x_v_.h[1], y_v_.h[1], z_v_.h[1]); o_v_.v; })",
                    "#else", "#define vfma8(a, b, c) ({ vd8 a_v_ = (a), b_v_ = (b), c_v_ = (c), o_v_;"
                    " for (int l_ = 0; l_ < 8; l_++) o_v_[l_] = fma(a_v_[l_], b_v_[l_], c_v_[l_]); o_v_; })", "#endif"]
        out.append("#endif")
    return "\n".join(out) + "\n"


def _vdots(name, L, ncs, pcs):
    """NAME_vdot<nc>(a, b) = sum_{j<4nc} a_j b_j as 4 partial sums s_m (j = m mod 4, each a chain
    of fma from fma(a_m, b_m, 0)), returned as (s0 + s2) + (s1 + s3); NAME_pdot<nc>(a, b), a pair
    node's (two interleaved sums): the same terms as 2 partial sums (j even, j odd), s0 + s1. One
    lane: in the processor's 4-wide vectors; L lanes: lane by lane (the same numbers)."""
    out = []
    t = "double" if L == 1 else f"vd{L}"
    tu = "double" if L == 1 else f"vd{L}u"
    fm = "fma" if L == 1 else f"vfma{L}"
    z = "0.0" if L == 1 else f"(vd{L}){{0}}"
    for nc in ncs:
        if L == 1:
            out += ["#if defined(__AVX__) && defined(__FMA__)", "#include <immintrin.h>",
                    f"static inline double {name}_vdot{nc}(const double *a, const double *b) {{",
                    "  __m256d s = _mm256_fmadd_pd(_mm256_loadu_pd(a), _mm256_loadu_pd(b), _mm256_setzero_pd());"]
            out += [f"  s = _mm256_fmadd_pd(_mm256_loadu_pd(a + {4 * c}), _mm256_loadu_pd(b + {4 * c}), s);"
                    for c in range(1, nc)]
            out += ["  __m128d h = _mm_add_pd(_mm256_castpd256_pd128(s), _mm256_extractf128_pd(s, 1));",
                    "  return _mm_cvtsd_f64(_mm_add_sd(h, _mm_unpackhi_pd(h, h)));", "}", "#else"]
        if L == 1:
            out.append(f"static inline double {name}_vdot{nc}(const double *a, const double *b) {{")
        else:
            out.append(f"static inline void {name}_vdot{nc}_(vd{L} *r, const {tu} *a, const {tu} *b) {{")
        out.append(f"  const {t} z = {z};")
        out.append("  " + " ".join(f"{t} s{m} = {fm}(a[{m}], b[{m}], z);" for m in range(4)))
        for c in range(1, nc):
            out.append("  " + " ".join(f"s{m} = {fm}(a[{4 * c + m}], b[{4 * c + m}], s{m});" for m in range(4)))
        out += ["  return (s0 + s2) + (s1 + s3);" if L == 1 else "  *r = (s0 + s2) + (s1 + s3);", "}"]
        if L > 1:
            out.append(f"#define {name}_vdot{nc}(a, b) ({{ vd{L} o_v_; {name}_vdot{nc}_(&o_v_, a, b); o_v_; }})")
        if L == 1:
            out.append("#endif")
    for nc, swa, swb in pcs:      # 2 nc terms, 2 at a time
        if L == 1:      # a, b: interleaved pairs (x_j, y_j) (swapped: (y_j, x_j)), j = 0 .. 2nc-1
            fn = f"{name}_pdot{nc}" + (f"_s{swa}{swb}" if swa or swb else "")
            la = "_mm256_permute_pd(_mm256_loadu_pd(a{}), 5)" if swa else "_mm256_loadu_pd(a{})"
            lb = "_mm256_permute_pd(_mm256_loadu_pd(b{}), 5)" if swb else "_mm256_loadu_pd(b{})"
            out += ["#if defined(__AVX__) && defined(__FMA__)", "#include <immintrin.h>",
                    f"static inline vd2 {fn}(const double *a, const double *b) {{",
                    f"  __m256d s = _mm256_fmadd_pd({la.format('')}, {lb.format('')}, _mm256_setzero_pd());"]
            out += [f"  s = _mm256_fmadd_pd({la.format(' + ' + str(4 * c))}, {lb.format(' + ' + str(4 * c))}, s);"
                    for c in range(1, nc)]
            out += ["  return (vd2)_mm_add_pd(_mm256_castpd256_pd128(s), _mm256_extractf128_pd(s, 1));", "}",
                    "#else", f"static inline vd2 {fn}(const double *a, const double *b) {{"]
            ia = (lambda q: q ^ 1) if swa else (lambda q: q)
            ib = (lambda q: q ^ 1) if swb else (lambda q: q)
            out.append("  " + " ".join(f"double s{m} = fma(a[{ia(m)}], b[{ib(m)}], 0.0);" for m in range(4)))
            out += ["  " + " ".join(f"s{m} = fma(a[{ia(4 * c + m)}], b[{ib(4 * c + m)}], s{m});" for m in range(4))
                    for c in range(1, nc)]
            out += ["  return (vd2){s0 + s2, s1 + s3};", "}", "#endif"]
        else:           # one member: a, b contiguous, j = 0 .. 2nc-1
            out.append(f"static inline void {name}_pdot{nc}_(vd{L} *r, const {tu} *a, const {tu} *b) {{")
            out.append(f"  const {t} z = {z};")
            out.append(f"  {t} s0 = {fm}(a[0], b[0], z); {t} s1 = {fm}(a[1], b[1], z);")
            for c in range(1, nc):
                out.append(f"  s0 = {fm}(a[{2 * c}], b[{2 * c}], s0); s1 = {fm}(a[{2 * c + 1}], b[{2 * c + 1}], s1);")
            out += ["  *r = s0 + s1;", "}"]
            out.append(f"#define {name}_pdot{nc}(a, b) ({{ vd{L} o_v_; {name}_pdot{nc}_(&o_v_, a, b); o_v_; }})")
    return "\n".join(out) + ("\n" if out else "")


_FUNCS = ("sqrt", "exp", "log", "sin", "cos", "tan", "sinh", "cosh", "tanh", "atan", "asin", "acos")


def _build(d, outs, order, age, smin, fwd_reads, rev_reads):
    """The ops of the jet, node by node, order by order (a topological order), with the stores of
    the coefficients that later orders read (all: fwd_reads, rev_reads None)."""
    n = d.n()
    S = order + 1
    o = Ops()
    rev = {_rev_operand(d, i, nd) for i, nd in enumerate(d.nodes)} - {None}
    args = set()
    for nd in d.nodes:
        le, lt, nx = _series_args(nd)
        args.update(le + lt + nx)
    fields = [r[1] for r in outs if r[0] == "s"]
    fold = {i for i, r in enumerate(outs) if r[0] == "s" and r[1] >= n and d.nodes[r[1] - n].kind == "lin"
            and r[1] not in args and fields.count(r[1]) == 1}
    cur = [0]                     # the order of the coefficient being computed
    done, busy = set(), set()
    fr, rr = set(), set()         # the coefficients read from memory, forwards and backwards
    chk = {}                      # a state's sum of 0 x its coefficients: NaN if one is not finite

    def V(i, j):
        if j >= cur[0]:
            return f"v{i}_{j}"
        fr.add((i, j))
        return f"M:{i}:{j}"

    def cv(A, B, lo, hi, k):
        js = list(range(lo, hi + 1))
        el = [j for j in js if j <= k - age and k - j <= k - age]
        v = None
        if smin and B in rev and len(el) >= smin:
            nc = len(el) // 4
            sj = el[:4 * nc]
            fr.update((A, j) for j in sj)
            rr.update((B, k - j) for j in sj)
            v = o.emit("vdot", [A, B, sj[0], k, nc] + [f"M:{A}:{j}" for j in sj] + [f"M:{B}:{k - j}" for j in sj])
            o.ready[v] += 4 * (nc - 1)
            js = [j for j in js if j not in sj]
        return v, [(V(A, j), V(B, k - j)) for j in js]

    def stored(i, j):
        v = f"v{i}_{j}"
        if i < n:
            chk[i] = o.fma(v, "ZERO", chk[i]) if i in chk else o.mul(v, "ZERO")
        if rev_reads is None or (i, j) in rev_reads:
            o.store("str", i, j, v)
        if i < n or fwd_reads is None or (i, j) in fwd_reads:
            o.store("st", i, j, v)        # (a state's coefficient 0: tc has it)
            o.ready[f"M:{i}:{j}"] = o.ready[v] + LAT["load"]

    def need(i, k):
        if (i, k) in done:
            return
        if (i, k) in busy:
            raise ValueError("the vector field's nodes depend on themselves at one order")
        busy.add((i, k))
        v = f"v{i}_{k}"
        if i < n:
            if k == 0:
                o.node = (i, 0)
                o.emit("load", [i], v)
            else:
                r = outs[i]
                if i in fold:      # x_k = f_{k-1} / k, f a sum: its terms divided by k
                    nd = d.nodes[r[1] - n]
                    for s in nd.args:
                        for j in range(k):
                            need(s, j)
                    cur[0] = k - 1
                    o.node = (i, k)
                    terms = []
                    for t, (c, s) in enumerate(zip(nd.data[:-1], nd.args)):
                        if c is None or _num(f"CST({c})") is not None:
                            f = _cst((1.0 if c is None else float(c)) / k)
                        else:   # one constant per term: two parameters' terms are two constants
                            f = o.once(f"K{i}_{k}_{t}", lambda nm: o.mul(f"CST({c})", _cst(1.0 / k), nm))
                        terms.append((V(s, k - 1), f))
                    off = nd.data[-1]
                    init = f"CST({off})" if off is not None and k == 1 else None
                    o.dot(terms, init=init, dst=v)
                elif r[0] == "s":
                    need(r[1], k - 1)
                    cur[0] = k - 1
                    o.node = (i, k)
                    o.mul(V(r[1], k - 1), _cst(1.0 / k), v)
                else:
                    o.node = (i, k)
                    o.emit("const", [f"CST({r[1]})" if k == 1 else "ZERO"], v)
        else:
            nd = d.nodes[i - n]
            le, lt, nx = _series_args(nd)
            for j in range(k):
                need(i, j)
            for s in le:
                for j in range(k + 1):
                    need(s, j)
            for s in lt:
                for j in range(k):
                    need(s, j)
            for s in nx:
                for j in range(k + 2):
                    need(s, j)
            cur[0] = k
            o.node = (i, k)
            _sched_node(o, i, nd, k, V, v, cv)
        o.node = (i, k)
        stored(i, k)
        o.node = None
        busy.discard((i, k))
        done.add((i, k))

    for i in range(n):
        need(i, 0)
    for k in range(1, S):
        for i in range(n):
            need(i, k)
        o.barrier()
    z = None
    for i in range(n):
        z = chk[i] if z is None else o.emit("add", [z, chk[i]])
    o.emit("mov", [z], "notfinite_")
    return o, fr, rr


def _pair_ops(d, o, part):
    """Pairs of ops: the ops of a node's coefficient and of its partner's, position by position of
    the same kind, their operands the same or partners. {op index: partner op index} (both
    ways), and the partner of each name."""
    n = d.n()
    by = {}
    for t, op in enumerate(o.ops):
        if op.node is not None:
            by.setdefault(op.node, []).append(t)
    corr = {}
    pair = {}

    def tok_ok(x, y):
        if isinstance(x, int) or isinstance(y, int):
            return x == y
        if x == y:
            return not (x in corr)       # a shared operand (not itself one of a pair)
        if corr.get(x) == y:
            return True
        if _is_mem(x) and _is_mem(y):
            (i, j), (i2, j2) = _mem(x), _mem(y)
            return j == j2 and part.get(i) == i2
        if _is_const(x) and _is_const(y):
            return True
        return False

    done = set()
    for (i, k) in sorted(by, key=lambda nk: min(by[nk])):
        if i not in part or (i, k) in done:
            continue
        j = part[i]
        if (j, k) not in by:
            continue
        A, B = by[(i, k)], by[(j, k)]
        done.update([(i, k), (j, k)])
        if len(A) != len(B):
            continue
        local = {}
        ok = True
        for ta, tb in zip(A, B):
            oa, ob = o.ops[ta], o.ops[tb]
            if oa.kind != ob.kind or len(oa.args) != len(ob.args) or oa.seg != ob.seg:
                ok = False
                break
            if oa.kind in ("st", "str"):
                if part.get(oa.args[0]) != ob.args[0] or oa.args[1] != ob.args[1]:
                    ok = False
                    break
                xa, xb = oa.args[2], ob.args[2]
                if not (local.get(xa) == xb or corr.get(xa) == xb):
                    ok = False
                    break
                continue
            if oa.kind == "vdot":
                Aa, Ba, Ab, Bb = oa.args[0], oa.args[1], ob.args[0], ob.args[1]
                if oa.args[2:5] != ob.args[2:5] or not ((part.get(Aa) == Ab or Aa == Ab) and (part.get(Ba) == Bb or Ba == Bb)) \
                        or (Aa == Ab and Ba == Bb):
                    ok = False
                    break
                local[oa.dst] = ob.dst
                continue
            if oa.kind == "load":
                if part.get(oa.args[0]) != ob.args[0]:
                    ok = False
                    break
                local[oa.dst] = ob.dst
                continue
            for xa, xb in zip(oa.args, ob.args):
                if local.get(xa) == xb:
                    continue
                if xa in local or xb in local.values() or not tok_ok(xa, xb):
                    ok = False
                    break
            if not ok:
                break
            if oa.kind == "call" and oa.args[0] != ob.args[0]:
                ok = False
                break
            local[oa.dst] = ob.dst
        if not ok:
            continue
        for ta, tb in zip(A, B):
            pair[ta], pair[tb] = tb, ta
        for a_, b_ in local.items():
            corr[a_], corr[b_] = b_, a_
    return pair, corr


def _schedule(o, pair):
    """The ops in a topological order close to the program's, a pair as one op (at the first of
    its two ops' places, as soon as both operands are ready); each segment between barriers
    stays."""
    import heapq
    ops = o.ops
    defs = {op.dst: t for t, op in enumerate(ops) if op.dst}
    stores = {}
    for t, op in enumerate(ops):
        if op.kind in ("st", "str"):
            stores[(op.kind, op.args[0], op.args[1])] = t

    def deps(t):
        op = ops[t]
        out = []
        if op.kind in ("st", "str"):
            ds = [op.args[2]]
        elif op.kind == "load":
            ds = []
        elif op.kind == "vdot":
            ds = [a for a in op.args[5:]]
        else:
            ds = op.args
        for x in ds:
            if not isinstance(x, str):
                continue
            if x in defs:
                out.append(defs[x])
            elif _is_mem(x):
                i, j = _mem(x)
                if ("st", i, j) in stores:
                    out.append(stores[("st", i, j)])
        if op.kind == "vdot":
            A, B, j0, k, nc = op.args[:5]
            for j in range(j0, j0 + 4 * nc):
                if ("str", B, k - j) in stores:
                    out.append(stores[("str", B, k - j)])
        return out

    order = []
    segs = []
    cur = []
    for t, op in enumerate(ops):
        if op.kind == "bar":
            segs.append((cur, t))
            cur = []
        else:
            cur.append(t)
    segs.append((cur, None))
    placed = set()
    for seg, bar in segs:
        units = {}
        for t in seg:
            u = min(t, pair.get(t, t))
            units.setdefault(u, []).append(t)
        indeg = {}
        users = {}
        for u, ts in units.items():
            ds = set()
            for t in ts:
                for x in deps(t):
                    if x in placed:
                        continue
                    ux = min(x, pair.get(x, x))
                    if ux != u:
                        ds.add(ux)
            indeg[u] = len(ds)
            for ux in ds:
                users.setdefault(ux, []).append(u)
        heap = [u for u in units if indeg[u] == 0]
        heapq.heapify(heap)
        out = []
        while heap:
            u = heapq.heappop(heap)
            out.append(u)
            for w in users.get(u, []):
                indeg[w] -= 1
                if indeg[w] == 0:
                    heapq.heappush(heap, w)
        if len(out) != len(units):
            return None                 # a cycle: no pairs
        for u in out:
            order.append(units[u])
            placed.update(units[u])
        if bar is not None:
            order.append([bar])
            placed.add(bar)
    return order


def generate_scheduled(d, outs, name, order, L=1, simd_age=None, simd_min=None, pairs=None):
    """One function NAME(par, tc) computing the jet of order `order` for L lanes in straight-line
    code, order by order and node by node (a topological order; the processor overlaps the
    orders). The coefficients of the current order are in registers; those that a later order
    reads are stored (states in tc, nodes in local arrays, forwards and, for the sums, backwards)
    and read back from memory, as operands of the fused multiply-adds (a compiler barrier after
    each order keeps the compiler from holding hundreds of values in registers and spilling
    them). Every sum adds its oldest terms first and the newest last; the terms of coefficients at
    least SIMD_AGE orders old go 4 at a time (VDOT). Two nodes of the same shape (x and y of a
    symmetric model: _partners) go together in one vector register (one lane; for L lanes, one
    after the other: the same numbers). Returns (source, info)."""
    n, m = d.n(), len(d.nodes)
    S = order + 1
    age = SIMD_AGE if simd_age is None else simd_age
    smin = SIMD_MIN if simd_min is None else simd_min
    use_pairs = PAIRS if pairs is None else pairs
    o, fr, rr = _build(d, outs, order, age, smin, None, None)
    o, fr2, rr2 = _build(d, outs, order, age, smin, fr, rr)        # only the stores that are read
    assert fr2 <= fr and rr2 <= rr
    part = _partners(d, outs) if use_pairs else {}
    pair, corr = _pair_ops(d, o, part) if part else ({}, {})
    sched = _schedule(o, pair) if pair else None
    if sched is None:
        pair, corr = {}, {}
        sched = [[t] for t in range(len(o.ops))]
    ops = o.ops
    # pairs of series whose ops go together: their storage is interleaved (one lane)
    pser = {}
    for t, u in pair.items():
        op = ops[t]
        if op.kind in ("st", "str"):
            a, b = op.args[0], ops[u].args[0]
            pser[min(a, b)] = max(a, b)
    pid = {}
    for a in sorted(pser):
        pid[a] = (len(pid) // 2, 0)
        pid[pser[a]] = (pid[a][0], 1)
    npair = len(pser)
    def lane0(t):
        return ops[t].node[0] < ops[pair[t]].node[0]

    pvn = {}                      # a paired name -> (its pair's variable, lane)
    for t, u in pair.items():
        if lane0(t) and ops[t].dst:
            pvn[ops[t].dst] = (f"P{ops[t].dst}", 0)
            pvn[ops[u].dst] = (f"P{ops[t].dst}", 1)

    # what each copy of the stored coefficients is read by
    need_w, need_rv, need_q, need_qr, need_dq, need_dqr = set(), set(), set(), set(), set(), set()
    for units in sched:
        t = units[0]
        op = ops[t]
        paired = len(units) == 2
        if op.kind == "vdot":
            A, B, j0, k, nc = op.args[:5]
            js = range(j0, j0 + 4 * nc)
            if paired and L == 1:
                A2, B2 = ops[units[1]].args[:2]
                for (X, X2, dst_q, dst_d, f) in ((A, A2, need_q, need_dq, lambda j: j), (B, B2, need_qr, need_dqr, lambda j: k - j)):
                    for j in js:
                        (dst_q if X != X2 else dst_d).add((X, f(j)))
                        if X != X2:
                            dst_q.add((X2, f(j)))
            else:
                for tt in units:
                    A, B = ops[tt].args[:2]
                    need_w.update((A, j) for j in js)
                    need_rv.update((B, k - j) for j in js)
        elif op.kind not in ("st", "str", "bar", "load"):
            for tt in units:
                for x in ops[tt].args:
                    if isinstance(x, str) and _is_mem(x):
                        i, j = _mem(x)
                        (need_q if (L == 1 and i in pid) else need_w).add((i, j))

    vt = "double" if L == 1 else f"vd{L}"
    vtu = "double" if L == 1 else f"vd{L}u"

    def mref(x):
        i, j = _mem(x)
        if L == 1 and i in pid:
            p, lane = pid[i]
            return f"q_[{(p * S + j) * 2 + lane}]"
        return f"T({i * S + j})" if i < n else f"W({(i - n) * S + j})"

    def sref(x):
        """A scalar operand."""
        if isinstance(x, str) and _is_mem(x):
            return mref(x)
        if L == 1 and x in pvn:
            v, lane = pvn[x]
            return f"{v}[{lane}]"
        return x

    def pref(xa, xb):
        """A pair's operand (one lane)."""
        if xa in pvn and pvn[xa][1] == 0 and pvn.get(xb) == (pvn[xa][0], 1):
            return pvn[xa][0]
        if _is_mem(xa) and _is_mem(xb):
            (i, j), (i2, _) = _mem(xa), _mem(xb)
            if i in pid and pid[i][1] == 0 and pid.get(i2) == (pid[i][0], 1):
                return f"PQ({(pid[i][0] * S + j) * 2})"
        if xa == xb:
            return f"BC({sref(xa)})"
        if _is_const(xa) and _is_const(xb):
            return f"((vd2){{{xa}, {xb}}})"
        return f"((vd2){{{sref(xa)}, {sref(xb)}}})"

    def render(kind, args, arg):
        """C expression of an op, operands rendered by arg."""
        if kind == "mul":
            return f"{arg(0)}*{arg(1)}"
        if kind == "fma":
            return f"FMA({arg(0)}, {arg(1)}, {arg(2)})"
        if kind == "add":
            return f"{arg(0)} + {arg(1)}"
        if kind == "neg":
            return f"-{arg(0)}"
        if kind in ("mov", "const"):
            return arg(0)
        if kind == "div":
            return f"{arg(0)}/{arg(1)}"
        if kind == "sqrt":
            return f"SQRT({arg(0)})"
        if kind == "call":
            return f"{args[0]}(" + ", ".join(arg(q) for q in range(1, len(args))) + ")"
        raise ValueError(kind)

    vdots, pdots = set(), set()
    body = []
    for units in sched:
        op = ops[units[0]]
        if op.kind == "bar":
            body.append("  BARRIER();")
            continue
        if L == 1 and len(units) == 2:
            ta, tb = units if lane0(units[0]) else units[::-1]
            a_, b_ = ops[ta], ops[tb]
            if a_.kind in ("st", "str"):
                i, j, v = a_.args
                p, lane = pid[i]
                pv = pvn[v][0]
                if a_.kind == "st":
                    if (i, j) in need_q or (b_.args[0], j) in need_q:
                        body.append(f"  PQ({(p * S + j) * 2}) = {pv};")
                    for ii in (i, b_.args[0]):
                        if ii < n and j > 0:
                            body.append(f"  T({ii * S + j}) = {pv}[{pid[ii][1]}];")
                        elif (ii, j) in need_w:
                            body.append(f"  W({(ii - n) * S + j}) = {pv}[{pid[ii][1]}];")
                else:
                    if (i, j) in need_qr or (b_.args[0], j) in need_qr:
                        body.append(f"  PQR({(p * S + S - 1 - j) * 2}) = {pv};")
                    for ii in (i, b_.args[0]):
                        if (ii, j) in need_rv:
                            body.append(f"  RV({ii * S + S - 1 - j}) = {pv}[{pid[ii][1]}];")
                continue
            pv = pvn[a_.dst][0]
            if a_.kind == "vdot":
                A, B, j0, k, nc = a_.args[:5]
                A2, B2 = b_.args[:2]
                pa = f"&q_[{(pid[A][0] * S + j0) * 2}]" if A != A2 else f"&dq_[{(A * S + j0) * 2}]"
                pb = f"&qr_[{(pid[B][0] * S + S - 1 - (k - j0)) * 2}]" if B != B2 else f"&dqr_[{(B * S + S - 1 - (k - j0)) * 2}]"
                sw = (int(A != A2 and pid[A][1] == 1), int(B != B2 and pid[B][1] == 1))   # operands stored y, x
                pdots.add((2 * nc,) + sw)
                body.append(f"  const vd2 {pv} = {name}_pdot{2 * nc}{'_s%d%d' % sw if any(sw) else ''}({pa}, {pb});")
                continue
            if a_.kind == "load":
                body.append(f"  const vd2 {pv} = (vd2){{tc[{a_.args[0] * S}], tc[{b_.args[0] * S}]}};")
                continue
            if a_.kind == "call":
                body.append(f"  const vd2 {pv} = (vd2){{{render(a_.kind, a_.args, lambda q: sref(a_.args[q]))}, "
                            f"{render(b_.kind, b_.args, lambda q: sref(b_.args[q]))}}};")
                continue
            body.append(f"  const vd2 {pv} = {render(a_.kind, a_.args, lambda q: pref(a_.args[q], b_.args[q]))};")
            continue
        for t in units:
            op = ops[t]
            if op.kind == "st":
                i, j, v = op.args
                vv = sref(v)
                if i < n and j > 0:
                    body.append(f"  T({i * S + j}) = {vv};")
                if L == 1 and i in pid:
                    if (i, j) in need_q:
                        body.append(f"  q_[{(pid[i][0] * S + j) * 2 + pid[i][1]}] = {vv};")
                    if (i, j) in need_w and i >= n:
                        body.append(f"  W({(i - n) * S + j}) = {vv};")
                elif i >= n and (i, j) in need_w:
                    body.append(f"  W({(i - n) * S + j}) = {vv};")
                if L == 1 and (i, j) in need_dq:
                    body.append(f"  PDQ({(i * S + j) * 2}) = BC({vv});")
                continue
            if op.kind == "str":
                i, j, v = op.args
                vv = sref(v)
                if (i, j) in need_rv:
                    body.append(f"  RV({i * S + S - 1 - j}) = {vv};")
                if L == 1 and i in pid and (i, j) in need_qr:
                    body.append(f"  qr_[{(pid[i][0] * S + S - 1 - j) * 2 + pid[i][1]}] = {vv};")
                if L == 1 and (i, j) in need_dqr:
                    body.append(f"  PDQR({(i * S + S - 1 - j) * 2}) = BC({vv});")
                continue
            if op.kind == "load":
                body.append(f"  const {vt} {op.dst} = T({op.args[0] * S});")
                continue
            if op.kind == "vdot":
                A, B, j0, k, nc = op.args[:5]
                pa = f"PT({A * S + j0})" if A < n else f"PW({(A - n) * S + j0})"
                pb = f"PR({B * S + S - 1 - (k - j0)})"
                if len(units) == 2:       # a pair's sum, lane by lane (L > 1)
                    pdots.add((2 * nc, 0, 0))
                    body.append(f"  const {vt} {op.dst} = {name}_pdot{2 * nc}({pa}, {pb});")
                else:
                    vdots.add(nc)
                    body.append(f"  const {vt} {op.dst} = {name}_vdot{nc}({pa}, {pb});")
                continue
            body.append(f"  const {vt} {op.dst} = {render(op.kind, op.args, lambda q: sref(op.args[q]))};")

    src = [f"int {name}(const double *restrict par, double *restrict tc) {{"]
    for cn, ce in d.consts:
        src.append(f"  const double {cn} = {ce};")
    src.append(f"  {vt} w_[{max(m * S, 1)}], r_[{(n + m) * S if need_rv else 1}];")
    if L == 1 and npair:
        nd_ = (n + m) * S * 2 if (need_dq or need_dqr) else 2
        src.append(f"  double q_[{npair * S * 2}] __attribute__((aligned(16))), qr_[{npair * S * 2}] __attribute__((aligned(16))), "
                   f"dq_[{nd_}] __attribute__((aligned(16))), dqr_[{nd_}] __attribute__((aligned(16)));")
        bar = "#define BARRIER() __asm__ volatile(\"\" : : \"r\"(w_), \"r\"(r_), \"r\"(q_), \"r\"(qr_), \"r\"(dq_), \"r\"(dqr_), \"r\"(tc) : \"memory\")"
    else:
        bar = "#define BARRIER() __asm__ volatile(\"\" : : \"r\"(w_), \"r\"(r_), \"r\"(tc) : \"memory\")"
    src += [bar, "#define W(i) w_[i]", "#define RV(i) r_[i]",
            f"#define PT(i) ((const {vtu} *)&T(i))", f"#define PW(i) ((const {vtu} *)&w_[i])",
            f"#define PR(i) ((const {vtu} *)&r_[i])",
            "#define PQ(i) (*(vd2 *)&q_[i])", "#define PQR(i) (*(vd2 *)&qr_[i])",
            "#define PDQ(i) (*(vd2 *)&dq_[i])", "#define PDQR(i) (*(vd2 *)&dqr_[i])"]
    if L == 1:
        src += ["#define CST(c) (c)", "#define ZERO 0.0", "#define FMA(a, b, c) _Generic((a), vd2: vfma2, default: fma)(a, b, c)",
                "#define BC(x) ((vd2){(x), (x)})", "#define T(i) tc[i]"]
        src += [f"#define {f.upper()}(a) {f}(a)" for f in _FUNCS if f != "sqrt"]
        src += ["#define SQRT(a) _Generic((a), vd2: vsqrt2_, default: sqrt)(a)",
                "#define POW(a, b) pow(a, b)", "#define ATAN2(a, b) atan2(a, b)"]
    else:
        src += [f"#define CST(c) (({vt}){{" + ", ".join(["(c)"] * L) + "})",
                f"#define ZERO (({vt}){{0}})",
                f"#define FMA(a, b, c) vfma{L}(a, b, c)",
                f"#define T(i) (*({vtu} *)&tc[(i)*{L}])"]
        for f in _FUNCS:
            src.append(f"#define {f.upper()}(a) ({{ {vt} o_v_; for (int l_ = 0; l_ < {L}; l_++) o_v_[l_] = {f}((a)[l_]); o_v_; }})")
        src.append(f"#define POW(a, b) ({{ {vt} o_v_; for (int l_ = 0; l_ < {L}; l_++) o_v_[l_] = pow((a)[l_], (b)[0]); o_v_; }})")
        src.append(f"#define ATAN2(a, b) ({{ {vt} o_v_; for (int l_ = 0; l_ < {L}; l_++) o_v_[l_] = atan2((a)[l_], (b)[l_]); o_v_; }})")
    src += body
    if L == 1:     # 0 x a coefficient is NaN for an infinity or a NaN, 0 otherwise
        src.append(f"  if ({sref('notfinite_')} != 0.0) return -1;")
    else:
        src.append(f"  for (int l = 0; l < {L}; l++) if (notfinite_[l] != 0.0) return -1;")
    src += [f"#undef {u}" for u in ("CST", "ZERO", "FMA", "BC", "T", "W", "RV", "PT", "PW", "PR", "PQ", "PQR", "PDQ",
                                     "PDQR", "BARRIER", "POW", "ATAN2")]
    src += [f"#undef {f.upper()}" for f in _FUNCS]
    src += ["  return 0;", "}"]
    conv, lin = d.cost()
    nops = sum(1 for u in sched if ops[u[0]].dst)
    cp = max(o.ready[f"v{i}_{order}"] for i in range(n))
    return _types(L) + _vdots(name, L, sorted(vdots), sorted(pdots)) + "\n".join(src) + "\n", \
        {"nodes": m, "convolutions": conv, "linear": lin, "ops": nops, "cycles": cp, "pairs": len(pair) // 2}
