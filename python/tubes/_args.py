"""The one check of the Python API's numeric arguments (issue 39): a bool, a string, NaN, an
infinity, a value out of range or a non-integral count is refused with a message naming the
function, the argument, the value given and what is allowed, never converted silently
(``int(2.5)``, ``float(True)``, ``max(1, n)``). Ranges that the input file also has are checked
by the program's reader (tubes._settings); this module checks the arguments that bypass it."""

from __future__ import annotations

import math
import numbers

import numpy as np


def _allowed(lo, hi, lo_open, hi_open, what: str) -> str:
    parts = []
    if lo is not None:
        parts.append(f"{'>' if lo_open else '>='} {lo:g}")
    if hi is not None:
        parts.append(f"{'<' if hi_open else '<='} {hi:g}")
    return f"allowed {what}" + (" " + " and ".join(parts) if parts else "")


def real(who: str, name: str, v, *, lo=None, hi=None, lo_open: bool = False, hi_open: bool = False,
         finite: bool = True) -> float:
    """v as a float: a real number (int, float, numpy scalar or 0-d array; not a bool, not a
    string), finite unless finite=False, within [lo, hi] (open ends with lo_open / hi_open)."""
    if type(v) is float and (lo is None or (v > lo if lo_open else v >= lo)) \
            and (hi is None or (v < hi if hi_open else v <= hi)) and (v - v == 0 or (not finite and v == v)):
        return v            # the common case, without the checks below (a call's cost: issue 36)
    what = "a finite real number" if finite else "a real number"
    if isinstance(v, np.ndarray) and v.ndim == 0:
        v = v[()]
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, numbers.Real):
        raise TypeError(f"{who}: {name} = {v!r} is not a real number: {_allowed(lo, hi, lo_open, hi_open, what)}")
    x = float(v)
    if math.isnan(x) or (finite and math.isinf(x)) \
            or (lo is not None and (x <= lo if lo_open else x < lo)) \
            or (hi is not None and (x >= hi if hi_open else x > hi)):
        raise ValueError(f"{who}: {name} = {v!r} is out of range: {_allowed(lo, hi, lo_open, hi_open, what)}")
    return x


def integer(who: str, name: str, v, *, lo=None, hi=None) -> int:
    """v as an int: an integer (int, numpy integer, or a float with an integral value such as
    1e4; not a bool, not a string, not 2.5) within [lo, hi]."""
    if type(v) is int and (lo is None or v >= lo) and (hi is None or v <= hi):
        return v            # the common case
    if isinstance(v, np.ndarray) and v.ndim == 0:
        v = v[()]
    ok = (isinstance(v, numbers.Integral) or (isinstance(v, numbers.Real) and math.isfinite(float(v))
                                               and float(v).is_integer()))
    if isinstance(v, (bool, np.bool_)) or not ok:
        raise TypeError(f"{who}: {name} = {v!r} is not an integer: {_allowed(lo, hi, False, False, 'an integer')}")
    n = int(v)
    if (lo is not None and n < lo) or (hi is not None and n > hi):
        raise ValueError(f"{who}: {name} = {v!r} is out of range: {_allowed(lo, hi, False, False, 'an integer')}")
    return n


def reals(who: str, name: str, v) -> list[float]:
    """v (a number or a sequence of numbers) as a list of finite floats, each checked by real();
    the range is the caller's (or the program reader's)."""
    a = np.asarray(v, dtype=object).reshape(-1)
    return [real(who, f"{name}[{k}]" if a.size > 1 else name, x) for k, x in enumerate(a)]


def flag(who: str, name: str, v) -> bool:
    """v as a bool: True or False (numpy's too), nothing else (not 0, 1 or 'no')."""
    if isinstance(v, (bool, np.bool_)):
        return bool(v)
    raise TypeError(f"{who}: {name} = {v!r} is not True or False: allowed True or False")


def floats(who: str, name: str, x) -> np.ndarray:
    """x (an array of numbers) as a float64 copy: an array of bools, strings or objects that
    are not numbers is refused (np.array would read True as 1 and fail on 'a' without naming x)."""
    a = np.asarray(x)
    if a.dtype.kind == "O":
        try:
            a = np.asarray(a.tolist(), dtype=np.float64)
        except (TypeError, ValueError):
            pass
    if a.dtype.kind not in "iuf":
        raise TypeError(f"{who}: {name} must be an array of real numbers: got {a.dtype} values "
                        f"(e.g. {a.reshape(-1)[0]!r})" if a.size else f"{who}: {name} is empty")
    return np.array(a, dtype=np.float64, copy=True)
