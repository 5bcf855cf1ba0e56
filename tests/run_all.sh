#!/usr/bin/env bash
# make check: every Fortran and C test program (optimised build, then the runtime-checked
# build in build/debug) with the fuzzers beside them, the MPI flavour's 2-rank checks
# (tests/mpi_check.sh), then pytest
# (Python layer and the tubes executable).
# Ends with one line "N passed, N failed"; exits non-zero if anything failed.
# QUICK=1 (make quick): the optimised build's test programs and the Python tests not marked slow only.
set -u
cd "$(dirname "$0")/.."
log_dir=build/testlogs
mkdir -p "$log_dir"
show_log='^FAIL|Error|error'
. tests/harness.sh
# the fuzzers: 20 s of the namelist fuzzer (make fuzz runs it longer; docs/development.md), and
# each Python (Atheris) target's corpus replayed and 5 s of fuzzing (SKIP without atheris). Each
# runs for a fixed time on one core: they run at once, beside the one-core test programs (started
# before them; their lines printed, and counted, in this order when they end; a finding is saved
# as build/fuzz/findings/<target>-crash-*, so each target counts its own)
fuzz_one() {   # fuzz_one K NAME CMD...: run NAME in the background, its lines and count in fuzz.K.*
  local k=$1
  shift
  (pass=0; fail=0; run "$@"; echo "$pass $fail" >"$log_dir/fuzz.$k.count") >"$log_dir/fuzz.$k.out" 2>&1 &
  fuzz_pids+=($!)
}
fuzz_start() {
  fuzz_pids=()
  rm -f "$log_dir"/fuzz.*.count "$log_dir"/fuzz.*.out
  if [ -x build/fuzz/fuzz_namelist ]; then
    fuzz_one 0 "fuzz/namelist (20 s)" bash tests/fuzz/run.sh build/fuzz/fuzz_namelist 20
  else
    echo "SKIP fuzz/namelist (no build/fuzz/fuzz_namelist: no clang-14)" >"$log_dir/fuzz.0.out"
  fi
  local k=1
  for t in tests/fuzz/fuzz_*.py; do
    [ -f "$t" ] || continue
    n=$(basename "$t" .py); n=${n#fuzz_}
    if .venv/bin/python -c 'import atheris' 2>/dev/null; then
      fuzz_one $k "fuzz/$n (5 s)" bash tests/fuzz/run.sh "$t" 5
    else
      echo "SKIP fuzz/$n (atheris is not installed in .venv: make deps installs it)" >"$log_dir/fuzz.$k.out"
    fi
    k=$((k + 1))
  done
}
fuzz_end() {
  local f
  wait "${fuzz_pids[@]}"
  for f in $(ls "$log_dir"/fuzz.*.out 2>/dev/null | sort -t. -k2 -n); do
    cat "$f"
    if [ -f "${f%.out}.count" ]; then
      read -r fp ff <"${f%.out}.count"
      pass=$((pass + fp)); fail=$((fail + ff))
    elif ! grep -q '^SKIP' "$f"; then
      fail=$((fail + 1)); echo "FAIL $(basename "$f") (the fuzzer's job left no count)"
    fi
  done
}
quick=${QUICK:-0}
[ "$quick" != 1 ] && fuzz_start
for t in build/tests/test_*; do
  [ -x "$t" ] && run "release/$(basename "$t")" "$t"
done
for t in build/debug/tests/test_*; do
  [ "$quick" = 1 ] && break
  [ -x "$t" ] && run "debug/$(basename "$t")" "$t"
done
[ "$quick" != 1 ] && fuzz_end
# the MPI flavour (built by make check when mpifort exists): 2-rank runs against the serial one
if [ "$quick" = 1 ]; then
  echo "SKIP debug/*, mpi/*, fuzz/* and the slow Python tests (make quick; make check runs them)"
elif [ -x build/mpi/bin/tubes ]; then
  for t in identical fault badinput badoutput pastend formula flux3 taylor damped; do
    run "mpi/$t" bash tests/mpi_check.sh "$t"
  done
else
  echo "SKIP mpi/* (no build/mpi/bin/tubes: no MPI compiler wrapper)"
fi
# pip install . into a fresh venv (tests/pip_check.sh, about 2 minutes): make pipcheck, run by .ci/run
# (kept out of make check's 10-minute budget)
log=build/testlogs/pytest.log
# two pytest workers (pytest-xdist, installed by make deps), each test file on one worker (its
# module fixtures made once); most tests run ./tubes on one thread
xd=()
.venv/bin/python -c 'import xdist' 2>/dev/null && xd=(-n "${TUBES_TEST_WORKERS:-2}" --dist loadfile)
sel=()
[ "$quick" = 1 ] && sel=(-m "not slow")
OMP_NUM_THREADS=${OMP_NUM_THREADS:-2} .venv/bin/python -m pytest -q -p no:cacheprovider "${xd[@]}" "${sel[@]}" --durations=15 tests >"$log" 2>&1
prc=$?
tail -3 "$log"
np=$(grep -Eo '[0-9]+ passed' "$log" | tail -1 | grep -Eo '[0-9]+' || true)
nf=$(grep -Eo '[0-9]+ (failed|error|errors)' "$log" | awk '{s += $1} END {print s + 0}')
np=${np:-0}
nf=${nf:-0}
if [ "$prc" -ne 0 ] && [ "$nf" -eq 0 ]; then
  nf=1   # pytest failed without a count (collection error, no tests): count it as a failure
  grep -E 'Error|error' "$log" | head -10
fi
pass=$((pass + np))
fail=$((fail + nf))
[ "$nf" -gt 0 ] && grep -E '^(FAILED|ERROR)' "$log" | head -20
echo "$pass passed, $fail failed"
[ "$fail" -eq 0 ]
