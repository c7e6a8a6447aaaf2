#!/usr/bin/env bash
# fuzz.sh - runs the libFuzzer harnesses of tests/fuzz/ (built by `make fuzz-build` with clang,
# ASan and UBSan into build/fuzz/).
#   tools/fuzz.sh               the smoke run `make test` ends with: every seed of
#                               tests/fuzz/corpus/NAME/, then FUZZ_SMOKE_RUNS (2000) mutations from
#                               the fixed seed 1, cut at FUZZ_SMOKE_SECONDS (5) each: the same inputs
#                               on every machine (a slower one runs a prefix of them), so the suite
#                               cannot fail by chance on a bug the last full run did not meet;
#                               prints "CHECKS pass fail skipped" like a test binary, and a
#                               skip reason when clang's libFuzzer is not installed
#   tools/fuzz.sh --seconds S   `make fuzz FUZZ_SECONDS=S`: each harness for S seconds, growing its
#                               corpus in build/fuzz/corpus/NAME/; FUZZ_JOBS=N (default 1) runs N
#                               processes of each harness at once (seeds 1..N apart from a
#                               per-run base, one shared corpus folder that each reloads, so
#                               they merge what they find; logs in build/fuzz/logs/); a table at
#                               the end: harness, executions (all jobs), executions per second
#                               (wall), findings. Stopped early (Ctrl-C, SIGTERM), the jobs print
#                               their counts and the table still comes, with the counts so far.
# A finding (sanitizer report, PRT_CHECK, broken invariant, one input running over 60 s of wall
# time: at 10 s a loaded machine made one of an input that takes 0.9 s of CPU) leaves its input
# in build/fuzz/findings/ and fails the run; reproduce with build/fuzz/fuzz_NAME FILE. $T filters the
# harnesses by name ("fuzz/obj") as it filters test cases.
set -u
cd "$(dirname "$0")/.."
seconds=""
[ "${1:-}" = "--seconds" ] && seconds="${2:-60}"
libfuzzer=$(ls /usr/lib/llvm-*/lib/clang/*/lib/linux/libclang_rt.fuzzer-x86_64.a 2>/dev/null | head -n 1)
if [ -z "$seconds" ] && { ! command -v clang >/dev/null || [ -z "$libfuzzer" ]; }; then
  echo "fuzz: skipped: clang's libFuzzer is not installed (make fuzz installs it: apt-get install clang libclang-rt-dev)"
  echo "CHECKS 0 0 0"
  exit 0
fi
# the harnesses $T selects (all without a filter); none: nothing to build
selected=()
for src in tests/fuzz/fuzz_*.c; do
  name=$(basename "$src" .c); name=${name#fuzz_}
  if [ -n "${T:-}" ] && [[ "fuzz/$name" != *"$T"* ]]; then continue; fi
  selected+=("$name")
done
total=$(ls tests/fuzz/fuzz_*.c | wc -l)
if [ ${#selected[@]} -eq 0 ]; then
  [ -z "$seconds" ] && echo "CHECKS 0 0 $total"
  exit 0
fi
if ! log=$(make --no-print-directory -j"$(nproc)" fuzz-build 2>&1); then
  printf '%s\n' "$log" | tail -n 20
  echo "fuzz: building the harnesses failed"
  [ -z "$seconds" ] && echo "CHECKS 0 1 0"
  exit 1
fi
mkdir -p build/fuzz/findings
pass=0; fail=0
table=""
skip=$((total - ${#selected[@]}))
jobs_n=${FUZZ_JOBS:-1}
case "$jobs_n" in ''|*[!0-9]*|0) echo "fuzz: FUZZ_JOBS must be a positive integer (got '$jobs_n')"; exit 2 ;; esac
stopped=0; pids=()
# Ctrl-C or SIGTERM: each job gets SIGINT, prints its final stats and exits; the table follows.
on_stop() { stopped=1; for p in "${pids[@]}"; do kill -INT "$p" 2>/dev/null; done; }
[ -n "$seconds" ] && trap on_stop INT TERM

# fuzz_run NAME: runs harness NAME for $seconds on $jobs_n processes; sets rc, execs, rate, out (the logs)
fuzz_run() {
  local name=$1 bin=build/fuzz/fuzz_$1 seeds=tests/fuzz/corpus/${1%_crc} work=build/fuzz/corpus/$1 logs=build/fuzz/logs
  local base=$(( ($(date +%s) + $$) % 100000 * 64 )) t0 t1 j c
  mkdir -p "$work" "$logs"
  rm -f "$logs/$name".*.log
  t0=$(date +%s.%N)
  pids=()
  for ((j = 0; j < jobs_n; j++)); do
    "$bin" "${opts[@]}" -seed=$((base + j + 1)) -max_total_time="$seconds" "$work" "$seeds" >"$logs/$name.$j.log" 2>&1 &
    pids+=($!)
  done
  rc=0
  for p in "${pids[@]}"; do
    wait "$p"; c=$?
    while [ $c -gt 128 ] && [ $stopped -eq 1 ]; do wait "$p"; c=$?; done   # a trapped signal ended the wait: again
    [ $c -eq 127 ] && c=72                    # already reaped after the stop
    [ $c -ne 0 ] && [ $c -ne 72 ] && rc=$c    # 72: libFuzzer interrupted (SIGINT), not a finding
  done
  pids=()
  t1=$(date +%s.%N)
  execs=0
  for ((j = 0; j < jobs_n; j++)); do
    c=$(sed -n 's/^stat::number_of_executed_units: *//p' "$logs/$name.$j.log" | tail -n 1)
    execs=$((execs + ${c:-0}))
  done
  rate=$(awk -v e="$execs" -v a="$t0" -v b="$t1" 'BEGIN { d = b - a; printf "%.0f", (d > 0 ? e / d : 0) }')
  out=$(cat "$logs/$name".*.log)
}

