#!/usr/bin/env bash
# make study: what accuracy costs in time. Sweeps prt's knobs one at a time around
# the defaults on a diffuse bunny + floor and on a glossy Spot + floor, measures for
# every point the error against a path-traced reference (per vertex and in the image)
# and the cost (precompute seconds, file MB, light-change ms, view-change ms), and
# writes docs/study/{study.csv,results.md,*.png}. Not a test: it measures, and a
# failed step stops it with a message rather than writing a made-up number.
#
#   tools/study.sh [build/prt]          full study (needs ../shared/data; ~45 min on 2 cores)
#   STUDY_QUICK=1 tools/study.sh        tiny procedural scenes and sweeps (a few minutes),
#                                       written to docs/study/quick/ and labelled as such
#   STUDY_RESUME=1                      reuse the .prt files and logs of an earlier run in
#                                       build/study*/ (default: start afresh)
#   STUDY_OUT=DIR                       write the results to DIR instead
#
# Method (docs/study/README.md says more):
#  * Each knob is swept with the others at the defaults: N = 128 coefficients, K = 4
#    BRDF terms, 8-bit quantization, visibility 128^2 per face (2x2 supersampling of
#    the 64^2 lighting cube), no interreflection passes; the bounce sweep uses a
#    gathering cube of 32^2 per face and the gather sweep one bounce.
#  * "uncompressed" is N = 24,576 (every non-zero coefficient) with float storage.
#  * Shadows: the Haar measure (the default, wavelets of the transport per
#    steradian, against the paper's --texel-measure) and the refinement threshold
#    (--refine-threshold; 0 = no refinement, the default). A refined point's mesh has its own
#    vertices, so its per-vertex reference is traced for it; the floor is refined exactly and
#    the models are not, so the scene's reference image serves.
#  * The light prior (--light-prior, docs/design/shadows.md): the sharp probe's, measured under it and
#    under the soft one (the cost of a prior made for another probe).
#  * SH baseline: --sh ORDER (ORDER^2 coefficients, same pipeline and 8-bit storage)
#    against Haar with N = ORDER^2, under a probe with a sun (city) and a soft one.
#  * The reference (prt reference: path tracing with the analytic BRDFs and the
#    full-resolution probe) is computed once per scene, probe and bounce count and
#    reused; its own noise is recorded beside every error so that errors close to it
#    can be read as "no measurable difference".
#  * Errors: rel_rmse and max_rel_err of prt compare (compare.h) between the vertex
#    radiance toward the camera (prt render --vertices) and the reference's, and
#    between the rendered image (Gouraud-shaded, no background) and the reference's.
#  * Costs: precompute total from its timing summary, file size, and the medians of
#    prt bench (CPU, both cores). The machine may be shared: timings are wall clock.
set -u
PRT=${1:-build/prt}
QUICK=${STUDY_QUICK:-0}
T_START=$(date +%s)
LOAD_START=$(cut -d' ' -f1-3 /proc/loadavg)

die() { echo "study: $*" >&2; exit 1; }
[ -x "$PRT" ] || die "$PRT not found or not executable (run make first)"

# --- tools: Debian's python3-matplotlib (numpy) for the plots, oiiotool for PNGs ----
need_pkgs=""
dpkg -s python3-matplotlib >/dev/null 2>&1 || need_pkgs="$need_pkgs python3-matplotlib"
command -v oiiotool >/dev/null 2>&1 || need_pkgs="$need_pkgs openimageio-tools"
if [ -n "$need_pkgs" ]; then
  echo "study: installing Debian packages:$need_pkgs"
  if [ "$(id -u)" = 0 ]; then SUDO=""; else SUDO="sudo"; fi
  $SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq $need_pkgs >/dev/null \
    || die "could not install$need_pkgs"
fi
PY=/usr/bin/python3
HERE=$(cd "$(dirname "$0")" && pwd)

