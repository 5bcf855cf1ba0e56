#!/usr/bin/env bash
# make check: `pip install .` (pyproject.toml, meson.build) into a fresh venv, then the installed
# package and program against this tree's ./tubes and python/ (docs/development.md "pip install").
#   bash tests/pip_check.sh --probe   exit 0 if pip can reach the package index (run_all.sh skips
#                                     this check, saying so, when it cannot)
#   bash tests/pip_check.sh           the check; exit 0 only if every comparison agrees
# The install is pip's default, with build isolation: pip fetches meson-python, meson, ninja and
# numpy for the build, and numpy, h5py and SymPy for the package (from its cache when it has them),
# as a user's `pip install .` does. It installs from a copy of this tree's files (git's tracked and
# untracked, not ignored: no build/, no .venv), and the copy is deleted before anything runs, so
# nothing installed can fall back on a source tree (src/io/tubes_expr.c, find_tool).
set -u
cd "$(dirname "$0")/.."
repo=$PWD
py=${PYTHON:-python3}
if [ "${1:-}" = --probe ]; then
  d=$(mktemp -d) && trap 'rm -rf "$d"' EXIT
  if "$py" -m pip download --quiet --no-deps --timeout 15 --retries 0 -d "$d" meson-python >"$d/log" 2>&1; then exit 0; fi
  echo "pip cannot reach the package index ($(tail -1 "$d/log"))"
  exit 1
fi
tmp=$(mktemp -d "${TMPDIR:-/tmp}/tubes-pip.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
unset MAKEFLAGS MFLAGS MAKELEVEL   # the build's own make is not a child of make check's jobserver
nfail=0
check() {   # check NAME CMD...: runs CMD, prints PASS NAME or FAIL NAME
  local name=$1
  shift
  if "$@"; then echo "PASS $name"; else echo "FAIL $name"; nfail=$((nfail + 1)); fi
}

mkdir -p "$tmp/src" "$tmp/run"
git ls-files -z --cached --others --exclude-standard | tar --null --ignore-failed-read -T - -cf - | tar -xf - -C "$tmp/src"
"$py" -m venv "$tmp/venv" || exit 1
vpy=$tmp/venv/bin/python
t0=$SECONDS
(cd "$tmp/src" && "$vpy" -m pip install --quiet .) || { echo "FAIL pip install ."; exit 1; }
echo "pip install .: $((SECONDS - t0)) s (build and dependencies)"
"$vpy" -m pip cache remove --quiet tubes >/dev/null 2>&1 || true   # the wheel pip built and cached
rm -rf "$tmp/src"
cd "$tmp/run" || exit 1
export OMP_NUM_THREADS=${OMP_NUM_THREADS:-2}
unset TUBES_CODEGEN TUBES_PYTHON

# the package is the installed one, with its extension and the program inside it
check import "$vpy" -c "import sys, tubes, tubes._core, tubes._program as p
site = '$tmp/venv/lib/'
assert tubes.__file__.startswith(site) and tubes._core.__file__.startswith(site), (tubes.__file__, tubes._core.__file__)
assert p.executable().startswith(site), p.executable()"
[ -x "$tmp/venv/bin/tubes" ] || { echo "FAIL no console script $tmp/venv/bin/tubes"; nfail=$((nfail + 1)); }

# the paper's run: the installed program against this tree's ./tubes, bit for bit
same_run() {   # same_run INPUT: both programs on INPUT, each with its own fresh model cache
  local b
  b=$(basename "$1" .nml)
  TUBES_CACHE_DIR=$tmp/cache-pip "$tmp/venv/bin/tubes" "$repo/input/$1" -o "pip-$b.h5" >"pip-$b.log" 2>&1 \
    || { tail -5 "pip-$b.log"; return 1; }
  TUBES_CACHE_DIR=$tmp/cache-repo "$repo/tubes" "$repo/input/$1" -o "repo-$b.h5" >"repo-$b.log" 2>&1 \
    || { tail -5 "repo-$b.log"; return 1; }
  "$vpy" -m tubes.h5compare "repo-$b.h5" "pip-$b.h5"
}
t0=$SECONDS
check paper same_run paper.nml
echo "paper.nml, both programs: $((SECONDS - t0)) s"
# a formula model: the installed codegen.py and jetgen.py generate it (the cache starts empty)
check formula same_run expression.nml
check formula-built bash -c "ls '$tmp'/cache-pip/expr_*.so >/dev/null"

# the Python facade: the installed package against this tree's, to the last bit
# (every float printed to its last bit; a UserWarning, such as a Taylor kernel that could not be
# generated and the DOP853 fallback, is an error)
facade='import tubes
def full(d):
    return {k: (v.tolist() if hasattr(v, "tolist") else v) for k, v in d.items()}
m = tubes.Model()
print(full(m.transition(dE=[100.0])))
f = tubes.Model("expression", hamiltonian="(px^2 + py^2)/2 - x^2/2 + x^4/4 + 9/8*y^2 + x^2*y/5")
print(full(tubes.equilibria(f)))'
installed() { TUBES_CACHE_DIR=$tmp/cache-pip "$vpy" -W error::UserWarning -c "$facade" > py-pip.txt; }
tree() { TUBES_CACHE_DIR=$tmp/cache-repo "$repo/.venv/bin/python" -W error::UserWarning -c "$facade" > py-repo.txt; }
check python-installed installed
check python-tree tree
check python-same cmp py-repo.txt py-pip.txt
grep -q "'p_trans': \[0.0819" py-pip.txt || { echo "FAIL p_trans(100) is not 0.0819...: $(head -c 300 py-pip.txt)"; nfail=$((nfail + 1)); }

[ "$nfail" -eq 0 ] && echo "pip check: all passed" || echo "pip check: $nfail FAILED"
[ "$nfail" -eq 0 ]