for name in "${selected[@]}"; do
  bin=build/fuzz/fuzz_$name seeds=tests/fuzz/corpus/${name%_crc}   # prt_crc: the prt seeds
  opts=(-timeout=60 -rss_limit_mb=2048 -artifact_prefix=build/fuzz/findings/"$name"- -print_final_stats=1)
  if [ -n "$seconds" ]; then
    if [ $stopped -eq 1 ]; then
      table="$table$(printf '| %-9s | %13s | %9s | %s |' "$name" "-" "-" "not run (stopped)")"$'\n'
      continue
    fi
    fuzz_run "$name"
  else
    work=$(mktemp -d)
    out=$("$bin" "${opts[@]}" -runs=0 "$seeds" 2>&1) && \
      out=$("$bin" "${opts[@]}" -seed=1 -runs="${FUZZ_SMOKE_RUNS:-2000}" -max_total_time="${FUZZ_SMOKE_SECONDS:-5}" \
            "$work" "$seeds" 2>&1); rc=$?
    rm -rf "$work"
    execs=$(printf '%s\n' "$out" | sed -n 's/^stat::number_of_executed_units: *//p' | tail -n 1)
  fi
  if [ $rc -eq 0 ]; then
    pass=$((pass + 1))
    echo "fuzz/$name: ${execs:-0} executions, no finding"
  else
    fail=$((fail + 1))
    printf '%s\n' "$out" | grep -v '^#\|^INFO\|^stat::' | tail -n 40
    echo "FAIL fuzz/$name: finding after ${execs:-?} executions (input in build/fuzz/findings/)"
  fi
  if [ -n "$seconds" ]; then
    table="$table$(printf '| %-9s | %13s | %9s | %s |' "$name" "$(echo "$execs" | sed ':a;s/\B[0-9]\{3\}\>/,&/;ta')" "$rate" \
                   "$([ $rc -eq 0 ] && echo none || echo "FINDING (build/fuzz/findings/$name-*)")")"$'\n'
  fi
done
if [ -n "$seconds" ]; then
  printf 'fuzzing, %s s each on %s job(s)%s (load %s):\n' "$seconds" "$jobs_n" "$([ $stopped -eq 1 ] && echo ', stopped early')" \
    "$(cut -d' ' -f1-3 /proc/loadavg 2>/dev/null || echo '?')"
  printf '| harness   |    executions |    exec/s | findings |\n|---|---:|---:|---|\n%s' "$table"
  [ $fail -eq 0 ]
  exit
fi
echo "CHECKS $pass $fail $skip"
[ $fail -eq 0 ]
