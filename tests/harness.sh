# The test scripts' runner, sourced by tests/run_all.sh and tests/sanitize.sh. `run NAME CMD...`
# runs CMD with its output in $log_dir/NAME.log (slashes in NAME become _) and counts it in pass
# or fail. It fails on a non-zero exit, or on a log line matching $bad_log where that is set; a
# failure prints the log's lines matching $show_log.
pass=0
fail=0
run() {
  local name=$1
  shift
  local f="$log_dir/${name//\//_}.log"
  local t1=$SECONDS
  if "$@" >"$f" 2>&1 && { [ -z "${bad_log:-}" ] || ! grep -qE "$bad_log" "$f"; }; then
    pass=$((pass + 1))
    printf 'PASS %-40s (%ds)\n' "$name" $((SECONDS - t1))
  else
    fail=$((fail + 1))
    printf 'FAIL %-40s (log %s)\n' "$name" "$f"
    grep -E "$show_log" "$f" | head -20
  fi
}
