#!/usr/bin/env bash
# Runs each test binary, prints its output, and closes with one line
# "N passed, N failed" summed over every check of every binary.
# A binary that crashes or exits non-zero without counting counts as one failure.
set -u
total_pass=0; total_fail=0; t0=$(date +%s)
for t in "$@"; do
  name=$(basename "$t")
  start=$(date +%s.%N)
  out=$("$t" 2>&1); rc=$?
  secs=$(awk -v a="$start" -v b="$(date +%s.%N)" 'BEGIN{printf "%.1f", b-a}')
  printf '%s\n' "$out" | grep -v '^CHECKS ' 
  line=$(printf '%s\n' "$out" | grep '^CHECKS ' | tail -n 1)
  p=$(echo "$line" | awk '{print $2}'); f=$(echo "$line" | awk '{print $3}')
  [ -z "$p" ] && p=0; [ -z "$f" ] && f=0
  if [ $rc -ne 0 ] && [ "$f" = 0 ]; then f=1; echo "$name: exited with status $rc"; fi
  echo "== $name: $p passed, $f failed (${secs}s)"
  total_pass=$((total_pass + p)); total_fail=$((total_fail + f))
done
echo "test suite took $(( $(date +%s) - t0 ))s"
echo "$total_pass passed, $total_fail failed"
[ "$total_fail" -eq 0 ]
