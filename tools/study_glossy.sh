#!/usr/bin/env bash
# make study-glossy: the vMF lobe transfer (Laurijssen et al. 2011) against the
# SVD path (Wang et al. 2006, section 3.3) on the glossy scenes of data/: error against
# precompute time and file size. Not a test: it measures, and a failed step stops it with
# a message rather than writing a made-up number.
#
#   tools/study_glossy.sh [build/prt]   full run (needs ../shared/data; about 35 min on 2 cores)
#   STUDY_QUICK=1                       one tiny procedural scene, K = 1 and 4, view level 1
#                                       (about a minute), written to docs/study/glossy/quick/
#   GLOSSY_SCENES="sphere-phong ..."    scenes of data/ (default sphere-phong teapot-floor spot-floor)
#   GLOSSY_K="1 2 4 8 16"               SVD terms;  GLOSSY_LEVELS="1 2 3" vMF view-grid levels
#   GLOSSY_SPP=256 GLOSSY_VSPP=1024     reference samples per pixel / per vertex
#   STUDY_OUT=DIR                       write the results to DIR (default docs/study/glossy)
#
# Method:
#  * Representation points, all with --bounces 0 so that the comparison is the
#    representations' and not the interreflection passes': --glossy svd --terms K for every
#    K, and --glossy vmf --view-level L for every level (Haar K = 1 diffuse + vMF specular).
#    Then one row per path at the defaults (--glossy svd, K = 4; --glossy auto; bounces: the
#    plan's, up to 3), compared with a reference of 3 bounces where the scene has a floor.
#  * The reference (prt reference, path tracing with the analytic BRDFs) is traced once per
#    scene, probe and bounce count and reused; its own noise (prt reference's estimate) is
#    recorded beside every error. Image 400x300, no background, same camera as prt render.
#  * Errors: rel_rmse of prt compare between prt render --vertices and the reference's
#    vertices, and between the rendered image (Gouraud) and the reference image.
#  * Costs: precompute total from the timing summary, file MB, prt bench --backend cpu
#    --frames 20 medians (light change, view change). The machine is shared: each row
#    carries the 1-minute load average at the start of its precompute.
set -u
PRT=${1:-build/prt}
QUICK=${STUDY_QUICK:-0}
T_START=$(date +%s)
HERE=$(cd "$(dirname "$0")" && pwd)
die() { echo "study_glossy: $*" >&2; exit 1; }
[ -x "$PRT" ] || die "$PRT not found or not executable (run make first)"
DATA=${PRT_DATA:-}
if [ -z "$DATA" ]; then
  for d in ../shared/data ../../shared/data /work/shared/data; do [ -d "$d/probes" ] && { DATA=$d; break; }; done
fi
[ -n "$DATA" ] && [ -f "$DATA/probes/city.exr" ] && [ -f "$DATA/probes/forest.exr" ] \
  || die "probes not found: set PRT_DATA to the shared data folder (with probes/city.exr, forest.exr)"
SIZE=400x300
FRAMES=20
if [ "$QUICK" = 1 ]; then
  WORK=build/study-glossy-quick; OUT=${STUDY_OUT:-docs/study/glossy/quick}
  K_LIST="1 4"; LEVELS="1"; SPP=32; VSPP=128
  mkdir -p "$WORK"
  cat > "$WORK/quick.json" <<'EOF'
{ "comment": "study-glossy quick mode: a paper-phong sphere over a small floor",
  "models": [ { "sphere": { "center": [0, 0.5, 0], "radius": 0.5, "rings": 12, "segments": 24 }, "material": "paper-phong" } ],
  "floor": { "vertices": 400, "material": "lambert:kd=0.7", "size": 2.5 } }
EOF
  SCENES="quick"; SCENE_FILE_quick="$WORK/quick.json"; FOREST_SCENE=quick
else
  WORK=build/study-glossy; OUT=${STUDY_OUT:-docs/study/glossy}
  K_LIST=${GLOSSY_K:-"1 2 4 8 16"}; LEVELS=${GLOSSY_LEVELS:-"1 2 3"}
  SPP=${GLOSSY_SPP:-256}; VSPP=${GLOSSY_VSPP:-1024}
  SCENES=${GLOSSY_SCENES:-"sphere-phong teapot-floor spot-floor"}; FOREST_SCENE=${GLOSSY_FOREST_SCENE:-sphere-phong}
