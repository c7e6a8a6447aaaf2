#!/usr/bin/env bash
# Runs each test binary, prints its output, and closes with one line
# "N passed, N failed" summed over every check of every binary (", N skipped"
# follows when a filter left cases out: `make test T=haar` sets $T, which each
# binary reads as its case filter; see tests/harness.h).
# A binary that crashes or exits non-zero without counting counts as one failure.
set -u
total_pass=0; total_fail=0; total_skip=0; t0=$(date +%s)
for t in "$@"; do
  name=$(basename "$t")
  start=$(date +%s.%N)
  out=$("$t" 2>&1); rc=$?
  secs=$(awk -v a="$start" -v b="$(date +%s.%N)" 'BEGIN{printf "%.1f", b-a}')
  line=$(printf '%s\n' "$out" | grep '^CHECKS ' | tail -n 1)
  p=$(echo "$line" | awk '{print $2}'); f=$(echo "$line" | awk '{print $3}'); s=$(echo "$line" | awk '{print $4}')
  [ -z "$p" ] && p=0; [ -z "$f" ] && f=0; [ -z "$s" ] && s=0
  if [ $rc -ne 0 ] && [ "$f" = 0 ]; then f=1; fi
  total_skip=$((total_skip + s))
  # a binary whose every case the filter left out prints nothing but its count
  if [ -n "${T:-}" ] && [ "$p" = 0 ] && [ "$f" = 0 ] && [ $rc -eq 0 ]; then continue; fi
  printf '%s\n' "$out" | grep -v '^CHECKS '
  if [ $rc -ne 0 ] && [ -z "$line" ]; then echo "$name: exited with status $rc"; fi
  echo "== $name: $p passed, $f failed (${secs}s)"
  total_pass=$((total_pass + p)); total_fail=$((total_fail + f))
done
echo "test suite took $(( $(date +%s) - t0 ))s"
if [ "$total_skip" -gt 0 ]; then
  echo "filter '${T:-}': $total_skip cases left out"
  echo "$total_pass passed, $total_fail failed, $total_skip skipped"
else
  echo "$total_pass passed, $total_fail failed"
fi
[ "$total_fail" -eq 0 ]