# --- data --------------------------------------------------------------------------
DATA=${PRT_DATA:-}
if [ -z "$DATA" ]; then
  for d in ../shared/data ../../shared/data /work/shared/data; do [ -d "$d/probes" ] && { DATA=$d; break; }; done
fi
[ -n "$DATA" ] && [ -f "$DATA/probes/city.exr" ] || die "probes not found: set PRT_DATA to the shared data folder (with probes/city.exr)"
SHARP=city                       # a sun four orders of magnitude above the sky: sharp shadows
SOFT=${STUDY_SOFT_PROBE:-forest} # no sun: soft, low-frequency light
for p in $SHARP $SOFT; do [ -f "$DATA/probes/$p.exr" ] || die "$DATA/probes/$p.exr not found"; done

# --- configuration -------------------------------------------------------------------
UNC=24576   # all coefficients of the 6x64x64 cube: "uncompressed" together with --quant 32
if [ "$QUICK" = 1 ]; then
  WORK=build/study-quick
  OUT=${STUDY_OUT:-docs/study/quick}
  SIZE=200x150
  REF_SPP=64; REF_VSPP=256; FRAMES=10
  N_LIST="16 128 $UNC"; Q_LIST="8 32"; V_LIST="64 128"; K_LIST="1 4"
  B_LIST="0 1"; G_LIST="8 32"; SH_LIST="3 5"; GB_LIST="0"; R_LIST="0 5"
else
  WORK=build/study
  OUT=${STUDY_OUT:-docs/study}
  SIZE=${STUDY_SIZE:-400x300}
  REF_SPP=${STUDY_REF_SPP:-1024}; REF_VSPP=${STUDY_REF_VSPP:-8192}; FRAMES=60
  N_LIST="16 32 64 128 256 512 $UNC"; Q_LIST="8 16 32"; V_LIST="64 128 256"; K_LIST="1 2 4 8 16"
  B_LIST="0 1 2 3"; G_LIST="8 16 32 64"; SH_LIST="3 4 5 6 7 8 9 10"; GB_LIST=${STUDY_GLOSSY_BOUNCES:-"0 1"}
  R_LIST=${STUDY_REFINE:-"0 20 5 2"}   # refinement thresholds in thousandths (5 = the paper's 0.5%)
  BUNNY_VERTS=${STUDY_BUNNY_VERTS:-6000}; BUNNY_FLOOR=${STUDY_BUNNY_FLOOR:-4096}
  SPOT_FLOOR=${STUDY_SPOT_FLOOR:-2500}
fi
[ "${STUDY_RESUME:-0}" = 1 ] || rm -rf "$WORK"
mkdir -p "$WORK/log" "$WORK/ref" "$WORK/out" "$OUT"

# Scenes: name -> precompute arguments (input and scene flags).
declare -A SCENE_ARGS SCENE_DESC
if [ "$QUICK" = 1 ]; then
  cat > "$WORK/diffuse.json" <<'EOF'
{ "comment": "study quick mode: diffuse sphere and box over a floor",
  "models": [ { "sphere": { "center": [0, 0.5, 0], "radius": 0.5, "rings": 12, "segments": 24 }, "material": "lambert:kd=0.8" },
              { "box": { "min": [0.6, 0, -0.3], "max": [1.0, 0.6, 0.1], "n": 3 }, "material": "lambert:kd=0.8" } ],
  "floor": { "vertices": 400, "material": "lambert:kd=0.7", "size": 2.5 } }
EOF
  cat > "$WORK/glossy.json" <<'EOF'
{ "comment": "study quick mode: glossy sphere over a floor",
  "models": [ { "sphere": { "center": [0, 0.5, 0], "radius": 0.5, "rings": 12, "segments": 24 }, "material": "paper-phong" } ],
  "floor": { "vertices": 400, "material": "lambert:kd=0.7", "size": 2.5 } }
