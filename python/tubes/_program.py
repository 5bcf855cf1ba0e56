"""The ``tubes`` console script of a pip-installed tubes (pyproject.toml): runs the compiled
program, shipped in the package as ``tubes/bin/tubes``, with the same arguments.

    tubes input/paper.nml -o paper.h5        (or: python -m tubes._program ...)

Before it runs the program it names the code generator for formula models, as ``tubes.Model``
does: ``TUBES_CODEGEN`` = this package's codegen.py and ``TUBES_PYTHON`` = this Python (it has
SymPy, a dependency of the package), unless the environment already sets them. Otherwise the
program would look beside itself and in the source tree it was built from (src/io/tubes_expr.c,
find_tool), neither of which an installed package has. The program replaces this process
(``os.execv``): its exit status, signals and output are the program's own.
"""
from __future__ import annotations

import os
import sys

from . import _codegen_env


def executable() -> str:
    """The compiled program: the package's bin/tubes (pip install), else the source tree's
    ./tubes (make), beside python/."""
    here = os.path.dirname(os.path.abspath(__file__))
    for path in (os.path.join(here, "bin", "tubes"), os.path.join(here, os.pardir, os.pardir, "tubes")):
        if os.path.isfile(path) and os.access(path, os.X_OK):
            return os.path.normpath(path)
    raise FileNotFoundError(f"the tubes program is neither in {os.path.join(here, 'bin')} (pip install .) "
                            f"nor in the source tree beside {os.path.dirname(here)} (make)")


def main() -> None:
    try:
        exe = executable()
    except FileNotFoundError as e:
        sys.exit(f"tubes: {e}")
    _codegen_env()
    os.execv(exe, [sys.argv[0], *sys.argv[1:]])


if __name__ == "__main__":
    main()
