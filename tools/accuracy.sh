#!/usr/bin/env bash
# make accuracy: how far PRT's relighting is from the path tracer, the same way every time, over
# scenes x probes x light yaws x effect settings. Not a test: it measures, prints the matrix and
# writes it with contact sheets per scene, setting and yaw (and, when measured, hard-cases.png: the
# README's low sun and studio key light on the Lambertian teapot); a failed step stops it with its log rather
# than writing a made-up number.
#
#   tools/accuracy.sh [build/prt]     the whole matrix (needs ../shared/data; hours on 2 cores:
#                                     the bunny's defaults are the longest; knobs below to narrow it)
#   ACCURACY_QUICK=1                  one scene, two probes, one yaw, 16 spp at 200x150 (a few
#                                     minutes on a shared machine), into build/accuracy-quick/
#   docs/accuracy/ holds ACCURACY_SCENES="teapot-floor teapot-lambert" ACCURACY_EFFECTS=direct
#                                     (32 images at the defaults: 37 min on 2 shared cores)
# Knobs (environment):
#   ACCURACY_SCENES   data/ scene names (data/NAME.json) and teapot-lambert (the Utah teapot in
#                     lambert:kd=0.8 over teapot-floor.json's 2,500-vertex floor, as precompute
#                     flags); default: teapot-floor teapot-lambert spot-floor bunny-floor sphere-phong
#   ACCURACY_PROBES   probe names in ../shared/data/probes (default: all eight)
#   ACCURACY_YAWS     light yaws in degrees, --light-rotation (default: 0 135)
#   ACCURACY_EFFECTS  direct (precompute --no-bounces, reference --bounces 0) and/or full (the
#                     precompute's defaults, the reference with as many bounces as prt info says
#                     the precompute did); default: direct full
#   ACCURACY_SPP      reference samples per pixel (default 256)
#   ACCURACY_NOISE_SPP  the second reference's (default ACCURACY_SPP / 4; see "noise" below)
#   ACCURACY_SIZE     image size (default 400x300)
#   ACCURACY_OUT      where matrix.md, matrix.csv and the sheets go (default docs/accuracy)
#   ACCURACY_RESUME=1 reuse the .prt files, images and references of an earlier run in the work
#                     folder (default: start afresh)
#   PRT_DATA          the shared data folder (default ../shared/data; data/*.json name their models
#                     as ../../shared/data/models/ from data/)
#
# Method (written into matrix.md too):
#  * Each scene is precomputed once per effect setting; every probe and yaw relights that file
#    (prt render --light-rotation YAW, --no-background, the default camera).
#  * image: rel_rmse of prt compare between the PRT image and a reference (prt reference, seed 1,
#    ACCURACY_SPP samples).
#  * noise: a second reference (seed 2, ACCURACY_NOISE_SPP samples) gives d = rel_rmse(ref2, ref1);
#    the two errors are independent with variances in the ratio of the sample counts, so the
#    first reference's own noise is d / sqrt(1 + SPP / NOISE_SPP) (d / sqrt(2) at equal counts).
#    "PRT alone" is sqrt(image^2 - noise^2): the reference's noise adds to PRT's error in squares.
#  * floor shadow: the same over the floor's shadow region (tools/accuracy_img.c "mask": floor
#    pixels, away from silhouettes, below 60% of the floor's median in the second direct-only
#    reference), so the mask's own noise is independent of the reference it is compared against.
#    The region is taken from the direct-only reference when that setting runs (else from the
#    setting's own); "-" where the scene has no floor or the region is under 50 pixels.
set -u
T0=$(date +%s.%N)
die() { echo "accuracy: $*" >&2; exit 1; }
# Paths given relative to the caller's folder are made absolute; the rest is relative to the repository.
abs() { case "$1" in /*) echo "$1" ;; *) echo "$PWD/$1" ;; esac; }
PRT=$(abs "${1:-build/prt}")
DATA=$([ -n "${PRT_DATA:-}" ] && abs "$PRT_DATA")
cd "$(dirname "$0")/.." || die "cannot enter the repository"
[ -x "$PRT" ] || die "$PRT not found or not executable (run make first)"
DATA=${DATA:-../shared/data}
[ -d "$DATA/probes" ] && [ -d "$DATA/models" ] || die "no shared assets at $DATA (probes/, models/): clone them to ../shared or set PRT_DATA"

QUICK=${ACCURACY_QUICK:-0}
if [ "$QUICK" = 1 ]; then
  SCENES=${ACCURACY_SCENES:-teapot-lambert}; PROBES=${ACCURACY_PROBES:-city sunrise}; YAWS=${ACCURACY_YAWS:-0}
  SPP=${ACCURACY_SPP:-16}; NSPP=${ACCURACY_NOISE_SPP:-16}; SIZE=${ACCURACY_SIZE:-200x150}
  WORK=build/accuracy-quick; OUT=${ACCURACY_OUT:-build/accuracy-quick/out}
else
  SCENES=${ACCURACY_SCENES:-teapot-floor teapot-lambert spot-floor bunny-floor sphere-phong}
  PROBES=${ACCURACY_PROBES:-city courtyard forest interior night studio sunrise sunset}; YAWS=${ACCURACY_YAWS:-0 135}
  SPP=${ACCURACY_SPP:-256}; NSPP=${ACCURACY_NOISE_SPP:-$(( (${ACCURACY_SPP:-256} + 3) / 4 ))}; SIZE=${ACCURACY_SIZE:-400x300}
  WORK=build/accuracy; OUT=${ACCURACY_OUT:-docs/accuracy}
fi
EFFECTS=${ACCURACY_EFFECTS:-direct full}
SHEET_KB=400
[[ "$SIZE" =~ ^[1-9][0-9]*x[1-9][0-9]*$ ]] || die "bad ACCURACY_SIZE '$SIZE' (expected WxH)"
[[ "$SPP" =~ ^[1-9][0-9]*$ && "$NSPP" =~ ^[1-9][0-9]*$ ]] || die "bad ACCURACY_SPP '$SPP' or ACCURACY_NOISE_SPP '$NSPP'"
for p in $PROBES; do [ -f "$DATA/probes/$p.exr" ] || die "$DATA/probes/$p.exr not found (ACCURACY_PROBES)"; done
for y in $YAWS; do [[ "$y" =~ ^-?[0-9]+([.][0-9]+)?$ ]] || die "bad yaw '$y' in ACCURACY_YAWS"; done
for e in $EFFECTS; do [ "$e" = direct ] || [ "$e" = full ] || die "unknown effect setting '$e' (direct, full)"; done
# The precompute's arguments for a scene name.
scene_args() {
  case "$1" in
    teapot-lambert) echo "$DATA/models/teapot.obj --material lambert:kd=0.8 --floor 2500" ;;
    *) [ -f "data/$1.json" ] && echo "data/$1.json" ;;
  esac
}
for s in $SCENES; do [ -n "$(scene_args "$s")" ] || die "unknown scene '$s' (ACCURACY_SCENES: data/NAME.json or teapot-lambert)"; done

[ "${ACCURACY_RESUME:-0}" = 1 ] || rm -rf "$WORK"
mkdir -p "$WORK" "$OUT" || die "cannot create $WORK or $OUT"
tools/accuracy_img.sh uniform "$WORK/uniform.exr" || die "could not build tools/accuracy_img"
IMG=build/accuracy_img

# --- timing: seconds per phase, summed over the runs that made the work folder's files --------------
declare -A T=([precompute]=0 [render]=0 [reference]=0 [compare]=0)
WALL0=0
if [ -f "$WORK/timing.txt" ]; then
  read -r T[precompute] T[render] T[reference] T[compare] WALL0 < "$WORK/timing.txt" || die "unreadable $WORK/timing.txt"
fi
# timed PHASE LOG CMD...: runs CMD with stdout+stderr to LOG, adds its wall time to T[PHASE];
# on failure prints LOG's tail and stops.
timed() {
  local ph=$1 log=$2 t; shift 2
  t=$(date +%s.%N)
  "$@" > "$log" 2>&1 || { tail -n 5 "$log" >&2; die "failed: $*"; }
  T[$ph]=$(awk -v a="${T[$ph]}" -v b="$(date +%s.%N)" -v t="$t" 'BEGIN { printf "%.2f", a + b - t }')
}
kv() { echo "$1" | tr ' ' '\n' | awk -F= -v k="$2" '$1 == k { print $2 }'; }
# noise D: the first reference's noise from the two references' difference D (header).
noise() { awk -v d="$1" -v a="$SPP" -v b="$NSPP" 'BEGIN { if (d == "-") print "-"; else printf "%.4f", d / sqrt(1 + a / b) }'; }
# alone E N: sqrt(E^2 - N^2), 0 when the error is within the noise.
alone() { awk -v e="$1" -v n="$2" 'BEGIN { if (e == "-" || n == "-") print "-"; else { v = e * e - n * n; printf "%.4f", (v > 0 ? sqrt(v) : 0) } }'; }

CSV=$WORK/matrix.csv
echo "scene,effect,bounces,probe,yaw,image_rel_rmse,ref_noise,ref_noise_stderr,prt_alone,shadow_rel_rmse,shadow_ref_noise,shadow_px,floor_px,ref_seconds" > "$CSV"
nsc=$(echo $SCENES | wc -w); npr=$(echo $PROBES | wc -w); nya=$(echo $YAWS | wc -w); nef=$(echo $EFFECTS | wc -w)
total=$((nsc * npr * nya * nef)); done_n=0
echo "accuracy: $nsc scene(s) x $npr probe(s) x $nya yaw(s) x $nef setting(s) = $total images, $SIZE, reference $SPP spp (noise: a second at $NSPP), work in $WORK"

# measure SCENE EFFECT F.prt BOUNCES PROBE YAW: one image of the matrix (a CSV row and a progress line).
measure() {
  local s=$1 e=$2 f=$3 nb=$4 p=$5 y=$6 b=$W/$1-$2-$5-$6
  local pe="$DATA/probes/$p.exr"
  [ -f $b.exr ] || timed render $b.render.log "$PRT" render "$f" --probe "$pe" --light-rotation "$y" --size "$SIZE" --no-background -o $b.exr
  [ -f $b.ref.exr ] || timed reference $b.ref.log "$PRT" reference "$f" --probe "$pe" --light-rotation "$y" --size "$SIZE" \
    --no-background --spp "$SPP" --bounces "$nb" --seed 1 --quiet -o $b.ref.exr
  [ -f $b.ref2.exr ] || timed reference $b.ref2.log "$PRT" reference "$f" --probe "$pe" --light-rotation "$y" --size "$SIZE" \
    --no-background --spp "$NSPP" --bounces "$nb" --seed 2 --quiet -o $b.ref2.exr
  local ci cn mask=$W/$s-$p-$y.mask.exr sh="-" sn="-" spx=0 fpx=0 m
  timed compare $b.cmp.log "$PRT" compare $b.exr $b.ref.exr --error-image $b.err.png
  ci=$(grep -m1 "^rel_rmse=" $b.cmp.log)
  cn=$($IMG cmp $b.ref2.exr $b.ref.exr) || die "compare of $b.ref2.exr failed"
  if [ -f $W/$s-model.exr ]; then
    # the shadow region: from the direct-only second reference when that setting runs (header)
    local src=$b.ref2.exr
    [ "$e" = full ] && [ -f $W/$s-direct-$p-$y.ref2.exr ] && src=$W/$s-direct-$p-$y.ref2.exr
    if [ ! -f $mask ]; then
      $IMG mask $W/$s-$e-cover.exr $W/$s-model.exr $src $mask > $mask.txt || die "mask of $b failed"
    fi
    spx=$(kv "$(cat $mask.txt)" shadow_px); fpx=$(kv "$(cat $mask.txt)" floor_px)
    if [ "$spx" -ge 50 ]; then
      m=$($IMG cmp $b.exr $b.ref.exr $mask) || die "masked compare of $b failed"; sh=$(kv "$m" rel_rmse)
      m=$($IMG cmp $b.ref2.exr $b.ref.exr $mask) || die "masked compare of $b failed"; sn=$(noise "$(kv "$m" rel_rmse)")
      sh=$(awk -v v="$sh" 'BEGIN { printf "%.4f", v }')
    fi
  fi
  local ri rn rs rt
  ri=$(awk -v v="$(kv "$ci" rel_rmse)" 'BEGIN { printf "%.4f", v }'); rn=$(noise "$(kv "$cn" rel_rmse)")
  rs=$(sed -n 's/.*relative noise \([0-9.e+-]*\).*/\1/p' $b.ref.log | head -n 1); rt=$(sed -n 's/.* spp in \([0-9.]*\)s.*/\1/p' $b.ref.log | head -n 1)
  echo "$s,$e,$nb,$p,$y,$ri,$rn,${rs:--},$(alone "$ri" "$rn"),$sh,$sn,$spx,$fpx,${rt:--}" >> "$CSV"
  done_n=$((done_n + 1))
  printf "[%d/%d] %-15s %-6s %-9s yaw %4s: image %s (ref noise %s)  floor shadow %s (ref noise %s, %s px)\n" \
    $done_n $total "$s" "$e" "$p" "$y" "$ri" "$rn" "$sh" "$sn" "$spx"
}

