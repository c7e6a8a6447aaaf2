#!/usr/bin/env bash
# tools/shadows.sh - the shadows' accuracy targets (docs/design/shadows.md) on a Lambert bunny
# (lambert:kd=0.8) over a lambert:kd=0.7 floor under city.exr, direct light (--no-bounces),
# against prt reference: the floor's sun-shadow error per vertex (the study's region: floor
# vertices below 60% of the floor's median reference radiance) and its worst vertex, every
# camera-facing vertex, and the image beside the reference's own noise. Not a test: it measures.
#
#   tools/shadows.sh [build/prt] [precompute flags...]   full bunny + 31,000-vertex floor
#   SHADOWS_QUICK=1 tools/shadows.sh ...                  the study's reduced case: bunny reduced to
#                                                         6,000 vertices, 4,096-vertex floor (a minute)
#   SHADOWS_PROBE=forest                                  another probe (default city)
#   SHADOWS_DIR=build/shadows-refine                      another folder, so another reference: needed where the
#                                                         flags change the mesh (--refine), since the reference is
#                                                         kept per folder and read by vertex id
# The full case with `--light-prior ../shared/data/probes/city.exr` is data/bunny-shadows.json at its
# defaults (the same file but for its recorded timings; docs/design/shadows.md).
# The reference (4,096 samples per vertex, 65,536 in the shadow region, 256 per pixel at 400x300) is
# traced once per case and probe and kept in build/shadows*/; the precompute flags name the variant measured (default: none).
set -eu
PRT=${1:-build/prt}; shift || true
DATA=${PRT_DATA:-../shared/data}
P=${SHADOWS_PROBE:-city}
[ -f "$DATA/models/stanford-bunny.obj" ] && [ -f "$DATA/probes/$P.exr" ] || { echo "shadows: $DATA (PRT_DATA) has no bunny or $P.exr" >&2; exit 1; }
if [ "${SHADOWS_QUICK:-0}" = 1 ]; then
  W=${SHADOWS_DIR:-build/shadows-quick}; FLOOR=4096
  mkdir -p $W
  [ -f $W/bunny.obj ] || /usr/bin/python3 "$(dirname "$0")/study_mesh.py" "$DATA/models/stanford-bunny.obj" $W/bunny.obj 6000 >/dev/null
  OBJ=$W/bunny.obj
else
  W=${SHADOWS_DIR:-build/shadows}; FLOOR=31000; OBJ=$DATA/models/stanford-bunny.obj
  mkdir -p $W
fi
tag=$(echo "default $*" | tr -c 'A-Za-z0-9.\n-' '_' | sed 's/_*$//')
f=$W/$tag.prt
/usr/bin/env time -f "%e s wall, %U s user" "$PRT" precompute "$OBJ" --material lambert:kd=0.8 --floor $FLOOR --no-bounces \
  --quiet -o "$f" "$@" 2> $W/$tag.log || { cat $W/$tag.log >&2; exit 1; }
"$PRT" info "$f" > $W/$tag.info
# the reference per vertex is of this mesh (refinement changes it): keyed by its vertex count
r=$W/ref-$P-v$(awk '/^geometry/ { print $2; exit }' $W/$tag.info)
if [ ! -f $r.csv ]; then
  "$PRT" reference "$f" --probe "$DATA/probes/$P.exr" --spp 256 --vertex-spp 4096 --size 400x300 --no-background \
    --vertices $r.csv -o $r.exr --quiet 2> $r.log
  ff=$(awk '/^ *floor: [0-9]+ vertices \(from vertex/ { gsub(/\)/, ""); print $NF }' $W/$tag.info)
  awk -F, 'NR == 1 || $2 != 0 || $3 != 0 || $4 != 0 || $5 != 0 || $6 != 0 || $7 != 0' $r.csv > $r.front.csv
  med=$(awk -F, -v f="$ff" 'NR > 1 && $1 >= f { print $2 + $3 + $4 }' $r.front.csv | sort -g | awk '{ a[NR] = $1 } END { print a[int((NR + 1) / 2)] }')
  awk -F, -v f="$ff" -v m="$med" 'NR == 1 || ($1 >= f && $2 + $3 + $4 < 0.6 * m)' $r.front.csv > $r.shadow.csv
fi
# The shadow region again at 16x the samples (--vertex-list): at 4,096 a contact-shadow vertex at 1-3%
# of the region's mean radiance carries 8-12% noise of its own, and the worst vertex would measure it.
if [ ! -f $r.shadow-hi.csv ]; then
  "$PRT" reference "$f" --probe "$DATA/probes/$P.exr" --vertex-spp ${SHADOWS_REGION_SPP:-65536} --no-image \
    --vertex-list $r.shadow.csv --vertices $r.shadow-hi.csv --quiet 2>> $r.log
fi
o=$W/$tag-$P
"$PRT" render "$f" --probe "$DATA/probes/$P.exr" --size 400x300 --no-background -o $o.exr --vertices $o.csv 2>/dev/null
# The per-vertex figures are over the input's vertices: refinement adds vertices on visibility edges, the
# hardest places, and keeps the input's indices (refine.h: the models' first, the floor's own after the
# new model vertices, its new ones last), so a refined file is measured where an unrefined one is.
ff=$(awk '/^ *floor: [0-9]+ vertices \(from vertex/ { gsub(/\)/, ""); print $NF }' $W/$tag.info)
read -r m0 f0 < <(sed -n 's/.*(models \([0-9]*\) -> [0-9]*, floor \([0-9]*\) -> .*/\1 \2/p' $W/$tag.info | head -1)
inp() { awk -F, -v m="${m0:--1}" -v f="$ff" -v n="${f0:-0}" 'FNR == 1 || m < 0 || $1 < m || ($1 >= f && $1 < f + n)' "$1" > "$2"; }
inp $r.front.csv $o.rfront.csv; inp $r.shadow.csv $o.rshadow.csv; inp $r.shadow-hi.csv $o.rshadow-hi.csv
keep() { awk -F, 'NR == FNR { k[$1] = 1; next } FNR == 1 || ($1 in k)' "$1" $o.csv > "$2"; }
keep $o.rfront.csv $o.front.csv; keep $o.rshadow.csv $o.shadow.csv
cs=$("$PRT" compare $o.shadow.csv $o.rshadow-hi.csv); ca=$("$PRT" compare $o.front.csv $o.rfront.csv); ci=$("$PRT" compare $o.exr $r.exr 2>/dev/null)
kv() { echo "$1" | tr ' ' '\n' | awk -F= -v k="$2" '$1 == k { printf "%.2f", 100 * $2 }'; }
noise=$(awk '/\.exr/ { for (i = 1; i < NF; i++) if ($i == "noise") print $(i+1) }' $r.log | tr -d ',')
echo "shadows: $(grep -m1 geometry $W/$tag.info | sed 's/^geometry *//'), $P, flags: ${*:-none}; precompute $(tail -n 1 $W/$tag.log)"
echo "  floor sun shadow ($(( $(wc -l < $o.shadow.csv) - 1 )) of the input's vertices)  $(kv "$cs" rel_rmse)%   target <= 4%  (reference noise $(kv "$cs" ref_noise)%)"
echo "  its worst vertex                   $(kv "$cs" max_rel_err)%   target < 20%"
echo "  every vertex facing the camera     $(kv "$ca" rel_rmse)%   (reference noise $(kv "$ca" ref_noise)%)"
echo "  image 400x300                      $(kv "$ci" rel_rmse)%   target: within 2 points of the reference's noise, $(awk -v n="$noise" 'BEGIN { printf "%.2f", 100 * n }')%"
