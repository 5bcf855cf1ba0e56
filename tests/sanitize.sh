#!/usr/bin/env bash
# make sanitize: the test programs and the executable built with -fsanitize=address,undefined
# (build/sanitize, MODE=sanitize in the Makefile) run: every Fortran and C test program, the
# pytest suites that drive the executable (TUBES_EXE points them at the sanitized build), and the
# paper's input with reduced ensembles. Any sanitizer report fails the run (halt_on_error, and
# UBSan built with -fno-sanitize-recover). Ends with "sanitize: N passed, N failed in T s".
set -u
cd "$(dirname "$0")/.."
b=build/sanitize
log=$b/logs
mkdir -p "$log"
export ASAN_OPTIONS=${ASAN_OPTIONS:-halt_on_error=1:detect_leaks=1:abort_on_error=0}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
export OMP_NUM_THREADS=${OMP_NUM_THREADS:-2}
t0=$SECONDS
log_dir=$log
bad_log='ERROR: (AddressSanitizer|LeakSanitizer)|runtime error:'   # a sanitizer's report
show_log='ERROR: |runtime error:|SUMMARY|^FAIL'
. tests/harness.sh
# Test programs: no leak check. gfortran frees a main program's allocatables with its stack
# frame at exit, so LeakSanitizer reports every array a test allocates; the library's own leaks
# are caught by the executable's runs below (a C main: nothing of the test harness).
for t in $b/tests/test_*; do
  [ -x "$t" ] && run "sanitize/$(basename "$t")" env ASAN_OPTIONS="${ASAN_OPTIONS/detect_leaks=1/detect_leaks=0}" "$t"
done
# the executable through its own test suites (the Python extension stays unsanitized)
run "sanitize/pytest (executable)" env TUBES_EXE=$b/bin/tubes TUBES_TIMEOUT_SCALE=6 .venv/bin/python -m pytest -q -p no:cacheprovider \
  tests/test_cli.py tests/test_tubes_cli.py tests/test_models_cli.py tests/test_orbits_cli.py \
  tests/test_experiment_scene.py tests/test_expression.py tests/test_flux.py tests/test_three_dof.py \
  tests/test_normal_form.py tests/test_tube_cut3.py -k "not python"
# the paper's input, its ensembles reduced (the code paths are the paper's)
work=$(mktemp -d)
sed -e 's/n_samples = 10000/n_samples = 1000/' -e 's/n_seeds = 40, n_iter = 300/n_seeds = 8, n_iter = 40/' \
    -e 's/n_tracks = 600/n_tracks = 40/' input/paper.nml >"$work/paper.nml"
run "sanitize/paper (reduced ensembles)" $b/bin/tubes "$work/paper.nml" -o "$work/paper.h5"
rm -rf "$work"
echo "sanitize: $pass passed, $fail failed in $((SECONDS - t0)) s ($(date -u +%Y-%m-%d), OMP_NUM_THREADS=$OMP_NUM_THREADS)"
[ "$fail" -eq 0 ]
