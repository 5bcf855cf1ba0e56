"""The registered namelist variables (annotations '!@ &group name | units | default | allowed | text'
in src/workflow/tubes_config.f90; docs/development.md, "Adding a namelist variable"): for each one
the reader (./tubes FILE --check) refuses a value just outside its allowed range and accepts values
just inside it. The bounds are read here from the annotations' text, not from the generated checks:
a generator or a reader that drifted from the annotation fails."""
import math
import re
import subprocess

import pytest
import tubes

from conftest import ROOT, TUBES


def annotations():
    """(group, name, kind, default, allowed) of every registered variable, kind from the declaration
    that follows its annotation: real, int, int64, logical, string, list."""
    lines = (ROOT / "src/workflow/tubes_config.f90").read_text().splitlines()
    out = []
    for k, line in enumerate(lines):
        m = re.match(r"\s*!@\s*&(\w+)\s+(\w+)\s*\|(.*)$", line)
        if not m:
            continue
        group, name, rest = m.groups()
        if rest.strip().startswith("default "):   # a hand-written variable's per-model default: a mark
            continue
        units, default, allowed = (f.strip() for f in rest.split("|")[:3])
        decl = lines[k + 1].split("!")[0]
        if re.search(r"character\(kind=c_char\)", decl):
            kind = "string"
        elif re.search(r"real\(c_double\).*\(\w+\)\s*$", decl):
            kind = "list"
        elif "real(c_double)" in decl:
            kind = "real"
        elif "integer(c_int64_t)" in decl:
            kind = "int64"
        elif default in (".true.", ".false."):
            kind = "logical"
        else:
            kind = "int"
        out.append((group, name, kind, default, allowed))
    return out


REGISTERED = annotations()
PER_MODEL = re.compile(r"([a-z][a-z0-9_]*): ([^;]+); other models: required")


def per_model_defaults():
    """(group, name, model, value) of every per-model default (DEFAULT 'MODEL: VALUE; other models:
    required'), of registered variables and of hand-written ones' marks ('!@ &group name | default ...')."""
    out = []
    for line in (ROOT / "src/workflow/tubes_config.f90").read_text().splitlines():
        m = re.match(r"\s*!@\s*&(\w+)\s+(\w+)\s*\|\s*(default )?([^|]*)\|?\s*([^|]*)", line)
        if not m:
            continue
        group, name, mark, first, second = m.groups()
        d = PER_MODEL.fullmatch((first if mark else second).strip())
        if d:
            out.append((group, name, d[1], d[2]))
    return out


PER_MODEL_DEFAULTS = per_model_defaults()


def the_default(default):
    """The value the reader stores: a per-model default's value (the test files run its model, the
    rolling ball), else the default itself."""
    m = PER_MODEL.fullmatch(default)
    return m[2] if m else default

# Settings a value needs to be judged on its own range: another variable's check would refuse it
# otherwise (those checks are the reader's rules between variables, docs/input.md).
CONTEXT = {
    ("experiment", "n_tracks"): "&experiment duration = 0.1 /\n",      # n_tracks x frames <= 5e7
    ("tubes", "n_init"): "&tubes n_max = 1000000 /\n",                 # n_max >= n_init
    ("trajectory", "dt_out"): "&trajectory t_end = 0 /\n",             # t_end/dt_out <= 5e7
    ("integrator", "method"): "&integrator h = 0.001 /\n",             # fixed-step methods need h > 0
    ("integrator", "rtol"): "&integrator method = 'dop853' /\n",       # not 'auto''s choice
    ("scan", "*"): "&scan parameter = 'alpha', to = 0.08, de = 10 /\n",   # the scan's required variables
    # n_grid^N <= 1e6 (the model's N): a 1-DOF model reaches the range's 2001
    ("equilibria", "n_grid"): "&model system = 'expression', hamiltonian = 'p^2/2 + q^4/4 - q^2/2', "
                              "coordinates = 'q', momenta = 'p' /\n",
    # order > 0 needs a model written as a formula (Henon-Heiles')
    ("flux", "order"): "&model system = 'expression', hamiltonian = '(px^2 + py^2)/2 + (x^2 + y^2)/2 + x^2*y - y^3/3' /\n",
}


def run(group, name, value):
    """Exit code and messages of --check on a file that sets &group name = value."""
    ctx = CONTEXT.get((group, name), "") + CONTEXT.get((group, "*"), "")
    text = "&run scenes = 'equilibria' /\n" + ctx
    if f"&{group} " in ctx:   # one group, once: put the value into the context's group
        text = text.replace(f"&{group} ", f"&{group} {name} = {value},\n ", 1)
    else:
        text += f"&{group}\n  {name} = {value}\n/\n"
    return text


