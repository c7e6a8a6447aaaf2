#!/usr/bin/env bash
# bench_gl_lights.sh - the gl runtime with local lights: light-move, view-change (one
# per-pixel frame) and effect times of two scenes, as one table. A benchmark, not a test: it prints
# what `prt bench` measured and asserts nothing.
#
#   tools/bench_gl_lights.sh [build/prt]
#
#   1. bunny + floor (65,810 vertices: make bench's build/bench/bunny.prt, else precomputed here from
#      the Stanford bunny, paper-phong, a 31,000-vertex floor, --no-bounces), the city probe and a spot
#      light above the bunny (tools/bench_lights.sh's): direct; direct + VSGLs (--local-bounce, the
#      glossy bunny's VSGL term per pixel); the cpu runtime's direct + VSGLs beside it.
#   2. data/chrome-point.json (16,500 vertices, --probe none, one point light): direct; + VSGLs;
#      + VSGLs + indirect highlights (32 rays per glossy vertex, on the CPU, added per vertex).
#
# env: PRT_GL=egl|osmesa (the GL context: EGL on a GPU machine, OSMesa/llvmpipe otherwise; the
#      default picks EGL where an NVIDIA GPU is present), PRT_DATA (default ../shared/data),
#      SIZE (800x600), FRAMES (10 timed light moves and view changes per row), OUT (build/bench/gl_lights).
# Precomputes use --threads $(nproc); on a 16-core machine the whole run is about 2-3 minutes, most
# of it the bunny's precompute (skipped when make bench made it) and the cpu rows.
# Columns: "light move" is prt bench's local light move (the light on a small circle: shadow maps,
# and the VSGLs' RSM + sums on the CPU, "of it: bounce"); "frame" its view change: one SIZE frame per
# pixel, finished (with the highlights' per-vertex CPU pass, "indirect of frame"); "GPU" the timer
# query of that frame's draw. Medians in ms; the wall-clock figures depend on the machine's load, so
# the load average and this script's CPU time are printed beneath.
set -u
PRT=${1:-build/prt}
DATA=${PRT_DATA:-../shared/data}
SIZE=${SIZE:-800x600}
FRAMES=${FRAMES:-10}
OUT=${OUT:-build/bench/gl_lights}
T=$(nproc)
[ -x "$PRT" ] || { echo "bench_gl_lights: $PRT not built (run make)" >&2; exit 1; }
mkdir -p "$OUT"

BUNNY=build/bench/bunny.prt
if [ ! -f "$BUNNY" ]; then
  BUNNY=$OUT/bunny.prt
  if [ ! -f "$BUNNY" ]; then
    [ -f "$DATA/models/stanford-bunny.obj" ] || { echo "bench_gl_lights: no $DATA/models/stanford-bunny.obj (set PRT_DATA)" >&2; exit 1; }
    echo "precomputing the bunny + floor ($T threads) ..." >&2
    "$PRT" precompute "$DATA/models/stanford-bunny.obj" --material paper-phong --floor 31000 --glossy svd --terms 4 --no-bounces \
      --threads "$T" --quiet -o "$BUNNY" 2> "$OUT/bunny.log" || { echo "bench_gl_lights: bunny precompute failed (see $OUT/bunny.log)" >&2; exit 1; }
  fi
fi
CHROME=$OUT/chrome.prt
if [ ! -f "$CHROME" ]; then
  echo "precomputing data/chrome-point.json ($T threads) ..." >&2
  "$PRT" precompute data/chrome-point.json --no-bounces --vis-res 64 --threads "$T" --quiet -o "$CHROME" 2> "$OUT/chrome.log" ||
    { echo "bench_gl_lights: chrome-point precompute failed (see $OUT/chrome.log)" >&2; exit 1; }