EOF
  SCENE_ARGS[diffuse]="$WORK/diffuse.json"
  SCENE_ARGS[glossy]="$WORK/glossy.json"
  SCENE_DESC[diffuse]="procedural diffuse sphere + box over a 400-vertex floor (quick mode)"
  SCENE_DESC[glossy]="procedural paper-phong sphere over a 400-vertex floor (quick mode)"
  D=diffuse; G=glossy
else
  for m in stanford-bunny spot; do [ -f "$DATA/models/$m.obj" ] || die "$DATA/models/$m.obj not found"; done
  BUNNY_OBJ="$WORK/bunny-$BUNNY_VERTS.obj"
  $PY "$HERE/study_mesh.py" "$DATA/models/stanford-bunny.obj" "$BUNNY_OBJ" "$BUNNY_VERTS" > "$WORK/log/mesh.txt" \
    || die "could not reduce the bunny"
  BV=$(awk '{print $2}' "$WORK/log/mesh.txt")
  SCENE_ARGS[bunny]="$BUNNY_OBJ --material lambert:kd=0.8 --floor $BUNNY_FLOOR"
  SCENE_ARGS[spot]="$DATA/models/spot.obj --material paper-phong --floor $SPOT_FLOOR"
  SCENE_DESC[bunny]="Stanford bunny reduced to $BV vertices (vertex clustering, tools/study_mesh.py), lambert:kd=0.8, over a $BUNNY_FLOOR-vertex lambert:kd=0.7 floor"
  SCENE_DESC[spot]="Spot (2,930 vertices), paper-phong (red diffuse + Phong n=50), over a $SPOT_FLOOR-vertex lambert:kd=0.7 floor"
  D=bunny; G=spot
fi

# --- the points ----------------------------------------------------------------------
# A point is "scene N K quant vis bounces gather sh refine measure" (refine: threshold in
# thousandths, 0 none; measure: 1 for --texel-measure, 2 for --light-prior of the sharp probe);
# ids name its files. A point may
# belong to several sweeps (the default point to all); it is computed once.
declare -A SWEEPS PROBES
ORDER=()
add() { # sweep scene N K Q V B G SH [REFINE [TEXEL]]
  local id="$2_n$3_k$4_q$5_v$6_b$7_g$8_sh$9_r${10:-0}_m${11:-0}"
  if [ -z "${SWEEPS[$id]+x}" ]; then ORDER+=("$id"); SWEEPS[$id]="$1"; else SWEEPS[$id]="${SWEEPS[$id]};$1"; fi
  # Every point is measured under the sharp probe; direct-only points under the soft one too.
  if [ "$7" = 0 ]; then PROBES[$id]="$SHARP $SOFT"; else PROBES[$id]="$SHARP"; fi
}
for s in $D $G; do
  for n in $N_LIST; do q=8; [ "$n" = $UNC ] && q=32; add N $s $n 4 $q 128 0 32 0; done
  for q in $Q_LIST; do add quant $s 128 4 $q 128 0 32 0; done
  for v in $V_LIST; do add vis $s 128 4 8 $v 0 32 0; done
done
for k in $K_LIST; do add K $G 128 $k 8 128 0 32 0; done
for b in $B_LIST; do add bounces $D 128 4 8 128 $b 32 0; done
for g in $G_LIST; do add gather $D 128 4 8 128 1 $g 0; done
for b in $GB_LIST; do add bounces $G 128 4 8 128 $b 32 0; done
for r in $R_LIST; do add refine $D 128 4 8 128 0 32 0 "$r"; done
for s in $D $G; do add measure $s 128 4 8 128 0 32 0 0 0; add measure $s 128 4 8 128 0 32 0 0 1; done
for s in $D $G; do add prior $s 128 4 8 128 0 32 0 0 0; add prior $s 128 4 8 128 0 32 0 0 2; done
for o in $SH_LIST; do
  add sh $D $((o * o)) 4 8 128 0 32 "$o"
  add haar $D $((o * o)) 4 8 128 0 32 0
done
if [ "$QUICK" != 1 ]; then
  for o in 4 6 8 10; do add sh $G $((o * o)) 4 8 128 0 32 "$o"; add haar $G $((o * o)) 4 8 128 0 32 0; done
