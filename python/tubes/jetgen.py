"""Taylor-series code from a model's formula (docs/integrators-taylor.md): the recurrences of
automatic differentiation in time, generated as C.

A vector field dx/dt = f(x) written with SymPy is decomposed into elementary operations (the
nodes: linear combinations, products, squares, quotients, powers, exp, log, the trigonometric
and hyperbolic functions and their inverses); each node's recurrence for its k-th normalised
Taylor coefficient u_k (u(t0 + s) = sum_k u_k s^k) from the lower ones is written once below
(`Node.code`), and the generated function computes, order by order, every node's coefficient k
and then x_{k+1} = f_k / (k + 1). Sub-expressions are shared (sympy.cse, and hash-consing of the
nodes), expressions of the parameters alone are computed once per call, and a quotient's and a
power's division by the operand's constant term is a multiplication by its reciprocal, computed
once per call.

The generated function (one per lane count L):

    int NAME(int order, const double *restrict par, double *restrict tc, double *restrict w)

tc holds x's coefficients, tc[(i*(order+1) + k)*L + l] for variable i, order k, lane l; the
caller fills k = 0 with the state, the function fills k = 1..order. par: the parameters, in the
order given to `generate`. w: scratch of NAME_nwork * (order+1) * L doubles (the nodes'
coefficients). Returns 0, or -1 if a coefficient of order `order` or `order`-1 is not finite.

Lanes: L trajectories at once, in lockstep; every lane does exactly the arithmetic of L = 1
(explicit fma(), no reassociation across lanes), so a trajectory's coefficients do not depend on
the lane it is in or on L (tests/test_taylor.py checks it bit for bit).
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
                return self.add_node("pow", [sb[1]], self.const(x)[1])
            return self.conv(sp.exp(x * sp.log(b)))
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
        conv = sum(1 for nd in self.nodes if nd.kind not in ("lin", "aux"))
        return conv, len(self.nodes) - conv


def _emit_node(d, idx, nd, L):
    """C statements computing coefficient k of node idx (names U<i> are the series' pointers)."""
    u = f"U{idx}"
    A = lambda i, j: f"U{i}[({j})*{L} + l]"          # noqa: E731
    out = []
    loop = f"for (int l = 0; l < {L}; l++)"
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
        out.append(f"{loop} {{ " + " ".join(body) + f" double v = 2.0*s; if ((k & 1) == 0) v = fma({A(x, 'k/2')}, {A(x, 'k/2')}, v); {u}[k*{L} + l] = v; }}")
        return out
    if k in ("div", "recip"):
        if k == "div":
            x, y = a
            num0 = A(x, "k")
        else:
            y, = a
            num0 = None
        inv = f"R{idx}"
        out.append(f"if (k == 0) {loop} {{ {inv}[l] = 1.0 / {A(y, 0)}; {u}[l] = {num0 if num0 else nd.data} * {inv}[l]; }}")
        body = conv_sum("1", "k", lambda j, s: f"fma(-{A(y, j)}, {A(idx, f'k - ({j})')}, {s})")
        out.append(f"else {loop} {{ " + " ".join(body) + f" {u}[k*{L} + l] = ({num0 + ' + s' if num0 else 's'}) * {inv}[l]; }}")
        return out
    if k == "sqrt":
        x, = a
        inv = f"R{idx}"
        out.append(f"if (k == 0) {loop} {{ {u}[l] = sqrt({A(x, 0)}); {inv}[l] = 0.5 / {u}[l]; }}")
        body = conv_sum("1", "(k - 1) >> 1", lambda j, s: f"fma({A(idx, j)}, {A(idx, f'k - ({j})')}, {s})")
        out.append(f"else {loop} {{ " + " ".join(body) + f" double v = 2.0*s; if ((k & 1) == 0) v = fma({A(idx, 'k/2')}, {A(idx, 'k/2')}, v); {u}[k*{L} + l] = ({A(x, 'k')} - v) * {inv}[l]; }}")
        return out
    if k == "pow":
        x, = a
        al = nd.data
        inv = f"R{idx}"
        out.append(f"if (k == 0) {loop} {{ {u}[l] = pow({A(x, 0)}, {al}); {inv}[l] = 1.0 / {A(x, 0)}; }}")
        body = conv_sum("0", "k - 1", lambda j, s: f"fma(({al}*(double)(k - ({j})) - (double)({j})) * {A(x, f'k - ({j})')}, {A(idx, j)}, {s})")
        out.append(f"else {loop} {{ " + " ".join(body) + f" {u}[k*{L} + l] = s * {inv}[l] * RK[k]; }}")
        return out
    if k == "exp":
        x, = a
        out.append(f"if (k == 0) {loop} {u}[l] = exp({A(x, 0)});")
        body = conv_sum("1", "k", lambda j, s: f"fma((double)({j}) * {A(x, j)}, {A(idx, f'k - ({j})')}, {s})")
        out.append(f"else {loop} {{ " + " ".join(body) + f" {u}[k*{L} + l] = s * RK[k]; }}")
        return out
    if k == "log":
        x, = a
        inv = f"R{idx}"
        out.append(f"if (k == 0) {loop} {{ {u}[l] = log({A(x, 0)}); {inv}[l] = 1.0 / {A(x, 0)}; }}")
        body = conv_sum("1", "k - 1", lambda j, s: f"fma((double)({j}) * {A(idx, j)}, {A(x, f'k - ({j})')}, {s})")
        out.append(f"else {loop} {{ " + " ".join(body) + f" {u}[k*{L} + l] = ({A(x, 'k')} - s * RK[k]) * {inv}[l]; }}")
        return out
    if k in ("sin", "sinh"):
        x, = a
        c = nd.data
        f0 = "sin" if k == "sin" else "sinh"
        out.append(f"if (k == 0) {loop} {u}[l] = {f0}({A(x, 0)});")
        body = conv_sum("1", "k", lambda j, s: f"fma((double)({j}) * {A(x, j)}, {A(c, f'k - ({j})')}, {s})")
        out.append(f"else {loop} {{ " + " ".join(body) + f" {u}[k*{L} + l] = s * RK[k]; }}")
        return out
    if k in ("cos", "cosh"):
        x, s_ = a
        f0 = "cos" if k == "cos" else "cosh"
        sign = "-" if k == "cos" else ""
        out.append(f"if (k == 0) {loop} {u}[l] = {f0}({A(x, 0)});")
        body = conv_sum("1", "k", lambda j, s: f"fma((double)({j}) * {A(x, j)}, {A(s_, f'k - ({j})')}, {s})")
        out.append(f"else {loop} {{ " + " ".join(body) + f" {u}[k*{L} + l] = {sign}s * RK[k]; }}")
        return out
    if k in ("tan", "tanh"):
        x, = a
        w = nd.data
        out.append(f"if (k == 0) {loop} {u}[l] = {k}({A(x, 0)});")
        body = conv_sum("1", "k", lambda j, s: f"fma((double)({j}) * {A(x, j)}, {A(w, f'k - ({j})')}, {s})")
        out.append(f"else {loop} {{ " + " ".join(body) + f" {u}[k*{L} + l] = s * RK[k]; }}")
        return out
    if k == "aux":   # w = 1 +- t^2 of tan/tanh t
        t, = a
        sign = "+" if nd.data == "tan" else "-"
        out.append(f"if (k == 0) {loop} {u}[l] = 1.0 {sign} {A(t, 0)}*{A(t, 0)};")
        body = conv_sum("0", "(k - 1) >> 1", lambda j, s: f"fma({A(t, j)}, {A(t, f'k - ({j})')}, {s})")
        out.append(f"else {loop} {{ " + " ".join(body) + f" double v = 2.0*s; if ((k & 1) == 0) v = fma({A(t, 'k/2')}, {A(t, 'k/2')}, v); {u}[k*{L} + l] = {sign}v; }}")
        return out
    if k in ("atan", "asin", "acos"):
        x, w = a
        inv = f"R{idx}"
        sign = "-" if k == "acos" else ""
        out.append(f"if (k == 0) {loop} {{ {u}[l] = {k}({A(x, 0)}); {inv}[l] = 1.0 / {A(w, 0)}; }}")
        body = conv_sum("1", "k - 1", lambda j, s: f"fma((double)({j}) * {A(idx, j)}, {A(w, f'k - ({j})')}, {s})")
        out.append(f"else {loop} {{ " + " ".join(body) + f" {u}[k*{L} + l] = ({sign}{A(x, 'k')} - s * RK[k]) * {inv}[l]; }}")
        return out
    if k == "atan2":
        y, x, w = a
        inv = f"R{idx}"
        out.append(f"if (k == 0) {loop} {{ {u}[l] = atan2({A(y, 0)}, {A(x, 0)}); {inv}[l] = 1.0 / {A(w, 0)}; }}")
        # k c_k w_0 = sum_{j=0}^{k-1} (k-j) (x_j y_{k-j} - y_j x_{k-j}) - sum_{j=1}^{k-1} j c_j w_{k-j}
        body = conv_sum("0", "k - 1", lambda j, s: f"fma((double)(k - ({j})), {A(x, j)}*{A(y, f'k - ({j})')} - {A(y, j)}*{A(x, f'k - ({j})')}, {s})")
        body2 = [b.replace("const double s =", "const double r =").replace("s0", "t0").replace("s1", "t1")
                 for b in conv_sum("1", "k - 1", lambda j, s: f"fma((double)({j}) * {A(idx, j)}, {A(w, f'k - ({j})')}, {s})", "i")]
        out.append(f"else {loop} {{ " + " ".join(body) + " " + " ".join(body2) + f" {u}[k*{L} + l] = (s - r) * RK[k] * {inv}[l]; }}")
        return out
    raise ValueError(k)


def decompose(sp, states, fields, params):
    """The decomposition of dx/dt = fields(states; params) and the refs of the fields."""
    d = Decomposition(sp, states, params)
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

#: latencies of the scalar operations [cycles], for the schedule only (a model of a current x86
#: core; the emitted order is a topological order whatever the numbers)
LAT = {"fma": 4, "mul": 4, "add": 3, "sub": 3, "neg": 1, "div": 13, "sqrt": 18, "call": 60, "mov": 0,
       "load": 4, "const": 0}


class Ops:
    """Straight-line scalar code: each op defines one name; ready times from LAT."""

    def __init__(self):
        self.ops = []        # (ready, seq, dst, c_expr)
        self.ready = {}
        self.seq = 0

    def emit(self, kind, expr, deps, dst=None, store=None):
        """dst = expr after deps; store: also written to tc at this offset (in units of L)."""
        if dst is None:
            dst = f"t{self.seq}"
        r = max([self.ready.get(d, 0) for d in deps], default=0) + LAT[kind]
        self.ready[dst] = r
        self.ops.append((r, self.seq, dst, expr, store))
        self.seq += 1
        return dst

    def dot(self, terms, init=None, dst=None):
        """sum of products a*b (+ init), shaped by ready times: the earliest partial sums are
        combined first, so that the terms made of the newest coefficients come in last."""
        import heapq
        items = sorted(terms, key=lambda t: max(self.ready.get(t[0], 0), self.ready.get(t[1], 0)))
        heap = []
        if init is not None:
            heapq.heappush(heap, (self.ready.get(init, 0), init))
        for a, b in items:
            rt = max(self.ready.get(a, 0), self.ready.get(b, 0))
            if heap and heap[0][0] <= rt + LAT["mul"]:
                _, s = heapq.heappop(heap)
                v = self.emit("fma", f"FMA({a}, {b}, {s})", [a, b, s])
            else:
                v = self.emit("mul", f"{a}*{b}", [a, b])
            heapq.heappush(heap, (self.ready[v], v))
        if not heap:
            return self.emit("const", "ZERO", [], dst) if dst else "ZERO"
        while len(heap) > 1:
            _, x = heapq.heappop(heap)
            _, y = heapq.heappop(heap)
            v = self.emit("add", f"{x} + {y}", [x, y])
            heapq.heappush(heap, (self.ready[v], v))
        v = heap[0][1]
        if dst:
            return self.emit("mov", v, [v], dst)
        return v


def _sched_node(o, idx, nd, k, V):
    """Ops for coefficient k of node idx; V(i, j) is the name of coefficient j of series i."""
    kind, a = nd.kind, nd.args
    dst = V(idx, k)
    R = f"R{idx}"
    K = lambda v: f"CST({v!r})"                          # noqa: E731
    if kind == "lin":
        coefs = nd.data
        terms, deps = [], []
        for c, s in zip(coefs[:-1], a):
            terms.append(V(s, k) if c is None else f"CST({c})*{V(s, k)}")
            deps.append(V(s, k))
        if coefs[-1] is not None and k == 0:
            terms.append(f"CST({coefs[-1]})")
        o.emit("add", " + ".join(terms) if terms else "ZERO", deps, dst)
        return
    if kind == "mul":
        x, y = a
        o.dot([(V(x, j), V(y, k - j)) for j in range(k + 1)], dst=dst)
        return
    if kind in ("sqr", "aux"):
        x, = a
        if k == 0:
            s = o.emit("mul", f"{V(x, 0)}*{V(x, 0)}", [V(x, 0)])
        else:
            half = o.dot([(V(x, j), V(x, k - j)) for j in range((k - 1) // 2 + 1)])
            s = o.emit("add", f"{half} + {half}", [half])
            if k % 2 == 0:
                s = o.emit("fma", f"FMA({V(x, k // 2)}, {V(x, k // 2)}, {s})", [V(x, k // 2), s])
        if kind == "sqr":
            o.emit("mov", s, [s], dst)
        elif nd.data == "tan":
            o.emit("add", f"CST(1.0) + {s}" if k == 0 else s, [s], dst)
        else:
            o.emit("sub", f"CST(1.0) - {s}" if k == 0 else f"-{s}", [s], dst)
        return
    if kind in ("div", "recip"):
        y = a[-1]
        if k == 0:
            o.emit("div", f"CST(1.0)/{V(y, 0)}", [V(y, 0)], R)
            num = V(a[0], 0) if kind == "div" else f"CST({nd.data})"
            o.emit("mul", f"{num}*{R}", [R] + ([V(a[0], 0)] if kind == "div" else []), dst)
            return
        # u_k = (a_k - sum_{j=1}^{k} y_j u_{k-j}) / y_0
        s = o.dot([(V(y, j), V(idx, k - j)) for j in range(1, k + 1)])
        num = o.emit("sub", f"{V(a[0], k)} - {s}", [V(a[0], k), s]) if kind == "div" else \
            o.emit("neg", f"-{s}", [s])
        o.emit("mul", f"{num}*{R}", [num, R], dst)
        return
    if kind == "sqrt":
        x, = a
        if k == 0:
            o.emit("sqrt", f"SQRT({V(x, 0)})", [V(x, 0)], dst)
            o.emit("div", f"CST(0.5)/{dst}", [dst], R)
            return
        half = [(V(idx, j), V(idx, k - j)) for j in range(1, (k - 1) // 2 + 1)]
        s = o.dot(half) if half else None
        if s is not None:
            s = o.emit("add", f"{s} + {s}", [s])
        if k % 2 == 0:
            s = o.emit("fma" if s else "mul", f"FMA({V(idx, k // 2)}, {V(idx, k // 2)}, {s})" if s else
                       f"{V(idx, k // 2)}*{V(idx, k // 2)}", [V(idx, k // 2)] + ([s] if s else []))
        num = o.emit("sub", f"{V(x, k)} - {s}", [V(x, k), s]) if s else V(x, k)
        o.emit("mul", f"{num}*{R}", [num, R], dst)
        return
    if kind == "pow":
        x, = a
        al = nd.data
        if k == 0:
            o.emit("call", f"POW({V(x, 0)}, {al})", [V(x, 0)], dst)
            o.emit("div", f"CST(1.0)/{V(x, 0)}", [V(x, 0)], R)
            return
        terms = []
        for j in range(k):
            c = o.emit("mul", f"CST({al}*{float(k - j)!r} - {float(j)!r})*{V(x, k - j)}", [V(x, k - j)])
            terms.append((c, V(idx, j)))
        s = o.dot(terms)
        o.emit("mul", f"{s}*{R}*CST({1.0 / k!r})", [s, R], dst)
        return
    if kind in ("exp", "sin", "sinh", "cos", "cosh", "tan", "tanh"):
        x = a[0]
        other = {"exp": idx, "cos": a[-1], "cosh": a[-1]}.get(kind, nd.data)
        if k == 0:
            o.emit("call", f"{kind.upper()}({V(x, 0)})", [V(x, 0)], dst)
            return
        terms = []
        for j in range(1, k + 1):
            c = o.emit("mul", f"CST({float(j) / k!r})*{V(x, j)}", [V(x, j)])
            terms.append((c, V(other, k - j)))
        s = o.dot(terms)
        o.emit("neg" if kind == "cos" else "mov", f"-{s}" if kind == "cos" else s, [s], dst)
        return
    if kind in ("log", "atan", "asin", "acos"):
        x = a[0]
        w = x if kind == "log" else a[1]
        if k == 0:
            o.emit("call", f"{kind.upper()}({V(x, 0)})", [V(x, 0)], dst)
            o.emit("div", f"CST(1.0)/{V(w, 0)}", [V(w, 0)], R)
            return
        # w_0 u_k = (+-) x_k - (1/k) sum_{j=1}^{k-1} j u_j w_{k-j}
        terms = []
        for j in range(1, k):
            c = o.emit("mul", f"CST({float(j) / k!r})*{V(idx, j)}", [V(idx, j)])
            terms.append((c, V(w, k - j)))
        s = o.dot(terms) if terms else None
        xk = V(x, k)
        if kind == "acos":
            num = o.emit("sub", f"-{xk} - {s}" if s else f"-{xk}", [xk] + ([s] if s else []))
        else:
            num = o.emit("sub", f"{xk} - {s}", [xk, s]) if s else xk
        o.emit("mul", f"{num}*{R}", [num, R], dst)
        return
    if kind == "atan2":
        y, x, w = a
        if k == 0:
            o.emit("call", f"ATAN2({V(y, 0)}, {V(x, 0)})", [V(y, 0), V(x, 0)], dst)
            o.emit("div", f"CST(1.0)/{V(w, 0)}", [V(w, 0)], R)
            return
        # k u_k w_0 = sum_{j=0}^{k-1} (k-j) (x_j y_{k-j} - y_j x_{k-j}) - sum_{j=1}^{k-1} j u_j w_{k-j}
        terms = []
        for j in range(k):
            cx = o.emit("mul", f"CST({float(k - j) / k!r})*{V(x, j)}", [V(x, j)])
            cy = o.emit("mul", f"CST({-float(k - j) / k!r})*{V(y, j)}", [V(y, j)])
            terms += [(cx, V(y, k - j)), (cy, V(x, k - j))]
        for j in range(1, k):
            c = o.emit("mul", f"CST({-float(j) / k!r})*{V(idx, j)}", [V(idx, j)])
            terms.append((c, V(w, k - j)))
        s = o.dot(terms)
        o.emit("mul", f"{s}*{R}", [s, R], dst)
        return
    raise ValueError(kind)


def _prologue(L):
    """Types and the fused multiply-add: fma() for one lane and the processor's vector fma for
    L lanes, each lane rounded as fma() rounds (compiled with -ffp-contract=off, so that nothing
    else is fused, in either): a lane's numbers do not depend on L."""
    vec = {2: ("__m128d", "_mm_fmadd_pd", "__FMA__"), 4: ("__m256d", "_mm256_fmadd_pd", "__FMA__"),
           8: ("__m512d", "_mm512_fmadd_pd", "__AVX512F__")}.get(L)
    out = ["#include <math.h>", f"#ifndef TUBES_JET_TYPES_{L}", f"#define TUBES_JET_TYPES_{L}",
           f"typedef double vd{L} __attribute__((vector_size({8 * L})));",
           f"typedef double vu{L} __attribute__((vector_size({8 * L}), aligned(8)));   /* tc: any alignment */"]
    if vec:
        out += [f"#if defined({vec[2]})", "#include <immintrin.h>",
                f"static inline vd{L} vfma{L}(vd{L} a, vd{L} b, vd{L} c) {{ return ({'vd' + str(L)}){vec[1]}(({vec[0]})a, ({vec[0]})b, ({vec[0]})c); }}",
                "#else",
                f"static inline vd{L} vfma{L}(vd{L} a, vd{L} b, vd{L} c) {{ vd{L} r; for (int l = 0; l < {L}; l++) r[l] = fma(a[l], b[l], c[l]); return r; }}",
                "#endif"]
    out.append("#endif")
    return "\n".join(out) + "\n"


def generate_scheduled(d, outs, name, order, L=1):
    """One function NAME(par, tc) computing the jet of order `order` for L lanes in straight-line
    code, ordered by a list schedule (LAT). Returns (source, info)."""
    n, m = d.n(), len(d.nodes)
    S = order + 1
    o = Ops()
    V = lambda i, j: f"v{i}_{j}"                            # noqa: E731
    for i in range(n):
        o.emit("load", f"LOAD({i * S})", [], V(i, 0))
    for k in range(order):
        for i, nd in enumerate(d.nodes):
            _sched_node(o, n + i, nd, k, V)
        for i, r in enumerate(outs):
            if r[0] == "s":
                o.emit("mul", f"{V(r[1], k)}*CST({1.0 / (k + 1)!r})", [V(r[1], k)], V(i, k + 1),
                       store=i * S + k + 1)
            else:
                o.emit("const", f"CST({r[1]})" if k == 0 else "ZERO", [], V(i, k + 1), store=i * S + k + 1)
    body = sorted(o.ops)
    vt = "double" if L == 1 else f"vd{L}"
    src = [f"int {name}(const double *restrict par, double *restrict tc) {{"]
    for cn, ce in d.consts:
        src.append(f"  const double {cn} = {ce};")
    if L == 1:
        src += ["#define CST(c) (c)", "#define ZERO 0.0", "#define FMA(a, b, c) fma(a, b, c)",
                "#define LOAD(i) tc[i]", "#define SQRT(a) sqrt(a)", "#define POW(a, b) pow(a, b)"]
        for f in ("exp", "log", "sin", "cos", "tan", "sinh", "cosh", "tanh", "atan", "asin", "acos"):
            src.append(f"#define {f.upper()}(a) {f}(a)")
        src.append("#define ATAN2(a, b) atan2(a, b)")
    else:
        src += [f"#define CST(c) (({vt}){{" + ", ".join(["(c)"] * L) + "})",
                f"#define ZERO (({vt}){{0}})",
                f"#define FMA(a, b, c) vfma{L}(a, b, c)",
                f"#define LOAD(i) ((vd{L})*(vu{L} *)&tc[(i)*{L}])"]
        for f in ("sqrt", "exp", "log", "sin", "cos", "tan", "sinh", "cosh", "tanh", "atan", "asin", "acos"):
            src.append(f"#define {f.upper()}(a) ({{ {vt} r_; for (int l_ = 0; l_ < {L}; l_++) r_[l_] = {f}((a)[l_]); r_; }})")
        src.append(f"#define POW(a, b) ({{ {vt} r_; for (int l_ = 0; l_ < {L}; l_++) r_[l_] = pow((a)[l_], b); r_; }})")
        src.append(f"#define ATAN2(a, b) ({{ {vt} r_; for (int l_ = 0; l_ < {L}; l_++) r_[l_] = atan2((a)[l_], (b)[l_]); r_; }})")
    for _, _, dst, expr, store in body:
        src.append(f"  const {vt} {dst} = {expr};")
        if store is not None:
            src.append(f"  tc[{store}] = {dst};" if L == 1 else f"  *(vu{L} *)&tc[{store * L}] = {dst};")
    src.append(f"  for (int i = 0; i < {n * S * L}; i++) if (!isfinite(tc[i])) return -1;")
    src += ["#undef CST", "#undef ZERO", "#undef FMA", "#undef LOAD", "#undef SQRT", "#undef POW", "#undef ATAN2"]
    for f in ("exp", "log", "sin", "cos", "tan", "sinh", "cosh", "tanh", "atan", "asin", "acos"):
        src.append(f"#undef {f.upper()}")
    src.append("  return 0;")
    src.append("}")
    conv, lin = d.cost()
    return _prologue(L) + "\n".join(src) + "\n", {"nodes": m, "convolutions": conv, "linear": lin,
                                                  "ops": len(body)}
