#!/usr/bin/env bash
# make fuzz / make check: run the namelist fuzzer (tests/fuzz/fuzz_namelist.c) for SECONDS.
# usage: tests/fuzz/run.sh BINARY SECONDS [merge]
#   The seed corpus is tests/fuzz/corpus (kept in git); new inputs go to build/fuzz/corpus.
#   With 'merge', the inputs that add coverage are merged back into tests/fuzz/corpus.
# Prints one line "fuzz: N executions in T s (R/s), C crashes, H hangs, ..." and exits 1 on a
# finding, with the input saved under build/fuzz/ and the command that reproduces it.
set -u
bin=$1
secs=$2
mode=${3:-}
cd "$(dirname "$0")/../.."
work=build/fuzz
mkdir -p "$work/corpus" "$work/findings"
log=$work/fuzz.log
touch "$log.start"; sleep 1
t0=$(date +%s)
ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1} "$bin" -max_total_time="$secs" -timeout=10 -rss_limit_mb=4096 \
  -print_final_stats=1 -artifact_prefix="$work/findings/" "$work/corpus" tests/fuzz/corpus >"$log" 2>&1
rc=$?
t1=$(date +%s)
execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
crashes=$(find "$work/findings" -name 'crash-*' -newer "$log.start" 2>/dev/null | wc -l)
leaks=$(find "$work/findings" -name 'leak-*' -newer "$log.start" 2>/dev/null | wc -l)
hangs=$(find "$work/findings" -name 'timeout-*' -newer "$log.start" 2>/dev/null | wc -l)
ncorp=$(find "$work/corpus" tests/fuzz/corpus -type f | wc -l)
echo "fuzz: ${execs:-0} executions in $((t1 - t0)) s ($(( ${execs:-0} / ( t1 - t0 > 0 ? t1 - t0 : 1) ))/s)," \
     "$crashes crashes, $hangs hangs, $leaks leaks; corpus $ncorp inputs; $(date -u +%Y-%m-%d)"
if [ "$rc" -ne 0 ]; then
  grep -a -E '^(fuzz:|==[0-9]+==ERROR|SUMMARY)|nml:[0-9]+:' "$log" | head -20
  for f in $(find "$work/findings" -type f -newer "$log.start"); do
    echo "finding: $f (reproduce: $bin $f)"
  done
  echo "fuzz: the fuzzer stopped on a finding (exit $rc); full log in $log" >&2
  exit 1
fi
if [ "$mode" = merge ]; then
  "$bin" -merge=1 tests/fuzz/corpus "$work/corpus" >"$work/merge.log" 2>&1 || { tail "$work/merge.log"; exit 1; }
  echo "fuzz: tests/fuzz/corpus now holds $(ls tests/fuzz/corpus | wc -l) inputs"
fi