def check(tmp_path, group, name, value):
    path = tmp_path / "r.nml"
    path.write_text(run(group, name, value))
    p = subprocess.run([str(TUBES), str(path), "--check"], capture_output=True, text=True, timeout=60, cwd=tmp_path)
    return p.returncode, p.stderr + p.stdout


def num(s):
    return float(s)


def step(x, direction):
    """The double next to x towards direction (+1, -1); next to 0 a small normal number (C's strtod
    calls a subnormal an overflow of range)."""
    if x == 0:
        return direction * 1e-300
    return math.nextafter(x, direction * math.inf)


def text(x, is_int):
    return str(int(x)) if is_int else repr(float(x))


def bounds(allowed):
    """lo, hi, lo_open, hi_open of a range form (docs/development.md), None where unbounded."""
    a = allowed
    if a == "finite":
        return None, None, False, False
    m = re.fullmatch(r"(\S+) \.\. (\S+)", a)
    if m:
        return num(m[1]), num(m[2]), False, False
    m = re.fullmatch(r"(>=|>|<=|<) (\S+)", a)
    if m:
        op, x = m[1], num(m[2])
        return (x, None, op == ">", False) if op[0] == ">" else (None, x, False, op == "<")
    m = re.fullmatch(r"(\S+) (<=?) \w+ (<=?) (\S+)", a)
    if m:
        return num(m[1]), num(m[4]), m[2] == "<", m[3] == "<"
    raise AssertionError(f"allowed {a!r} is not a range form")


def default_of(group, name):
    """The registered default of &group name (a per-model one: the rolling ball's, the test files' model)."""
    return next(the_default(d) for g, n, _, d, _ in REGISTERED if (g, n) == (group, name))


def cases(group, name, kind, default, allowed):
    """(inside, outside): values the reader must accept, values it must refuse. Forms beside the
    range forms: "V, or [even] LO .. HI[ TEXT]" (V allowed too; even: only even values in the range;
    TEXT a rule checked elsewhere), "OTHER .. HI" (bounded below by the group's variable OTHER, at its
    default here), "FORM, RULE" (RULE another check's: a pair's "< OTHER" or "> OTHER")."""
    m = re.fullmatch(r"(-?\d+), or (even )?(-?\d+) \.\. (-?\d+)( .*)?", allowed)
    if kind == "int" and m:
        alt, even, lo, hi = int(m[1]), bool(m[2]), int(m[3]), int(m[4])
        inside = [alt, lo, hi] + ([lo + 2] if even else [])
        outside = [v for v in (lo - 1, hi + 1, hi + 2, -1) if v != alt] + ([lo + 1, hi - 1] if even else [])
        return [str(v) for v in inside], [str(v) for v in outside]
    m = re.fullmatch(r"([a-z_]\w*) \.\. (\S+)", allowed)
    if m:   # bounded below by another variable
        lo = int(default_of(group, m[1]))
        return [default, str(lo), m[2]], [str(lo - 1), str(int(m[2]) + 1)]
    rule = ""
    if ", " in allowed and not re.fullmatch(r"-?\d+(, -?\d+)+", allowed) and kind in ("real", "int", "int64"):
        allowed, rule = allowed.split(", ", 1)
    if kind == "logical":
        return [".true.", ".false."], ["2", "'yes'"]
    if kind == "string":
        return [f"'{v}'" for v in allowed.split(", ")], ["'no_such_value'"]
    if kind == "list":
        assert allowed == "> 0, increasing"
        return ["1e-300, 1", "1, 2, 3"], ["0", "-1, 2", "2, 2", "3, 2"]
    is_int = kind in ("int", "int64")
    if is_int and re.fullmatch(r"-?\d+(, -?\d+)+", allowed):   # an integer's values
        vals = [int(v) for v in allowed.split(", ")]
        return [str(v) for v in vals], [str(min(vals) - 1), str(max(vals) + 1)]
    lo, hi, lo_open, hi_open = bounds(allowed)
    inside, outside = [default], []
    if allowed == "finite":   # a pair's rule "< OTHER" ("> OTHER") refuses the largest (smallest) double
        big = [v for v, r in (("1.7976931348623157e308", "<"), ("-1.7976931348623157e308", ">")) if not rule.startswith(r)]
        return [default] + big, ["1e309", "-1e309"]
    for b, is_open, d in ((lo, lo_open, -1), (hi, hi_open, +1)):
        if b is None:
            continue
        if is_int:
            inside.append(text(b - d if is_open else b, True))
            outside.append(text(b if is_open else b + d, True))
        else:
            inside.append(text(step(b, -d) if is_open else b, False))
            outside.append(text(b if is_open else step(b, d), False))
    return inside, outside


