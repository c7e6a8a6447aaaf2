#!/usr/bin/env bash
# make bench-scale: the large scenes (data/scale-*.json: the bunny over a dense floor, about
# 100 K, 300 K and 1 M vertices). Not a test: it prints measured figures beside their
# targets and never turns a miss into a pass.
#   1. the direct pass (--no-bounces, one process, 2 threads) at each size: wall and CPU time, CPU
#      time per 1,000 vertices (linear in vertices: about the same at every size; the bunny's K = 4
#      vertices cost more than the floor's), peak memory (/usr/bin/time -v);
#   2. loading each size's file (mapped, prtfile_read): `prt info` (the whole load: map,
#      CRC on every core, every index validated) and `prt render` at 320x240 on 2 threads (its time
#      to the first frame: load, probe, light change, view change, raster, write), wall and CPU time
#      and peak memory of each;
#   3. `mpirun -np 2` (1 thread per rank, unbound) against one process with 2 threads on one scene.
#
#   tools/bench_scale.sh [build/prt]     (needs ../shared/data or $PRT_DATA, /usr/bin/time; writes build/bench-scale/)
#   SCALE_SIZES="100k 300k"              the sizes to run (default: 100k 300k 1m)
#   SCALE_NP=100k                        the scene of the -np 2 comparison (default 100k; "" skips it)
#   SCALE_OPTS="--vis-res 64"            extra precompute options for every run (default none)
set -u
PRT=${1:-build/prt}
OUT=build/bench-scale
SIZES=${SCALE_SIZES:-100k 300k 1m}
NP=${SCALE_NP-100k}
OPTS=${SCALE_OPTS:-}
mkdir -p "$OUT"
DATA=${PRT_DATA:-../shared/data}
if [ ! -f "$DATA/models/stanford-bunny.obj" ]; then
  echo "bench-scale: $DATA/models/stanford-bunny.obj not found (set PRT_DATA)" >&2
  exit 1
fi
DATA=$(cd "$DATA" && pwd)
# the scenes of data/, with the bunny's path made absolute (the data folder may be elsewhere)
for s in 100k 300k 1m; do sed "s#\.\./\.\./shared/data#$DATA#" "data/scale-$s.json" > "$OUT/scale-$s.json"; done
[ -x /usr/bin/time ] || { echo "bench-scale: /usr/bin/time not found (Debian package time)" >&2; exit 1; }

# run LABEL LOG CMD...: runs CMD under /usr/bin/time -v; prints "wall_s peak_gb vertices cpu_s" or "fail".
# CPU seconds (user + system) are the figure a loaded machine distorts least.
run() {
  local log=$2; shift 2
  /usr/bin/time -v "$@" > /dev/null 2> "$log" || { echo fail; return; }
  awk '/Elapsed \(wall clock\)/ { n = split($NF, t, ":"); s = 0; for (i = 1; i <= n; i++) s = s * 60 + t[i] }
       /Maximum resident set size/ { kb = $NF }
       /User time \(seconds\)|System time \(seconds\)/ { cpu += $NF }
       /^scene: / && !v { v = $2 }
       END { printf "%.2f %.2f %d %.2f\n", s, kb / 1e6, v, cpu }' "$log"
}

