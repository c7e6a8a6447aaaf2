#!/usr/bin/env bash
# test_portable.sh - `make test-portable`: the whole suite three times, each on code paths that
# another x86-64 CPU would take, so a tolerance that only this CPU's rounding meets fails here.
#   tools/test_portable.sh PRT_BIN TEST_BINARY...   (the arguments of tools/run_tests.sh)
# Results that go through OpenBLAS (kernels by CPU model), Embree (SIMD width by CPU), glibc's
# libm (FMA variants of exp/log/pow/sin... on CPUs with AVX2 + FMA) or llvmpipe (vector width
# by CPU) are not the same bits on every machine; each run swaps some of them:
#   1. OPENBLAS_CORETYPE=Nehalem       SSE kernels, no AVX, no FMA
#   2. OPENBLAS_CORETYPE=Sandybridge   AVX kernels without FMA (Penryn on a CPU without AVX)
#   3. OpenBLAS's own pick for this CPU ($OPENBLAS_CORETYPE unset: SkylakeX or Cooperlake on
#      an AVX-512 machine), Embree capped at SSE4.2 (PRT_EMBREE_CONFIG, visibility.c), libm's
#      non-FMA variants (GLIBC_TUNABLES=glibc.cpu.hwcaps=-AVX2,-FMA: glibc 2.33+ names; older
#      glibc ignores them) and llvmpipe at 128-bit vectors (LP_NATIVE_VECTOR_WIDTH=128).
# Each run prints the suite's output and its closing "N passed, N failed" line; the three are
# repeated at the end, and the script fails if any run failed. $T filters cases as in `make test`.
set -u
cd "$(dirname "$0")/.."
prt=$1; shift
tmp=$(mktemp -d "${TMPDIR:-/tmp}/prt-portable.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n' > "$tmp/tri.obj"   # for Embree's verbose ISA line

blas_b=Sandybridge
grep -qw avx /proc/cpuinfo 2>/dev/null || blas_b=Penryn
runs=("OPENBLAS_CORETYPE=Nehalem"
      "OPENBLAS_CORETYPE=$blas_b"
      "-u OPENBLAS_CORETYPE PRT_EMBREE_CONFIG=isa=sse4.2 GLIBC_TUNABLES=glibc.cpu.hwcaps=-AVX2,-FMA LP_NATIVE_VECTOR_WIDTH=128")
closing=(); failed=0
for i in "${!runs[@]}"; do
  read -r -a vars <<< "${runs[$i]}"
  echo "=== test-portable run $((i + 1))/${#runs[@]}: ${runs[$i]/-u OPENBLAS_CORETYPE/OPENBLAS_CORETYPE unset}"
  # what the libraries say they picked under these settings
  env "${vars[@]}" OPENBLAS_VERBOSE=2 "$prt" --help 2>&1 | grep -m1 '^Core:' | sed 's/^/    OpenBLAS /'
  cfg=$(env "${vars[@]}" printenv PRT_EMBREE_CONFIG)
  env "${vars[@]}" PRT_EMBREE_CONFIG="${cfg:+$cfg,}verbose=1" "$prt" precompute "$tmp/tri.obj" -o "$tmp/tri.prt" \
    --no-floor 2>&1 | grep -m1 '^    ISA' | sed 's/^ */    Embree device /'
  env "${vars[@]}" PRT_BIN="$prt" tools/run_tests.sh "$@" | tee "$tmp/run$i.log"
  rc=${PIPESTATUS[0]}
  [ "$rc" -ne 0 ] && failed=$((failed + 1))
  closing+=("run $((i + 1)) (${runs[$i]/-u OPENBLAS_CORETYPE/OPENBLAS_CORETYPE unset}): $(grep -E '^[0-9]+ passed, [0-9]+ failed' "$tmp/run$i.log" | tail -n 1)")
done
echo "=== test-portable:"
printf '%s\n' "${closing[@]}"
[ "$failed" -eq 0 ]