def test_the_annotations_are_read():
    """The parse above sees every kind the generator takes (a regression of this file's own reader)."""
    kinds = {k for _, _, k, _, _ in REGISTERED}
    assert kinds == {"real", "int", "int64", "logical", "string", "list"}, kinds
    assert len(REGISTERED) >= 50


@pytest.mark.parametrize("model,n,ok", [("", 1000, True), ("", 1001, False),
                                         ("&model system = 'cr3bp', spatial = .true. /\n", 100, True),
                                         ("&model system = 'cr3bp', spatial = .true. /\n", 101, False)])
def test_n_grid_rule_is_the_model_s(tmp_path, model, n, ok):
    """&equilibria n_grid's rule beside its range (2 .. 2001): n_grid^N Newton starts at most 1e6,
    N the model's degrees of freedom (the ball's 2: 1000, not 1001; the spatial CR3BP's 3: 100, not 101)."""
    (tmp_path / "g.nml").write_text(f"&run scenes = 'equilibria' /\n{model}&equilibria n_grid = {n} /\n")
    p = subprocess.run([str(TUBES), "g.nml", "--check"], capture_output=True, text=True, timeout=60, cwd=tmp_path)
    if ok:
        assert p.returncode == 0, p.stderr
    else:
        assert p.returncode == 1 and (f"g.nml:{2 + bool(model)}: &equilibria: n_grid = {n} is out of range: allowed "
                                      "2 .. 2001, n_grid^N <= 1e6") in p.stderr, p.stderr
        assert "n_grid^N Newton starts at most 1e6" in p.stderr, p.stderr


@pytest.mark.parametrize("group,name,kind,default,allowed", REGISTERED, ids=[f"{g}.{n}" for g, n, *_ in REGISTERED])
def test_range_is_the_annotation_s(tmp_path, group, name, kind, default, allowed):
    inside, outside = cases(group, name, kind, the_default(default), allowed)
    for v in inside:
        rc, msg = check(tmp_path, group, name, v)
        assert rc == 0, f"&{group} {name} = {v} (allowed {allowed}) refused:\n{msg}"
    for v in outside:
        rc, msg = check(tmp_path, group, name, v)
        assert rc == 1, f"&{group} {name} = {v} (allowed {allowed}) accepted:\n{msg}"
        assert f"&{group}: " in msg and name in msg, msg   # the message names the variable
        if kind in ("real", "int", "int64", "string") and "309" not in v:
            assert allowed in msg, msg   # and says what is allowed, in the annotation's words


def test_the_forms_beside_the_ranges_are_used():
    """The forms this file's cases() reads beyond the range forms are those of registered variables."""
    allowed = {(g, n): a for g, n, _, _, a in REGISTERED}
    assert allowed[("flux", "n_cut")] == "0, or even 4 .. 64"
    assert allowed[("tubes", "n_max")] == "n_init .. 1000000"
    assert allowed[("experiment", "de_min")] == "finite, < de_max"
    assert allowed[("experiment", "camera_rate")].startswith("> 0, ")


def test_docs_rows_state_the_annotation():
    """docs/input.md's row of each registered variable states its annotation's default, and (but
    for a logical, whose allowed is text only) its allowed range in the annotation's words."""
    rows, group = {}, None
    for ln in (ROOT / "docs" / "input.md").read_text().splitlines():
        m = re.match(r"## `&(\w+)`", ln)
        group = m.group(1) if m else group
        cells = [c.strip().replace("`", "") for c in ln.split("|")[1:-1]]
        if len(cells) >= 5 and re.fullmatch(r"\w+", cells[0]):
            rows[(group, cells[0])] = cells
    for group, name, kind, default, allowed in REGISTERED:
        cells = rows.get((group, name))
        assert cells, f"&{group} {name}: no row in docs/input.md"
        assert cells[3] in (default, default.strip("'")), f"&{group} {name}: docs default {cells[3]!r}, annotation {default!r}"
        if kind != "logical":
            assert allowed in cells[4], f"&{group} {name}: docs allowed {cells[4]!r}, annotation {allowed!r}"


def test_per_model_defaults_are_read():
    """The excess energies' lists and the trajectory's start are the four-well ball's defaults."""
    named = {(g, n) for g, n, _, _ in PER_MODEL_DEFAULTS}
    assert {("trajectory", "x0"), ("trajectory", "y0"), ("orbits", "de"), ("tubes", "de"), ("transition", "de"),
            ("montecarlo", "de"), ("sections", "de")} <= named, named