fi
NPTS=${#ORDER[@]}

elapsed() { local s=$(( $(date +%s) - T_START )); printf '%d:%02d' $((s / 60)) $((s % 60)); }
say() { echo "[$(elapsed)] $*"; }
# Value after "key=" in a line of key=value pairs.
kv() { tr ' ' '\n' <<< "$1" | awk -F= -v k="$2" '$1 == k { print $2 }'; }

say "study: $NPTS configurations, probes $SHARP (sharp) and $SOFT (soft), image $SIZE, reference $REF_SPP spp/pixel, $REF_VSPP spp/vertex"
for s in $D $G; do say "  scene $s: ${SCENE_DESC[$s]}"; done

# --- precompute one point (cached in $WORK/ID.prt + log) -----------------------------
precompute() { # id
  local id=$1 f
  IFS=_ read -r s n k q v b g sh r m <<< "$id"
  n=${n#n}; k=${k#k}; q=${q#q}; v=${v#v}; b=${b#b}; g=${g#g}; sh=${sh#sh}; r=${r#r}; m=${m#m}
  local args=(--glossy svd --terms "$k" --quant "$q" --vis-res "$v" --gather-res "$g")
  # --glossy svd: the study sweeps the SVD path's knobs (K...), which the plan's default vMF path does not use
  [ "$r" != 0 ] && args+=(--refine-threshold "$(awk -v r="$r" 'BEGIN { print r / 1000 }')")
  [ "$m" = 1 ] && args+=(--texel-measure)
  [ "$m" = 2 ] && args+=(--light-prior "$DATA/probes/$SHARP.exr")
  if [ "$sh" != 0 ]; then args+=(--sh "$sh"); else args+=(--coeffs "$n"); fi
  if [ "$b" = 0 ]; then args+=(--no-bounces); else args+=(--bounces "$b" --force-bounces); fi
  f="$WORK/$id.prt"
  if [ -f "$f" ] && grep -q '^  total' "$WORK/log/$id.pre"; then return 0; fi
  # shellcheck disable=SC2086
  /usr/bin/time -f "cpu %U %S" -o "$WORK/log/$id.cpu" nice "$PRT" precompute ${SCENE_ARGS[$s]} "${args[@]}" -o "$f" \
    2> "$WORK/log/$id.pre.raw"
  local rc=$?
  tr '\r' '\n' < "$WORK/log/$id.pre.raw" | grep -v -E ': +[0-9]+%|^\s*$' > "$WORK/log/$id.pre"
  rm -f "$WORK/log/$id.pre.raw"
  [ $rc -eq 0 ] || { tail -n 3 "$WORK/log/$id.pre" >&2; die "precompute of $id failed"; }
  "$PRT" info "$f" > "$WORK/log/$id.info" || die "prt info $id failed"
}

# --- references: once per scene, probe and bounce count --------------------------------
declare -A REF_NOISE_V REF_NOISE_I
reference() { # scene probe bounces base-id [image-from]
  local s=$1 p=$2 b=$3 base=$4 r="$WORK/ref/$1-$2-b$3"
  if [ -n "${5:-}" ]; then   # a refined point: its own vertices, the scene's image
    cp "$5.exr" "$r.exr"
    [ -f "$r.csv" ] || nice "$PRT" reference "$WORK/$base.prt" --probe "$DATA/probes/$p.exr" --bounces "$b" --spp "$REF_SPP" \
      --vertex-spp "$REF_VSPP" --no-image --vertices "$r.csv" --quiet 2> "$r.log" || { cat "$r.log" >&2; die "reference $s/$p/b$b failed"; }
    grep -h '\.exr' "$5.log" >> "$r.log"
  elif [ ! -f "$r.csv" ] || [ ! -f "$r.exr" ]; then
    say "reference $s / $p / $b bounce(s): $REF_VSPP spp per vertex, $REF_SPP spp per pixel at $SIZE"
    nice "$PRT" reference "$WORK/$base.prt" --probe "$DATA/probes/$p.exr" --bounces "$b" --spp "$REF_SPP" \
      --vertex-spp "$REF_VSPP" --size "$SIZE" --no-background --vertices "$r.csv" -o "$r.exr" --quiet \
      2> "$r.log" || { cat "$r.log" >&2; die "reference $s/$p/b$b failed"; }
  fi
  # PNGs for the figures: one exposure per reference (its brightest pixel at 75%), shared
  # by the PRT renders compared with it.
  oiiotool --stats "$r.exr" 2>/dev/null | awk '/Stats Max:/ { m = $3; if ($4 > m) m = $4; if ($5 > m) m = $5;
    printf "%.6g\n", (m > 0 ? 0.75 / m : 1) }' > "$r.scale"
  oiiotool "$r.exr" --mulc "$(cat "$r.scale")" --colorconvert linear sRGB -o "$r.png" 2>/dev/null || true
  # Vertices the reference leaves at exactly 0 with zero standard error face away from
  # the camera (reference.h: one-sided surfaces reflect nothing below their horizon;
  # prt's relight keeps a Lambertian vertex's colour there, as it is hidden anyway):
  # they are left out of the per-vertex comparison, on both sides.
  awk -F, 'NR == 1 || $2 != 0 || $3 != 0 || $4 != 0 || $5 != 0 || $6 != 0 || $7 != 0' "$r.csv" > "$r.front.csv"
  # Shadow region: floor vertices whose reference radiance (r+g+b) is below 60% of the floor's
  # median, i.e. where the model's shadow falls (sharp under the sun of city, soft otherwise).
  # Whole-scene errors are dominated by smoothly lit surfaces; this is where bases differ.
  local ff med
  ff=$(awk '/^ *floor: [0-9]+ vertices \(from vertex/ { gsub(/\)/, ""); print $NF }' "$WORK/log/$base.info")
  med=$(awk -F, -v f="${ff:-999999999}" 'NR > 1 && $1 >= f { print $2 + $3 + $4 }' "$r.front.csv" | sort -g \
        | awk '{ a[NR] = $1 } END { print (NR ? a[int((NR + 1) / 2)] : 0) }')
  awk -F, -v f="${ff:-999999999}" -v m="$med" 'NR == 1 || ($1 >= f && $2 + $3 + $4 < 0.6 * m)' "$r.front.csv" > "$r.shadow.csv"
  REF_NOISE_V[$s-$p-$b]=$(awk '/\.csv:/ { for (i = 1; i < NF; i++) if ($i == "noise") print $(i+1) }' "$r.log" | tr -d ',')
  REF_NOISE_I[$s-$p-$b]=$(awk '/\.exr/ { for (i = 1; i < NF; i++) if ($i == "noise") print $(i+1) }' "$r.log" | tr -d ',')
  say "  $(( $(wc -l < "$r.front.csv") - 1 )) of $(( $(wc -l < "$r.csv") - 1 )) vertices face the camera, $(( $(wc -l < "$r.shadow.csv") - 1 )) in the floor's shadow region; reference noise (relative): vertices ${REF_NOISE_V[$s-$p-$b]}, image ${REF_NOISE_I[$s-$p-$b]}  ($(grep -o 'in [0-9.]* \(ms\|s\|min [0-9]* s\|h [0-9]* min\)' "$r.log" | tr '\n' ' '))"
}

# --- measure one point -----------------------------------------------------------------
CSV="$WORK/study.csv"
echo "scene,probe,sweeps,basis,coeffs,N,K,quant,vis_res,bounces,gather_res,precompute_s,precompute_cpu_s,visibility_s,transport_s,bounce_s,file_mb,light_ms,view_ms,light_min_ms,view_min_ms,vert_rel_rmse,vert_max_rel_err,img_rel_rmse,img_max_rel_err,ref_vert_noise,ref_img_noise,shadow_rel_rmse,ref_shadow_noise,refine,texel_measure,light_prior,verts,id" > "$CSV"
summary_s() { awk -v k="$2" 'index($0, "  " k) == 1 { v = $NF; sub(/s$/, "", v); s += v } END { printf "%.2f", s }' "$1"; }

measure() { # index id
  local i=$1 id=$2 f="$WORK/$2.prt"
  IFS=_ read -r s n k q v b g sh rf m <<< "$id"
  n=${n#n}; q=${q#q}; v=${v#v}; b=${b#b}; g=${g#g}; sh=${sh#sh}; rf=${rf#r}; m=${m#m}
  local L="$WORK/log/$id" rs=$s
  if [ "$rf" != 0 ]; then   # a refined mesh: per-vertex references of its own
    rs=$id
    for p in ${PROBES[$id]}; do reference "$id" "$p" "$b" "$id" "$WORK/ref/$s-$p-b$b"; done
  fi
  local verts
  verts=$(awk '/vertices/ { for (i = 1; i <= NF; i++) if ($i ~ /^[0-9,]+$/ && $(i+1) ~ /^vert/) { gsub(/,/, "", $i); print $i; exit } }' "$L.info")
  local pre_s cpu_s vis_s tr_s bo_s mb light view light_min view_min kk basis coeffs
  pre_s=$(summary_s "$L.pre" total); cpu_s=$(awk '/^cpu/ { printf "%.2f", $2 + $3 }' "$L.cpu"); vis_s=$(summary_s "$L.pre" visibility)
  tr_s=$(summary_s "$L.pre" transport); bo_s=$(summary_s "$L.pre" bounce)
  mb=$(stat -c %s "$f" | awk '{ printf "%.4f", $1 / 1e6 }')
  local frames=$FRAMES
  [ "$n" = $UNC ] && frames=5   # a light change of an uncompressed file takes about a second
  "$PRT" bench "$f" --probe "$DATA/probes/$SHARP.exr" --frames "$frames" > "$L.bench" 2>&1 || die "prt bench $id failed"
  # Median and best frame: on a shared machine the best frame is the one least disturbed by
  # other processes, so the plots use it; the table gives both.
  light=$(awk '/^light change:/ { print $3 }' "$L.bench"); view=$(awk '/^view change:/ { print $3 }' "$L.bench")
  light_min=$(awk '/^light change:/ { for (i = 1; i < NF; i++) if ($i == "min") print $(i+1) }' "$L.bench")
  view_min=$(awk '/^view change:/ { for (i = 1; i < NF; i++) if ($i == "min") print $(i+1) }' "$L.bench")
  kk=$(grep -o 'max K = [0-9]*' "$L.bench" | awk '{ print $4 }')
  if [ "$sh" != 0 ]; then basis=sh; coeffs=$((sh * sh)); else basis=haar; coeffs=$n; fi
  local line="[$i/$NPTS] $id: precompute ${pre_s}s, $mb MB, light $light ms, view $view ms"
  for p in ${PROBES[$id]}; do
    local o="$WORK/out/$id-$p" r="$WORK/ref/$rs-$p-b$b" cv ci
    "$PRT" render "$f" --probe "$DATA/probes/$p.exr" --size "$SIZE" --no-background -o "$o.exr" --vertices "$o.csv" \
      2> "$o.render.log" || { cat "$o.render.log" >&2; die "prt render $id ($p) failed"; }
    awk -F, 'NR == FNR { keep[$1] = 1; next } FNR == 1 || ($1 in keep)' "$r.front.csv" "$o.csv" > "$o.front.csv"
    cv=$("$PRT" compare "$o.front.csv" "$r.front.csv") || die "prt compare (vertices) $id ($p) failed"
    local cs="rel_rmse=nan ref_noise=nan"
    if [ "$(wc -l < "$r.shadow.csv")" -gt 1 ]; then
      awk -F, 'NR == FNR { keep[$1] = 1; next } FNR == 1 || ($1 in keep)' "$r.shadow.csv" "$o.csv" > "$o.shadow.csv"
      cs=$("$PRT" compare "$o.shadow.csv" "$r.shadow.csv") || die "prt compare (shadow) $id ($p) failed"
    fi
    ci=$("$PRT" compare "$o.exr" "$r.exr" --error-image "$o.err.png" 2>/dev/null) || die "prt compare (image) $id ($p) failed"
    oiiotool "$o.exr" --mulc "$(cat "$r.scale")" --colorconvert linear sRGB -o "$o.png" 2>/dev/null || true
    echo "$s,$p,${SWEEPS[$id]},$basis,$coeffs,$n,$kk,$q,$v,$b,$g,$pre_s,$cpu_s,$vis_s,$tr_s,$bo_s,$mb,$light,$view,$light_min,$view_min,$(kv "$cv" rel_rmse),$(kv "$cv" max_rel_err),$(kv "$ci" rel_rmse),$(kv "$ci" max_rel_err),$(kv "$cv" ref_noise),${REF_NOISE_I[$s-$p-$b]},$(kv "$cs" rel_rmse),$(kv "$cs" ref_noise),$rf,$(( m == 1 )),$( [ "$m" = 2 ] && echo "$SHARP"),$verts,$id" >> "$CSV"
    line="$line; $p: vertex err $(kv "$cv" rel_rmse), shadow $(kv "$cs" rel_rmse), image $(kv "$ci" rel_rmse)"
  done
  say "$line"
}

# --- run -------------------------------------------------------------------------------
# References first need one .prt of each scene (any point: the scene is the same).
for s in $D $G; do
  base="${s}_n128_k4_q8_v128_b0_g32_sh0_r0_m0"
  say "precompute $base (default point, also the reference's scene)"
  precompute "$base"
  for id in "${ORDER[@]}"; do
    [ "${id%%_*}" = "$s" ] || continue
    b=${id#*_b}; b=${b%%_*}
    for p in ${PROBES[$id]}; do [ -n "${REF_NOISE_V[$s-$p-$b]+x}" ] || reference "$s" "$p" "$b" "$base"; done
  done
done
i=0
for id in "${ORDER[@]}"; do
  i=$((i + 1))
  precompute "$id"
  measure "$i" "$id"
  # Uncompressed files are hundreds of MB: measured, then dropped (the log keeps the figures).
  case "$id" in *_n${UNC}_*) [ "${STUDY_KEEP:-0}" = 1 ] || rm -f "$WORK/$id.prt" ;; esac
done

# --- outputs ---------------------------------------------------------------------------
RUNTIME=$(( $(date +%s) - T_START ))
cp "$CSV" "$OUT/study.csv"
{
  echo "mode=$([ "$QUICK" = 1 ] && echo quick || echo full)"
  echo "runtime_s=$RUNTIME"
  echo "resumed=${STUDY_RESUME:-0}"
  echo "load_start=$LOAD_START"
  echo "load_end=$(cut -d' ' -f1-3 /proc/loadavg)"
  echo "machine=$(nproc) cores, $(awk '/MemTotal/{printf "%.0f GB", $2/1e6}' /proc/meminfo), $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//')"
  echo "date=$(date -u +%Y-%m-%dT%H:%MZ)"
  echo "commit=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)"
  echo "size=$SIZE"
  echo "ref_spp=$REF_SPP"
  echo "ref_vspp=$REF_VSPP"
  echo "sharp=$SHARP"
  echo "soft=$SOFT"
  echo "scene_$D=${SCENE_DESC[$D]}"
  echo "scene_$G=${SCENE_DESC[$G]}"
  echo "diffuse_scene=$D"
  echo "glossy_scene=$G"
} > "$OUT/meta.txt"
$PY "$HERE/study_plot.py" "$OUT" "$WORK" || die "plotting failed"
say "study done in $(elapsed): $OUT/study.csv, $OUT/results.md, $OUT/*.png"
