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
#                               they merge what they find; logs in build/fuzz/logs/)
#   tools/fuzz.sh --runs R      `make fuzz FUZZ_RUNS=R`: each harness to R executions in all, split
#                               over the FUZZ_JOBS processes (-runs=ceil(R/N) each); with --seconds
#                               too, whichever comes first. Both long modes end with a table:
#                               harness, executions (all jobs), wall seconds, executions per
#                               second (wall), findings. Stopped early (Ctrl-C, SIGTERM), the jobs
#                               print their counts and the table still comes, with the counts so far.
# Each harness also gets the libFuzzer options of tests/fuzz/fuzz_NAME.options when there is one
# (lines of flags; '#' starts a comment line), in every mode.
# A finding (sanitizer report, PRT_CHECK, broken invariant, one input running over 60 s of wall
# time: at 10 s a loaded machine made one of an input that takes 0.9 s of CPU) leaves its input
# in build/fuzz/findings/ and fails the run; reproduce with build/fuzz/fuzz_NAME FILE. $T filters the
# harnesses by name ("fuzz/obj") as it filters test cases. FUZZ_NO_BUILD=1 runs the binaries
# already in build/fuzz/ without make (the folder tools/fuzz_pack.sh writes: no compiler there).
set -u
cd "$(dirname "$0")/.."
seconds="" runs=""
while [ $# -gt 0 ]; do
  case "$1" in
    --seconds) seconds="${2:-60}"; shift; [ $# -gt 0 ] && shift ;;
    --runs) runs="${2:-}"; shift; [ $# -gt 0 ] && shift; [ -n "$runs" ] || { echo "fuzz: --runs takes a number of executions"; exit 2; } ;;
    *) echo "fuzz: unknown argument '$1' (--seconds S, --runs R)"; exit 2 ;;
  esac
done
for v in "$seconds" "$runs"; do
  case "$v" in *[!0-9]*|0) echo "fuzz: --seconds and --runs take a positive integer (got '$v')"; exit 2 ;; esac
done
long=""
[ -n "$seconds$runs" ] && long=1
build=1
[ "${FUZZ_NO_BUILD:-0}" = 1 ] && build=""
libfuzzer=$(ls /usr/lib/llvm-*/lib/clang/*/lib/linux/libclang_rt.fuzzer-x86_64.a 2>/dev/null | head -n 1)
if [ -z "$long" ] && [ -n "$build" ] && { ! command -v clang >/dev/null || [ -z "$libfuzzer" ]; }; then
  echo "fuzz: skipped: clang's libFuzzer is not installed (make fuzz installs it: apt-get install clang libclang-rt-dev)"
  echo "CHECKS 0 0 0"
  exit 0
fi
# the harnesses $T selects (all without a filter); none: nothing to build
selected=()
total=0
for src in tests/fuzz/fuzz_*.c build/fuzz/fuzz_*; do
  [ -e "$src" ] || continue
  case "$src" in tests/*) [ -n "$build" ] || continue ;; *) [ -z "$build" ] || continue ;; esac
  name=$(basename "$src" .c); name=${name#fuzz_}
  total=$((total + 1))
  if [ -n "${T:-}" ] && [[ "fuzz/$name" != *"$T"* ]]; then continue; fi
  selected+=("$name")
done
if [ ${#selected[@]} -eq 0 ]; then
  [ -z "$long" ] && echo "CHECKS 0 0 $total"
  exit 0
fi
if [ -n "$build" ] && ! log=$(make --no-print-directory -j"$(nproc)" fuzz-build 2>&1); then
  printf '%s\n' "$log" | tail -n 20
  echo "fuzz: building the harnesses failed"
  [ -z "$long" ] && echo "CHECKS 0 1 0"
  exit 1
fi
mkdir -p build/fuzz/findings
pass=0; fail=0
table=""
skip=$((total - ${#selected[@]}))
jobs_n=${FUZZ_JOBS:-1}
case "$jobs_n" in ''|*[!0-9]*|0) echo "fuzz: FUZZ_JOBS must be a positive integer (got '$jobs_n')"; exit 2 ;; esac
limits=()
[ -n "$seconds" ] && limits+=(-max_total_time="$seconds")
[ -n "$runs" ] && limits+=(-runs=$(( (runs + jobs_n - 1) / jobs_n )))
stopped=0; pids=()
# Ctrl-C or SIGTERM: each job gets SIGINT, prints its final stats and exits; the table follows.
on_stop() { stopped=1; for p in "${pids[@]}"; do kill -INT "$p" 2>/dev/null; done; }
[ -n "$long" ] && trap on_stop INT TERM

# fuzz_run NAME: runs harness NAME on $jobs_n processes to $limits; sets rc, execs, wall, rate, out (the logs)
fuzz_run() {
  local name=$1 bin=build/fuzz/fuzz_$1 seeds=tests/fuzz/corpus/${1%_crc} work=build/fuzz/corpus/$1 logs=build/fuzz/logs
  local base=$(( ($(date +%s) + $$) % 100000 * 64 )) t0 t1 j c
  mkdir -p "$work" "$logs"
  rm -f "$logs/$name".*.log
  t0=$(date +%s.%N)
  pids=()
  for ((j = 0; j < jobs_n; j++)); do
    "$bin" "${opts[@]}" -seed=$((base + j + 1)) "${limits[@]}" "$work" "$seeds" >"$logs/$name.$j.log" 2>&1 &
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
  wall=$(awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.0f", b - a }')
  rate=$(awk -v e="$execs" -v a="$t0" -v b="$t1" 'BEGIN { d = b - a; printf "%.0f", (d > 0 ? e / d : 0) }')
  out=$(cat "$logs/$name".*.log)
}

# commas NUMBER: 12345678 -> 12,345,678
commas() { echo "$1" | sed ':a;s/\B[0-9]\{3\}\>/,&/;ta'; }

for name in "${selected[@]}"; do
  bin=build/fuzz/fuzz_$name seeds=tests/fuzz/corpus/${name%_crc}   # prt_crc: the prt seeds
  opts=(-timeout=60 -rss_limit_mb=2048 -artifact_prefix=build/fuzz/findings/"$name"- -print_final_stats=1)
  [ -f "tests/fuzz/fuzz_$name.options" ] && opts+=($(grep -v '^#' "tests/fuzz/fuzz_$name.options"))
  if [ -n "$long" ]; then
    if [ $stopped -eq 1 ]; then
      table="$table$(printf '| %-9s | %13s | %7s | %9s | %s |' "$name" "-" "-" "-" "not run (stopped)")"$'\n'
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
  if [ -n "$long" ]; then
    table="$table$(printf '| %-9s | %13s | %7s | %9s | %s |' "$name" "$(commas "$execs")" "$wall" "$(commas "$rate")" \
                   "$([ $rc -eq 0 ] && echo none || echo "FINDING (build/fuzz/findings/$name-*)")")"$'\n'
  fi
done
if [ -n "$long" ]; then
  printf 'fuzzing%s%s on %s job(s) of %s core(s)%s (load %s):\n' "${runs:+, to $(commas "$runs") executions}" \
    "${seconds:+, at most $seconds s}" "$jobs_n" "$(nproc)" "$([ $stopped -eq 1 ] && echo ', stopped early')" \
    "$(cut -d' ' -f1-3 /proc/loadavg 2>/dev/null || echo '?')"
  printf '| harness   |    executions |  wall s |    exec/s | findings |\n|---|---:|---:|---:|---|\n%s' "$table"
  [ $fail -eq 0 ]
  exit
fi
echo "CHECKS $pass $fail $skip"
[ $fail -eq 0 ]
