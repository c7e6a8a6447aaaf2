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
#                               corpus in build/fuzz/corpus/NAME/; a table of executions at the end
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
for name in "${selected[@]}"; do
  bin=build/fuzz/fuzz_$name seeds=tests/fuzz/corpus/${name%_crc}   # prt_crc: the prt seeds
  opts=(-timeout=60 -rss_limit_mb=2048 -artifact_prefix=build/fuzz/findings/"$name"- -print_final_stats=1)
  if [ -n "$seconds" ]; then
    work=build/fuzz/corpus/$name
    mkdir -p "$work"
    out=$("$bin" "${opts[@]}" -max_total_time="$seconds" "$work" "$seeds" 2>&1); rc=$?
  else
    work=$(mktemp -d)
    out=$("$bin" "${opts[@]}" -runs=0 "$seeds" 2>&1) && \
      out=$("$bin" "${opts[@]}" -seed=1 -runs="${FUZZ_SMOKE_RUNS:-2000}" -max_total_time="${FUZZ_SMOKE_SECONDS:-5}" \
            "$work" "$seeds" 2>&1); rc=$?
    rm -rf "$work"
  fi
  execs=$(printf '%s\n' "$out" | sed -n 's/^stat::number_of_executed_units: *//p' | tail -n 1)
  if [ $rc -eq 0 ]; then
    pass=$((pass + 1))
    echo "fuzz/$name: ${execs:-0} executions, no finding"
  else
    fail=$((fail + 1))
    printf '%s\n' "$out" | grep -v '^#\|^INFO\|^stat::' | tail -n 40
    echo "FAIL fuzz/$name: finding after ${execs:-?} executions (input in build/fuzz/findings/)"
  fi
  table="$table$(printf '  %-10s %12s executions  %s' "$name" "${execs:-?}" "$([ $rc -eq 0 ] && echo ok || echo FINDING)")"$'\n'
done
if [ -n "$seconds" ]; then
  printf 'fuzzing, %s s each:\n%s' "$seconds" "$table"
  [ $fail -eq 0 ]
  exit
fi
echo "CHECKS $pass $fail $skip"
[ $fail -eq 0 ]