# sheet SCENE EFFECT YAW: the contact sheet (a row per probe), its tiles from half the image's width
# shrunk in 10% steps until the PNG is within SHEET_KB.
sheet() {
  local s=$1 e=$2 y=$3 list=$W/$1-$2-$3.sheet.txt out=$OUT/$1-$2-yaw$3.png tw=$(( ${SIZE%x*} / 2 )) p b lab
  : > $list
  for p in $PROBES; do
    b=$W/$s-$e-$p-$y
    lab=$(awk -F, -v s="$s" -v e="$e" -v p="$p" -v y="$y" '$1 == s && $2 == e && $4 == p && $5 == y {
      printf "%s: image %s (noise %s), shadow %s (%s)", p, $6, $7, $10, $11 }' "$CSV")
    printf "%s\t%s\t%s\t%s\n" "$lab" $b.exr $b.ref.exr $b.err.png >> $list
  done
  local title="$s, $e ($([ "$e" = direct ] && echo "--no-bounces / --bounces 0" || echo "defaults / --bounces $NB")), yaw $y, $SIZE, ref. $SPP spp"
  while :; do
    $IMG sheet $out $tw "$title" $list || die "contact sheet $out failed"
    [ $(( $(stat -c %s $out) / 1024 )) -le $SHEET_KB ] || [ $tw -le 64 ] && break
    tw=$(( tw * 9 / 10 ))
  done
  echo "wrote $out ($(( $(stat -c %s $out) / 1024 )) KB, tiles ${tw}px wide)"
}

