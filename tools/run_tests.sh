#!/usr/bin/env bash
# Runs each test binary, prints its output, and closes with one line
# "N passed, N failed" summed over every check of every binary (", N skipped"
# follows when a filter left cases out: `make test T=haar` sets $T, which each
# binary reads as its case filter, or a build without GL skipped the cases that need
# it, each named with its reason; see tests/harness.h).
# A binary that crashes or exits non-zero without counting counts as one failure.
#
# Binaries run $TEST_JOBS at a time (default 2): many of them spend their time starting
# `prt` processes or in one thread, so two at once use both cores (measured: see
# docs/design/tests.md). Each binary's output is kept whole and printed in the order given. Every test
# writes only under its own fresh build/tmp/t<pid>-XXXXXX (tests/harness.h: check_tmpdir), so two binaries
# never share a file.
set -u
total_pass=0; total_fail=0; total_skip=0; t0=$(date +%s)
jobs_max=${TEST_JOBS:-2}
work=$(mktemp -d "${TMPDIR:-/tmp}/prt-tests.XXXXXX")
trap 'rm -rf "$work"' EXIT
bins=("$@")

# run_one I BIN: runs BIN, leaving its output in $work/I.out, its status and seconds in $work/I.rc.
run_one() {
  local start rc secs
  start=$(date +%s.%N)
  "$2" > "$work/$1.out" 2>&1; rc=$?
  secs=$(awk -v a="$start" -v b="$(date +%s.%N)" 'BEGIN{printf "%.1f", b-a}')
  echo "$rc $secs" > "$work/$1.rc.tmp" && mv "$work/$1.rc.tmp" "$work/$1.rc"
}

# report I: prints binary I's output and adds its counts.
report() {
  local t=${bins[$1]} name out rc secs line p f s
  name=$(basename "$t")
  read -r rc secs < "$work/$1.rc"
  out=$(cat "$work/$1.out")
  line=$(printf '%s\n' "$out" | grep '^CHECKS ' | tail -n 1)
  p=$(echo "$line" | awk '{print $2}'); f=$(echo "$line" | awk '{print $3}'); s=$(echo "$line" | awk '{print $4}')
  [ -z "$p" ] && p=0; [ -z "$f" ] && f=0; [ -z "$s" ] && s=0
  if [ "$rc" -ne 0 ] && [ "$f" = 0 ]; then f=1; fi
  total_skip=$((total_skip + s))
  # a binary whose every case the filter left out prints nothing but its count
  if [ -n "${T:-}" ] && [ "$p" = 0 ] && [ "$f" = 0 ] && [ "$rc" -eq 0 ]; then return; fi
  printf '%s\n' "$out" | grep -v '^CHECKS '
  if [ "$rc" -ne 0 ] && [ -z "$line" ]; then echo "$name: exited with status $rc"; fi
  echo "== $name: $p passed, $f failed (${secs}s)"
  total_pass=$((total_pass + p)); total_fail=$((total_fail + f))
}

next=0   # the next binary to report, in order
flush() { while [ "$next" -lt "${#bins[@]}" ] && [ -f "$work/$next.rc" ]; do report "$next"; next=$((next + 1)); done; }
running=0
for i in "${!bins[@]}"; do
  while [ "$running" -ge "$jobs_max" ]; do wait -n; running=$((running - 1)); flush; done
  run_one "$i" "${bins[$i]}" &
  running=$((running + 1))
done
wait
flush
echo "test suite took $(( $(date +%s) - t0 ))s"
if [ "$total_skip" -gt 0 ]; then
  if [ -n "${T:-}" ]; then echo "filter '${T:-}': $total_skip cases left out"
  else echo "$total_skip cases skipped (each named above with its reason)"; fi
  echo "$total_pass passed, $total_fail failed, $total_skip skipped"
else
  echo "$total_pass passed, $total_fail failed"
fi
[ "$total_fail" -eq 0 ]