fi
# data/*.json name their models relative to the main checkout (../../shared/data/...): the
# study runs them from a copy whose paths point at $DATA, so that any worktree can run it.
DATA_ABS=$(cd "$DATA" && pwd)
scene_file() { if [ "$1" = quick ]; then echo "$WORK/quick.json"; else echo "$WORK/scene-$1.json"; fi; }
mkdir -p "$WORK"
for s in $SCENES; do
  [ "$s" = quick ] || [ ! -f "data/$s.json" ] \
    || sed "s#\"[./]*/shared/data/#\"$DATA_ABS/#g" "data/$s.json" > "$WORK/scene-$s.json"
done
for s in $SCENES; do [ -f "$(scene_file "$s")" ] || die "$(scene_file "$s") not found"; done
[ "${STUDY_RESUME:-0}" = 1 ] || rm -rf "$WORK/log" "$WORK/ref" "$WORK/out" "$WORK"/*.prt
mkdir -p "$WORK/log" "$WORK/ref" "$WORK/out" "$OUT"

elapsed() { local s=$(( $(date +%s) - T_START )); printf '%d:%02d' $((s / 60)) $((s % 60)); }
say() { echo "[$(elapsed)] $*"; }
kv() { tr ' ' '\n' <<< "$1" | awk -F= -v k="$2" '$1 == k { print $2 }'; }
load1() { cut -d' ' -f1 /proc/loadavg; }

precompute() { # scene id args...: $WORK/id.prt and its timing log; cached within a resumed run
  local s=$1 id=$2; shift 2
  local f="$WORK/$id.prt" L="$WORK/log/$id"
  if [ -f "$f" ] && grep -q '^  total' "$L.pre" 2> /dev/null; then return 0; fi
  load1 > "$L.load"
  nice "$PRT" precompute "$(scene_file "$s")" "$@" -o "$f" 2> "$L.raw" > /dev/null
  local rc=$?
  tr '\r' '\n' < "$L.raw" | grep -v -E ': +[0-9]+%|^\s*$' > "$L.pre"; rm -f "$L.raw"
  [ $rc -eq 0 ] || { tail -n 3 "$L.pre" >&2; die "precompute $id failed"; }
}

declare -A NOISE_V NOISE_I
reference() { # scene probe bounces prt-file: traced once per (scene, probe, bounces)
  local r="$WORK/ref/$1-$2-b$3"
  if [ ! -f "$r.csv" ]; then
    say "reference $1 / $2 / $3 bounce(s): $SPP spp per pixel at $SIZE, $VSPP per vertex"
    nice "$PRT" reference "$4" --probe "$DATA/probes/$2.exr" --bounces "$3" --spp "$SPP" --vertex-spp "$VSPP" \
      --size "$SIZE" --no-background --vertices "$r.csv" -o "$r.exr" --quiet 2> "$r.log" \
      || { cat "$r.log" >&2; die "reference $1/$2/b$3 failed"; }
  fi
  NOISE_V[$1-$2-$3]=$(awk '/\.csv:/ { for (i = 1; i < NF; i++) if ($i == "noise") print $(i+1) }' "$r.log" | tr -d ',')
  NOISE_I[$1-$2-$3]=$(awk '/\.exr/ { for (i = 1; i < NF; i++) if ($i == "noise") print $(i+1) }' "$r.log" | tr -d ',')
}

CSV="$WORK/glossy.csv"
# A resumed run appends to the CSV and skips the rows it already has (scene lists may differ).
[ "${STUDY_RESUME:-0}" = 1 ] && [ -f "$CSV" ] || echo "scene,probe,path,K,view_level,bounces,ref_bounces,precompute_s,vmf_s,file_mb,vmf_mb,light_ms,view_ms,vert_rel_rmse,img_rel_rmse,ref_vert_noise,ref_img_noise,load1,id" > "$CSV"
measure() { # scene id path K level bounces ref-bounces probe
  local s=$1 id=$2 path=$3 k=$4 lv=$5 b=$6 rb=$7 p=$8 f="$WORK/$2.prt" L="$WORK/log/$2"
  grep -q ",$id\$" "$CSV" && grep -q "^$s,$p,.*,$id\$" "$CSV" && return 0
  reference "$s" "$p" "$rb" "$f"
  local r="$WORK/ref/$s-$p-b$rb" o="$WORK/out/$id-$p"
  local pre vs mb vmb light view cv ci
  pre=$(awk '/^  total/ { v = $NF; sub(/s$/, "", v); print v }' "$L.pre")
  vs=$(awk '/^  vMF lobes/ { v = $NF; sub(/s$/, "", v); s += v } END { printf "%.2f", s }' "$L.pre")
  mb=$(stat -c %s "$f" | awk '{ printf "%.3f", $1 / 1e6 }')
  vmb=$(grep -o 'vmf [0-9.]* MB' "$L.pre" | awk '{ print $2 }'); vmb=${vmb:-0}
  if [ ! -f "$L.bench" ]; then
    nice "$PRT" bench "$f" --probe "$DATA/probes/city.exr" --backend cpu --frames "$FRAMES" > "$L.bench" 2>&1 || die "prt bench $id failed"
  fi
  light=$(awk '/^light change:/ { print $3 }' "$L.bench"); view=$(awk '/^view change:/ { print $3 }' "$L.bench")
  "$PRT" render "$f" --probe "$DATA/probes/$p.exr" --size "$SIZE" --no-background -o "$o.exr" --vertices "$o.csv" \
    > /dev/null 2> "$o.log" || { cat "$o.log" >&2; die "render $id ($p) failed"; }
  cv=$("$PRT" compare "$o.csv" "$r.csv") || die "compare (vertices) $id ($p) failed"
  ci=$("$PRT" compare "$o.exr" "$r.exr") || die "compare (image) $id ($p) failed"
  echo "$s,$p,$path,$k,$lv,$b,$rb,$pre,$vs,$mb,$vmb,$light,$view,$(kv "$cv" rel_rmse),$(kv "$ci" rel_rmse),${NOISE_V[$s-$p-$rb]},${NOISE_I[$s-$p-$rb]},$(cat "$L.load"),$id" >> "$CSV"
  say "$id ($p): ${pre}s, $mb MB, light $light ms, view $view ms; vertex err $(kv "$cv" rel_rmse), image $(kv "$ci" rel_rmse) (reference noise ${NOISE_V[$s-$p-$rb]} / ${NOISE_I[$s-$p-$rb]})"
}

say "study-glossy: scenes $SCENES; SVD K = $K_LIST; vMF view levels $LEVELS; $(nproc) cores, load $(cut -d' ' -f1-3 /proc/loadavg)"
LOAD_START=$(cut -d' ' -f1-3 /proc/loadavg)
for s in $SCENES; do
  probes=city; [ "$s" = "$FOREST_SCENE" ] && probes="city forest"
  # defaults: bounces are the plan's (up to 3); a floorless convex object has none to gather
  rb=3; grep -q '"floor": *false' "$(scene_file "$s")" && rb=0
  for k in $K_LIST; do
    id=$s-svd-k$k; precompute "$s" "$id" --glossy svd --terms "$k" --no-bounces
    for p in $probes; do measure "$s" "$id" svd "$k" "" 0 0 "$p"; done
  done
  for lv in $LEVELS; do
    id=$s-vmf-l$lv; precompute "$s" "$id" --glossy vmf --view-level "$lv" --no-bounces
    for p in $probes; do measure "$s" "$id" vmf 1 "$lv" 0 0 "$p"; done
  done
  id=$s-svd-default; precompute "$s" "$id" --glossy svd
  for p in $probes; do measure "$s" "$id" svd-default 4 "" plan "$rb" "$p"; done
  id=$s-auto-default; precompute "$s" "$id"
  for p in $probes; do measure "$s" "$id" auto-default 1 2 plan "$rb" "$p"; done
  grep -h -A3 '^  paths:' "$WORK/log/$id.pre" | sed 's/^/    /' > "$WORK/log/$s.plan"
done
RUNTIME=$(( $(date +%s) - T_START ))
cp "$CSV" "$OUT/glossy.csv"
{
  echo "date: $(date -u '+%Y-%m-%d %H:%M UTC'); runtime ${RUNTIME}s (this invocation; resumed: ${STUDY_RESUME:-0}); $(nproc) cores; load at start $LOAD_START, at end $(cut -d' ' -f1-3 /proc/loadavg)"
  echo "prt: $(git rev-parse --short HEAD 2> /dev/null); quick=$QUICK; reference $SPP spp/pixel, $VSPP spp/vertex, image $SIZE"
  for s in $(tail -n +2 "$CSV" | cut -d, -f1 | sort -u); do echo "plan for $s (defaults):"; cat "$WORK/log/$s.plan"; done
} > "$OUT/meta.txt"
/usr/bin/python3 "$HERE/study_glossy_plot.py" "$OUT/glossy.csv" "$OUT" "$OUT/meta.txt" || die "plots failed"
say "done: $OUT/glossy.csv, $OUT/results.md, $OUT/error_time.png, $OUT/error_mb.png"