def test_help_shows_the_per_model_defaults():
    """--help states each per-model default as 'VALUE (MODEL; other models: required)' (a list of
    more than five values shortened as the generator does)."""
    out = subprocess.run([str(TUBES), "--help"], capture_output=True, text=True, timeout=60).stdout
    group = None
    shown = {}
    for ln in out.splitlines():
        m = re.fullmatch(r"  &(\w+)", ln)
        group = m[1] if m else group
        m = re.match(r"    (\w+)\s+\w+\s+\[[^]]*\] default ((?:[^;(]|\([^)]*\))*); ", ln)
        if m:
            shown[(group, m[1])] = m[2]
    for group, name, model, value in PER_MODEL_DEFAULTS:
        v = value.split(", ")
        text = ", ".join(v[:3] + ["..."] + v[-2:]) if len(v) > 5 else value
        assert shown.get((group, name)) == f"{text} ({model}; other models: required)", (group, name, shown.get((group, name)))


@pytest.mark.parametrize("group,name,model,value", PER_MODEL_DEFAULTS,
                         ids=[f"{g}.{n}" for g, n, *_ in PER_MODEL_DEFAULTS])
def test_per_model_default_is_required_for_other_models(tmp_path, group, name, model, value):
    """A model other than the default's (Hénon–Heiles) running the group's scene without the variable
    is refused before any work, naming the group and the variable (exit 1)."""
    assert model == "rolling_ball"   # the other model below is not the default's
    scene = group   # the groups with per-model defaults are their scenes'
    path = tmp_path / "r.nml"
    path.write_text(f"&run scenes = '{scene}', output = '{tmp_path}/o.h5' /\n&model system = 'henon_heiles' /\n")
    p = subprocess.run([str(TUBES), str(path)], capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert p.returncode == 1, p.stderr
    assert f"&{group}: " in p.stderr and f"{name}" in p.stderr and "not set" in p.stderr, p.stderr


def test_python_method_codes_are_the_registry_list():
    """tubes.METHODS (the codes Python hands the core) are the places of the names in &integrator
    method's registered list (src/workflow/tubes_config.f90's annotation), as the reader's
    tubes_method_code and the C enum TUBES_METHOD_* (tests/test_capi.c) take them."""
    found, *_, allowed = tubes._lib().registry_range("integrator", "method")
    assert found == 2
    names = [v.strip() for v in tubes._str(allowed).strip().split(",")]
    assert list(tubes.METHODS) == names
    assert list(tubes.METHODS.values()) == list(range(1, len(names) + 1))


# Python's calls that bypass the reader (a namelist per call would cost more than the integration)
# and their keywords that are registered variables: keyword -> (group, name)
BYPASS = {"integrate": {"method": ("integrator", "method"), "rtol": ("integrator", "rtol"),
                        "atol": ("integrator", "atol"), "h": ("integrator", "h"),
                        "max_steps": ("integrator", "max_steps"), "solver": ("integrator", "solver"),
                        "max_iter": ("integrator", "max_iter"), "max_crossings": ("trajectory", "max_crossings")},
          "ensemble": {"method": ("integrator", "method"), "rtol": ("integrator", "rtol"),
                       "atol": ("integrator", "atol"), "h": ("integrator", "h"),
                       "max_steps": ("integrator", "max_steps"), "solver": ("integrator", "solver"),
                       "max_iter": ("integrator", "max_iter")},
          "Integrator": {"method": ("integrator", "method"), "rtol": ("integrator", "rtol"),
                         "atol": ("integrator", "atol"), "h": ("integrator", "h"),
                         "max_steps": ("integrator", "max_steps"), "solver": ("integrator", "solver"),
                         "max_iter": ("integrator", "max_iter")},
          "trajectory": {"dt_out": ("trajectory", "dt_out")},
          "tube_cut": {"kind": ("tubes", "kind")}}           # (a keyword always written into its namelist)


@pytest.mark.parametrize("fn", sorted(BYPASS))
def test_python_keyword_defaults_are_the_annotations(fn):
    """The keyword defaults of the Python calls that bypass the reader (tubes.integrate, ensemble,
    Integrator, trajectory; and tube_cut's kind) are the registered variables' defaults in their annotations (omega_bind's
    0, "Tao's default", stands for the annotation's value, and integrate's dt_out None, "the final
    state only", is not a sample spacing: both left out): a default changed in one place and not the
    other fails here."""
    import inspect
    ann = {(g, n): d for g, n, _, d, _ in REGISTERED}
    params = inspect.signature(getattr(tubes, fn)).parameters
    for kw, key in BYPASS[fn].items():
        want = ann[key]
        got = params[kw].default
        if isinstance(got, str):
            assert repr(got) == want, (fn, kw, got, want)
        else:
            assert got is not inspect.Parameter.empty and float(got) == float(want), (fn, kw, got, want)