W=$WORK
for s in $SCENES; do
  args=$(scene_args "$s")
  for e in $EFFECTS; do
    f=$W/$s-$e.prt
    flags=$([ "$e" = direct ] && echo --no-bounces)
    if [ ! -f $f ]; then
      echo "precompute $s ($e): prt precompute $args $flags"
      timed precompute $W/$s-$e.log "$PRT" precompute $args $flags --quiet -o $f
    fi
    "$PRT" info $f > $W/$s-$e.info || die "prt info $f failed"
    NB=0
    [ "$e" = full ] && NB=$(awk '/^interreflect/ { print $2 }' $W/$s-$e.info)
    [[ "$NB" =~ ^[0-9]+$ ]] || die "no interreflection count in $W/$s-$e.info"
    floor=$(grep -c 'floor:' $W/$s-$e.info)
    if [ "$floor" -gt 0 ]; then
      # the geometry masks of the shadow region (tools/accuracy_img.c): the model alone, and the whole scene
      if [ ! -f $W/$s-model.exr ]; then
        timed precompute $W/$s-model.log "$PRT" precompute $args --no-floor --no-bounces --coeffs 16 --vis-res 64 --glossy svd \
          --terms 1 --no-light-prior --no-refine --quiet -o $W/$s-model.prt
        timed render $W/$s-model.render.log "$PRT" render $W/$s-model.prt --probe $W/uniform.exr --size "$SIZE" --no-background -o $W/$s-model.exr
      fi
      [ -f $W/$s-$e-cover.exr ] || timed render $W/$s-$e-cover.log "$PRT" render $f --probe $W/uniform.exr --size "$SIZE" --no-background -o $W/$s-$e-cover.exr
    fi
    for p in $PROBES; do
      for y in $YAWS; do measure "$s" "$e" "$f" "$NB" "$p" "$y"; done
    done
    for y in $YAWS; do sheet "$s" "$e" "$y"; done
  done
