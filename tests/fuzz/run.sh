#!/usr/bin/env bash
# make fuzz / make check: run one fuzz target for SECONDS (docs/development.md "Fuzzing").
# usage: tests/fuzz/run.sh TARGET SECONDS [merge]
#   TARGET is the libFuzzer binary build/fuzz/fuzz_namelist (seed corpus tests/fuzz/corpus) or an
#   Atheris target tests/fuzz/fuzz_<name>.py (seed corpus tests/fuzz/corpus-<name>), run by the
#   .venv's python; SECONDS 0 only replays the corpus. Both corpora are kept in git; new inputs
#   go to build/fuzz/corpus-<name> (build/fuzz/corpus for the namelist). With 'merge', the inputs that add coverage are merged back
#   into the kept corpus. FUZZ_PYTHON overrides the Python (default .venv/bin/python); FUZZ_FLAGS
#   adds libFuzzer flags (e.g. -runs=1000000: stop after that many executions).
# Prints one line "fuzz/<name>: N executions in T s (R/s), C crashes, H hangs, ..." and exits 1 on
# a finding, with the input saved under build/fuzz/findings/ and the command that reproduces it.
# A Python target without atheris installed prints SKIP and exits 0.
set -u
target=$1
secs=$2
mode=${3:-}
cd "$(dirname "$0")/../.."
work=build/fuzz
case $target in
  *.py)
    name=$(basename "$target" .py); name=${name#fuzz_}
    py=${FUZZ_PYTHON:-.venv/bin/python}
    if ! "$py" -c 'import atheris' 2>/dev/null; then
      echo "SKIP fuzz/$name: atheris is not installed in $py (make deps installs it)"; exit 0
    fi
    # libFuzzer's -merge (and -fork) re-run argv[0], which Atheris sets to the script's path: the
    # target runs through an executable wrapper, build/fuzz/fuzz_<name>, that Python sees as argv[0]
    mkdir -p "$work"
    wrap=$work/fuzz_$name
    case $py in /*) ;; */*) py=$PWD/$py ;; esac    # absolute, not resolved: a venv's python is a link
    printf '#!/usr/bin/env bash\nexec %q -c %q "$0" %q "$@"\n' "$py" \
      'import sys; w, t = sys.argv[1:3]; sys.argv = [w] + sys.argv[3:]
exec(compile(open(t, "rb").read(), t, "exec"), {"__name__": "__main__", "__file__": t})' \
      "$(realpath "$target")" >"$wrap"
    chmod +x "$wrap"
    cmd=("$wrap"); repro="$py $target"; seeds=tests/fuzz/corpus-$name; new=$work/corpus-$name ;;
  *)
    name=$(basename "$target"); name=${name#fuzz_}
    cmd=("$target"); seeds=tests/fuzz/corpus; new=$work/corpus
    export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1} ;;
esac
mkdir -p "$new" "$seeds" "$work/findings"
log=$work/fuzz-$name.log
touch "$log.start"; sleep 1
if [ "$secs" -gt 0 ]; then limit=(-max_total_time="$secs"); else limit=(-runs=0); fi
t0=$(date +%s)
"${cmd[@]}" "${limit[@]}" -timeout=10 -rss_limit_mb=4096 -print_final_stats=1 \
  -artifact_prefix="$work/findings/$name-" ${FUZZ_FLAGS:-} "$new" "$seeds" >"$log" 2>&1
rc=$?
t1=$(date +%s)
execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
crashes=$(find "$work/findings" -name "$name-crash-*" -newer "$log.start" 2>/dev/null | wc -l)
leaks=$(find "$work/findings" -name "$name-leak-*" -newer "$log.start" 2>/dev/null | wc -l)
hangs=$(find "$work/findings" -name "$name-timeout-*" -newer "$log.start" 2>/dev/null | wc -l)
ncorp=$(find "$new" "$seeds" -type f | wc -l)
echo "fuzz/$name: ${execs:-0} executions in $((t1 - t0)) s ($(( ${execs:-0} / ( t1 - t0 > 0 ? t1 - t0 : 1) ))/s)," \
     "$crashes crashes, $hangs hangs, $leaks leaks; corpus $ncorp inputs; $(date -u +%Y-%m-%d)"
if [ "$rc" -ne 0 ]; then
  grep -a -E '^(fuzz:|==[0-9]+==ERROR|SUMMARY|[A-Za-z]*Error)|nml:[0-9]+:|^ +File ' "$log" | head -20
  for f in $(find "$work/findings" -type f -name "$name-*" -newer "$log.start"); do
    echo "finding: $f (reproduce: ${repro:-${cmd[*]}} $f)"
  done
  if [ $((crashes + hangs + leaks)) -gt 0 ]; then
    echo "fuzz/$name: the fuzzer stopped on a finding (exit $rc); full log in $log" >&2
  else
    tail -5 "$log"; echo "fuzz/$name: the fuzzer failed (exit $rc) without a finding; full log in $log" >&2
  fi
  exit 1
fi
if [ "$mode" = merge ]; then
  "${cmd[@]}" -merge=1 "$seeds" "$new" >"$work/merge-$name.log" 2>&1 || { tail "$work/merge-$name.log"; exit 1; }
  echo "fuzz/$name: $seeds now holds $(ls "$seeds" | wc -l) inputs"
fi