echo "== prt bench-scale: bunny (paper-phong, K = 4) over a dense Lambert floor, N = 128, direct pass only"
echo "   machine: $(nproc) cores, $(awk '/MemTotal/{printf "%.0f GB", $2/1e6}' /proc/meminfo), load $(cut -d' ' -f1-3 /proc/loadavg)${OPTS:+; options $OPTS}"
echo
printf "   %-6s %10s %10s %10s %16s %10s   %s\n" size vertices "wall s" "CPU s" "CPU s / 1K verts" "peak GB" "target (1 M: <= 25 min, <= 8 GB; linear)"
base=""
loads=""
for s in $SIZES; do
  r=$(run "$s" "$OUT/direct-$s.log" "$PRT" precompute "$OUT/scale-$s.json" --glossy svd --terms 4 --no-bounces --threads 2 $OPTS -o "$OUT/$s.prt")
  if [ "$r" != fail ]; then   # the file's load, printed after this table
    mb=$(stat -c %s "$OUT/$s.prt" | awk '{ printf "%.1f", $1 / 1e6 }')
    i=$(run info "$OUT/info-$s.log" "$PRT" info "$OUT/$s.prt")
    f=$(run render "$OUT/render-$s.log" "$PRT" render "$OUT/$s.prt" --probe "$DATA/probes/studio.exr" --size 320x240 --threads 2 -o "$OUT/render-$s.png")
    [ "$i" = fail ] && i="fail 0 0 0"
    [ "$f" = fail ] && f="fail 0 0 0"
    loads="$loads$s $mb $i $f"$'\n'
  fi
  rm -f "$OUT/$s.prt" "$OUT/render-$s.png"
  if [ "$r" = fail ]; then printf "   %-6s failed (see %s)\n" "$s" "$OUT/direct-$s.log"; continue; fi
  read -r wall peak verts cpu <<< "$r"
  per=$(awk -v w="$cpu" -v v="$verts" 'BEGIN { printf "%.3f", w / v * 1000 }')
  [ -z "$base" ] && base=$per
  note=$(awk -v p="$per" -v b="$base" 'BEGIN { printf "x%.2f of the first size", p / b }')
  if [ "$s" = 1m ]; then
    note="$note; $(awk -v w="$wall" -v g="$peak" 'BEGIN { printf "%s, %s", (w <= 1500 ? "time met" : "time MISSED"), (g <= 8 ? "memory met" : "memory MISSED") }')"
  fi
  printf "   %-6s %10d %10.1f %10.1f %16s %10.2f   %s\n" "$s" "$verts" "$wall" "$cpu" "$per" "$peak" "$note"
done

if [ -n "$loads" ]; then
  echo
  echo "-- loading each file (mapped): prt info; prt render 320x240, 2 threads (time to the first frame)"
  printf "   %-6s %9s %11s %7s %7s %13s %7s %7s\n" size "file MB" "info wall s" "CPU s" "peak GB" "render wall s" "CPU s" "peak GB"
  printf "%s" "$loads" | while read -r s mb iw ip _ ic fw fp _ fc; do
    [ -z "$s" ] && continue
    if [ "$iw" = fail ] || [ "$fw" = fail ]; then printf "   %-6s %9s   failed (see %s)\n" "$s" "$mb" "$OUT/info-$s.log, $OUT/render-$s.log"; continue; fi
    printf "   %-6s %9s %11.2f %7.2f %7.2f %13.2f %7.2f %7.2f\n" "$s" "$mb" "$iw" "$ic" "$ip" "$fw" "$fc" "$fp"
  done
fi

if [ -n "$NP" ]; then
  echo
  echo "-- mpirun -np 2 (1 thread per rank, --bind-to none) against one process with 2 threads, scale-$NP"
  one=$(run one "$OUT/np1-$NP.log" "$PRT" precompute "$OUT/scale-$NP.json" --glossy svd --terms 4 --no-bounces --threads 2 $OPTS -o "$OUT/np1.prt")
  two=$(run two "$OUT/np2-$NP.log" env OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 mpirun -q -np 2 --bind-to none \
        "$PRT" precompute "$OUT/scale-$NP.json" --glossy svd --terms 4 --no-bounces --threads 1 $OPTS -o "$OUT/np2.prt")
  rm -f "$OUT/np1.prt" "$OUT/np2.prt"
  if [ "$one" = fail ] || [ "$two" = fail ]; then
    echo "   a run failed (see $OUT/np1-$NP.log, $OUT/np2-$NP.log)"
  else
    read -r w1 p1 _ c1 <<< "$one"; read -r w2 p2 _ c2 <<< "$two"
    awk -v a="$w1" -v b="$w2" -v pa="$p1" -v pb="$p2" -v ca="$c1" -v cb="$c2" 'BEGIN {
      printf "   one process, 2 threads  %8.1f s wall  %8.1f CPU s  %6.2f GB peak\n", a, ca, pa
      printf "   mpirun -np 2            %8.1f s wall  %8.1f CPU s  %6.2f GB peak (largest rank)\n", b, cb, pb
      r = b / a; printf "   ratio %.3f: %s (target: within 10%%)\n", r, (r <= 1.10 ? "met" : "MISSED") }'
  fi
fi