done

# The README's picture of a light not known at precompute time: the Lambertian teapot's long shadow
# under a low sun and its handle's under the studio key light (yaw 135, direct), when measured.
hard_cases() {
  local list=$W/hard-cases.sheet.txt out=$OUT/hard-cases.png p b
  : > $list
  for p in studio sunrise; do
    b=$W/teapot-lambert-direct-$p-135
    [ -f $b.exr ] && [ -f $b.err.png ] || return 0
    grep "^$p:" $W/teapot-lambert-direct-135.sheet.txt >> $list || return 0
  done
  $IMG sheet $out 240 "teapot lambert:kd=0.8 over its floor, direct, yaw 135, no light prior ($SIZE, ref. $SPP spp)" $list ||
    die "contact sheet $out failed"
  echo "wrote $out"
}
hard_cases

# --- the matrix: printed and written as Markdown --------------------------------------------------
T1=$(date +%s.%N)
wall=$(awk -v a="$T0" -v b="$T1" -v w="$WALL0" 'BEGIN { printf "%.0f", w + b - a }')
echo "${T[precompute]} ${T[render]} ${T[reference]} ${T[compare]} $wall" > "$WORK/timing.txt"
table() {
  echo "| scene | setting | probe | yaw | image rel_rmse | reference noise | PRT alone | floor shadow rel_rmse | its reference noise | shadow px |"
  echo "|---|---|---|---:|---:|---:|---:|---:|---:|---:|"
  awk -F, 'NR > 1 { st = $2 == "direct" ? "direct" : "full (" $3 " bounces)"
    printf "| %s | %s | %s | %s | %s | %s | %s | %s | %s | %s |\n", $1, st, $4, $5, $6, $7, $9, $10, $11, ($13 == 0 ? "-" : $12) }' "$CSV"
}
echo
echo "accuracy matrix ($SIZE, reference $SPP spp, noise from a second reference at $NSPP spp):"
table | sed 's/^| //; s/ |$//; /^|-/d' | column -t -s '|'
echo
printf "timing: precompute %.0f s, render %.0f s, reference %.0f s, compare %.0f s; total %s s wall (load average at the end %s)\n" \
  "${T[precompute]}" "${T[render]}" "${T[reference]}" "${T[compare]}" "$wall" "$(cut -d' ' -f1-3 /proc/loadavg)"

