#!/usr/bin/env bash
# bench_gl.sh - light-change and view-change frame rates of the GL runtime and the CPU
# runtime at K = 1 and K = 4 BRDF terms, beside the paper's Table II (Bunny: GeForce 6800,
# Pentium 4 2.4 GHz): `prt bench --backend gl` and `--backend cpu`. A benchmark, not a test.
# The view change is each backend's own: GL, one SIZE frame with per-pixel view maps; CPU,
# the per-vertex colours (no raster), as the paper's CPU rows.
#
# usage: tools/bench_gl.sh FILE.prt PROBE [FILE_K1.prt]
#        tools/bench_gl.sh MODEL.obj PROBE          precomputes K=1 and K=4 files first
#                                                  (paper-phong, 31,000-vertex floor, N = 128)
# env:   PRT=build/prt  SIZE=800x600  RUNS=5 (frames timed)  PRT_GL=osmesa|egl (GL context; default: EGL
#        on a machine with an NVIDIA GPU, else OSMesa software rendering)
#
# With one .prt file the K=1 row uses its first BRDF term for view changes (--terms 1) but
# still relights every term the file holds, so its light change is the K=4 cost; pass a
# K=1 file (or an OBJ) for the paper's 1-term light change.
set -euo pipefail
PRT=${PRT:-build/prt}
SIZE=${SIZE:-800x600}
RUNS=${RUNS:-5}
if [ $# -lt 2 ]; then sed -n '2,16p' "$0" | sed 's/^# \{0,1\}//'; exit 2; fi
in=$1; probe=$2; k1=${3:-}
[ -x "$PRT" ] || { echo "bench_gl: $PRT not built (run make)" >&2; exit 1; }
case "$in" in
*.obj|*.OBJ|*.json)
    tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
    for k in 1 4; do
        echo "precomputing $in with K=$k ..." >&2
        "$PRT" precompute "$in" --material paper-phong --floor 31000 --glossy svd --no-bounces --terms $k --quiet -o "$tmp/k$k.prt"
    done
    k4="$tmp/k4.prt"; k1="$tmp/k1.prt" ;;
*) k4=$in ;;
esac

run() { # file terms -> the two backends' "bench:" key=value lines, prefixed gl_ / cpu_
    for b in gl cpu; do
        "$PRT" bench "$1" --probe "$probe" --backend $b --size "$SIZE" --frames "$RUNS" --terms "$2" | tee /dev/stderr |
            grep '^bench:' | sed "s/ \([a-z_]*\)=/ ${b}_\1=/g"
    done | tr '\n' ' '
}
line1=$(run "${k1:-$k4}" 1)
line4=$(run "$k4" 4)
get() { echo "$1" | tr ' ' '\n' | sed -n "s/^$2=//p"; }
fps() { awk -v ms="$1" 'BEGIN { if (ms > 0) printf "%.1f", 1000 / ms; else printf "-" }'; }

echo
echo "frame rates (fps), this machine vs the paper's Table II (Bunny, GPU/CPU):"
printf '%-4s %-14s %12s %12s    %-20s\n' "K" "" "GL" "CPU" "paper GPU/CPU"
for K in 1 4; do
    l=$([ $K = 1 ] && echo "$line1" || echo "$line4")
    if [ $K = 1 ]; then pl="31 / 12"; pv="226 / 79"; else pl="- / 4.8"; pv="97 / 62"; fi
    printf '%-4s %-14s %12s %12s    %-20s\n' "$K" "light change" "$(fps "$(get "$l" gl_light_ms)")" "$(fps "$(get "$l" cpu_light_ms)")" "$pl"
    printf '%-4s %-14s %12s %12s    %-20s\n' "" "view change" "$(fps "$(get "$l" gl_view_ms)")" "$(fps "$(get "$l" cpu_view_ms)")" "$pv"
done
[ -z "$k1" ] && echo "(K=1 light change relit all of the file's terms: pass a K=1 file or an OBJ for the paper's 1-term figure)"
echo "GL light kernel: $(get "$line4" gl_kernel); frame size $SIZE; $(nproc) CPU cores"
