#!/usr/bin/env bash
# tools/shimmer.sh - the far floor's ratio to the exact transport as the light turns
# (docs/design/shadows.md). A plane alone (every vertex unoccluded: what every far-floor vertex of a
# scene stores) is precomputed three ways: the defaults (Haar of the transport per steradian,
# N = 128, 8-bit), the paper's texel measure (--texel-measure, same storage), and
# uncompressed (all 24,576 coefficients, float: the exact product of the 6x64x64 cube, which
# agrees with prt reference to about 0.1%). It renders vertex 0 under PROBE turned in STEP-degree
# yaw steps through 90 degrees (yaw by 90 degrees maps the cube onto itself, so the pattern repeats)
# and prints, per degree, each compressed file's radiance over the uncompressed one's; then per
# file the mean, the worst |ratio - 1| and the largest change between neighbouring steps.
#   tools/shimmer.sh [PROBE.exr] [build/prt]      (STEP=1 END=90 by default; about 5 minutes)
#   SHIMMER_FLAGS="--budget shared"               precompute flags of the default file (the first column)
set -eu
PROBE=${1:-../shared/data/probes/city.exr}
PRT=${2:-build/prt}
STEP=${STEP:-1}; END=${END:-90}
W=build/shimmer
mkdir -p "$W"
[ -f "$PROBE" ] || { echo "shimmer: $PROBE not found" >&2; exit 1; }
cat > "$W/plane.json" <<'J'
{ "comment": "tools/shimmer.sh: an unoccluded plane",
  "models": [ { "plane": { "x": [-1, 1], "z": [-1, 1], "height": 0, "nx": 2, "nz": 2 }, "material": "lambert:kd=0.7" } ] }
J
"$PRT" precompute "$W/plane.json" --quiet ${SHIMMER_FLAGS:-} -o "$W/sa.prt" >/dev/null
"$PRT" precompute "$W/plane.json" --quiet --texel-measure -o "$W/texel.prt" >/dev/null
"$PRT" precompute "$W/plane.json" --quiet --coeffs 24576 --quant 32 -o "$W/exact.prt" >/dev/null
v0() { # file degrees -> r+g+b of vertex 0
  "$PRT" render "$1" --probe "$PROBE" --size 8x8 -o "$W/x.exr" --vertices "$W/x.csv" --light-rotation "$2" 2>/dev/null
  awk -F, 'NR == 2 { printf "%.9g\n", $2 + $3 + $4 }' "$W/x.csv"
}
echo "degrees  solid-angle(default)  texel(paper)"
for ((d = 0; d <= END; d += STEP)); do
  e=$(v0 "$W/exact.prt" $d); a=$(v0 "$W/sa.prt" $d); t=$(v0 "$W/texel.prt" $d)
  awk -v d=$d -v e="$e" -v a="$a" -v t="$t" 'BEGIN { printf "%7d  %20.4f  %12.4f\n", d, a / e, t / e }'
done | tee "$W/ratios.txt"
awk '{ for (c = 2; c <= 3; c++) { x = $c; s[c] += x; n[c]++; d = x > 1 ? x - 1 : 1 - x; if (d > w[c]) w[c] = d;
       if (NR > 1) { j = x > p[c] ? x - p[c] : p[c] - x; if (j > st[c]) st[c] = j } p[c] = x } }
     END { split("- solid-angle(default) texel(paper)", nm, " ");
           for (c = 2; c <= 3; c++) printf "%s: mean %.4f, worst |ratio-1| %.2f%%, largest step %.2f%%\n", nm[c], s[c] / n[c], 100 * w[c], 100 * st[c] }' \
  "$W/ratios.txt"