md=$OUT/matrix.md
{
  echo "# PRT against the path tracer (make accuracy)"
  echo
  echo "Written by \`tools/accuracy.sh\` (\`make accuracy\`) on $(date -u +%Y-%m-%d), prt $(git rev-parse --short HEAD 2>/dev/null || echo '?'): $SIZE,"
  echo "reference \`prt reference\` at $SPP spp (seed 1), its noise from a second reference at $NSPP spp (seed 2)."
  echo "Scenes: $SCENES. Probes: $PROBES. Yaws (\`--light-rotation\`): $YAWS. Settings: $EFFECTS."
  echo "Knobs: ACCURACY_SCENES=\"$SCENES\" ACCURACY_PROBES=\"$PROBES\" ACCURACY_YAWS=\"$YAWS\" ACCURACY_EFFECTS=\"$EFFECTS\" ACCURACY_SPP=$SPP ACCURACY_NOISE_SPP=$NSPP ACCURACY_SIZE=$SIZE."
  echo
  echo "* **setting**: direct = \`prt precompute --no-bounces\` against \`prt reference --bounces 0\`; full = the precompute's"
  echo "  defaults against the reference with the bounce count \`prt info\` reports the precompute did."
  echo "* **image rel_rmse**: \`prt compare PRT.exr REF.exr\` (sqrt(sum (a-b)^2 / sum b^2) over pixels and channels;"
  echo "  \`--no-background\`, the default camera; render's default backend: gl, per pixel, for a file with highlights,"
  echo "  cpu, per vertex, for a Lambertian one)."
  echo "* **reference noise**: rel_rmse(ref2, ref1) / sqrt(1 + $SPP / $NSPP): the two references' errors are independent"
  echo "  with variances in the ratio of their sample counts. An image error near it is no measurable difference."
  echo "* **PRT alone**: sqrt(image^2 - noise^2), PRT's own error with the reference's noise taken out (0: within it)."
  echo "* **floor shadow**: the same two numbers over the floor's shadow region: floor pixels (covered by the scene and not"
  echo "  by the model alone, both rendered under a uniform white probe, with all 8 neighbours so too: no silhouettes)"
  echo "  whose RGB sum in the direct-only second reference is below 60% of the floor pixels' median (the unshadowed"
  echo "  floor is one value in distant light; 60% as tools/shadows.sh takes it per vertex). The second reference"
  echo "  picks the region so that its noise does not select pixels the first reference happens to have dark."
  echo "  \"-\": no floor, or a region under 50 pixels (a soft probe casts little shadow; its pixel count is still shown)."
  echo
  table
  echo
  echo "Timing (wall, $(nproc) cores, shared machine, summed over the runs that made these files (ACCURACY_RESUME=1 adds"
  echo "its own); load average at the end $(cut -d' ' -f1-3 /proc/loadavg)): precompute ${T[precompute]} s, render ${T[render]} s,"
  echo "reference ${T[reference]} s, compare ${T[compare]} s; total $wall s."
  echo
  echo "Contact sheets, one per scene, setting and yaw (a row per probe: PRT | reference | \`prt compare --error-image\`,"
  echo "shrunk to stay within $SHEET_KB KB; PRT and reference at one exposure per row, the reference's 97th percentile at 0.85;"
  echo "the label: image rel_rmse (reference noise), floor shadow rel_rmse (its reference noise)):"
  echo
  for s in $SCENES; do for e in $EFFECTS; do
    echo "* $s, $e:$(for y in $YAWS; do printf " [yaw %s](%s-%s-yaw%s.png)" "$y" "$s" "$e" "$y"; done)"
  done; done
  [ -f $OUT/hard-cases.png ] && echo "* the README's hard cases (teapot-lambert, studio and sunrise at yaw 135): [hard-cases.png](hard-cases.png)"
  echo
  echo "Every number per image, with the reference's own estimate of its noise from its per-pixel standard errors"
  echo "(ref_noise_stderr) and its seconds: [matrix.csv](matrix.csv)."
} > $md.tmp && mv $md.tmp $md && cp "$CSV" $OUT/matrix.csv.tmp && mv $OUT/matrix.csv.tmp $OUT/matrix.csv || die "could not write $OUT"
echo "wrote $md, $OUT/matrix.csv"