fi
# The spot light of tools/bench_lights.sh: above the bunny (bounds from prt info), aimed at its centre.
read -r x0 y0 z0 x1 y1 z1 < <("$PRT" info "$BUNNY" | sed -n 's/^bounds *\[\(.*\)\] - \[\(.*\)\]/\1 \2/p')
SPOT=$(awk -v x0="$x0" -v y0="$y0" -v z0="$z0" -v x1="$x1" -v y1="$y1" -v z1="$z1" 'BEGIN{
  cx = (x0 + x1) / 2; cz = (z0 + z1) / 2; s = x1 - x0; if (z1 - z0 > s) s = z1 - z0;
  printf "spot:pos=%g,%g,%g;dir=0.3,-1,0.2;inner=25;outer=45;intensity=%g", cx - 0.3 * s, y1 + s, cz - 0.2 * s, s * s }')

# One row: label, file, probe, backend, extra flags -> "| ... |" with the figures of prt bench.
row() {
  local label=$1 file=$2 probe=$3 backend=$4; shift 4
  local log="$OUT/$(echo "$label" | tr -c 'a-zA-Z0-9\n' '_').log"
  if ! "$PRT" bench "$file" --probe "$probe" --backend "$backend" --frames "$FRAMES" --size "$SIZE" --threads "$T" "$@" > "$log" 2>&1; then
    printf '| %-44s | %-4s | %s |\n' "$label" "$backend" "failed (see $log)"
    return
  fi
  [ "$backend" = gl ] && [ -z "${DEVICE:-}" ] && DEVICE=$(sed -n 's/^backend gl: \(.*\); light kernel.*/\1/p' "$log")
  local move view gpu bounce hl
  move=$(sed -n 's/^local light move.*: \([0-9.]*\) ms median.*/\1/p' "$log")
  view=$(sed -n 's/^view change: *\([0-9.]*\) ms median.*/\1/p' "$log")
  gpu=$(sed -n 's/^GPU timer:.*view change \([0-9.]*\) ms.*/\1/p' "$log")
  bounce=$(sed -n 's/^local indirect: one bounce[^0-9]*2 VSGLs per light) \([0-9.]*\) ms of the move.*/\1/p' "$log")
  hl=$(sed -n 's/^local indirect:.* \([0-9.]*\) ms of the view change.*/\1/p' "$log")
  printf '| %-44s | %-4s | %10s | %8s | %10s | %8s | %10s |\n' "$label" "$backend" "${move:--}" "${bounce:--}" "${view:--}" \
    "${gpu:--}" "${hl:--}"
}

{
  echo "gl runtime with local lights: $SIZE frames, $FRAMES moves / frames per row, $T threads"
  echo
  printf '| %-44s | %-4s | %10s | %8s | %10s | %8s | %10s |\n' "scene, effects" "run" "light move" "of it: bounce" "frame" "GPU" \
    "indirect of frame"
  echo "|---|---|---|---|---|---|---|"
  row "bunny + floor, city + spot: direct" "$BUNNY" "$DATA/probes/city.exr" gl --light "$SPOT"
  row "bunny + floor, city + spot: direct + VSGLs" "$BUNNY" "$DATA/probes/city.exr" gl --light "$SPOT" --local-bounce
  row "bunny + floor, city + spot: direct + VSGLs" "$BUNNY" "$DATA/probes/city.exr" cpu --light "$SPOT" --local-bounce
  row "chrome-point: direct" "$CHROME" none gl
  row "chrome-point: direct + VSGLs" "$CHROME" none gl --local-bounce
  row "chrome-point: direct + VSGLs + highlights (32)" "$CHROME" none gl --local-bounce --highlights
  echo
  echo "GL: ${DEVICE:-?}; PRT_GL=${PRT_GL:-(default)}; load average $(cut -d' ' -f1-3 /proc/loadavg)"
  echo "cpu rows: frame = the per-vertex colours (no raster), as prt bench times the cpu runtime"
} | tee "$OUT/table.md"
echo "CPU time of this script (user, system), then of its children:"
times
