#!/usr/bin/env bash
# tools/shadows_teapot.sh - docs/design/shadows.md's teapot figure (docs/shadows_teapot.png): the handle's
# shadow of data/teapot-floor.json at its defaults, of data/teapot-shadows.json (its light prior and
# "refine": true) and of prt reference, under city.exr, direct light (--no-bounces), seen from behind
# the handle, cropped and enlarged 1.5x, and below, the whole default view with the light turned 90 degrees;
# prints each image's error against the reference. Not a test.
#   tools/shadows_teapot.sh [build/prt]     (needs ../shared/data, or PRT_DATA, and python3-pil; ~5 min)
set -eu
PRT=${1:-build/prt}
DATA=${PRT_DATA:-../shared/data}
W=build/shadows-teapot
CAM=-6,6,-9,0,1,0,45
SPP=${TEAPOT_SPP:-512}
mkdir -p $W
[ -f "$DATA/probes/city.exr" ] || { echo "shadows_teapot: $DATA (PRT_DATA) has no city.exr" >&2; exit 1; }
for s in teapot-floor teapot-shadows; do
  "$PRT" precompute data/$s.json --no-bounces --quiet -o $W/$s.prt
  for o in exr png; do
    "$PRT" render $W/$s.prt --probe "$DATA/probes/city.exr" --size 800x600 --camera $CAM --no-background --exposure -2 -o $W/$s.$o 2>/dev/null
  done
  echo "$s: $("$PRT" info $W/$s.prt | grep -m1 geometry | sed 's/^geometry *//')"
done
for o in exr png; do
  [ -f $W/ref.$o ] || "$PRT" reference $W/teapot-floor.prt --probe "$DATA/probes/city.exr" --spp $SPP --size 800x600 --camera $CAM \
    --no-background --exposure -2 -o $W/ref.$o --quiet 2>> $W/ref.log
done
# The second row: the whole default view with the light turned 90 degrees (where a sawtoothed edge shows),
# away from the prior's own orientation, where the light-weighted texels do not apply.
for o in exr png; do
  for s in teapot-floor teapot-shadows; do
    "$PRT" render $W/$s.prt --probe "$DATA/probes/city.exr" --light-rotation 90 --size 400x300 --no-background --exposure -2 -o $W/$s-90.$o 2>/dev/null
  done
  [ -f $W/ref-90.$o ] || "$PRT" reference $W/teapot-floor.prt --probe "$DATA/probes/city.exr" --light-rotation 90 --spp $SPP --size 400x300 \
    --no-background --exposure -2 -o $W/ref-90.$o --quiet 2>> $W/ref.log
done
for s in teapot-floor teapot-shadows; do echo "$s, image against the reference ($SPP spp): $("$PRT" compare $W/$s.exr $W/ref.exr); turned 90: $("$PRT" compare $W/$s-90.exr $W/ref-90.exr)"; done
# Per vertex (4,096 samples each): the floor's shadow region as tools/shadows.sh takes it (floor vertices
# below 60% of the floor's median reference radiance), so the image's error can be told from the vertices'.
for s in teapot-floor teapot-shadows; do
  [ $W/$s.vref.csv -nt $W/$s.prt ] || "$PRT" reference $W/$s.prt --probe "$DATA/probes/city.exr" --vertex-spp 4096 --no-image \
    --vertices $W/$s.vref.csv --quiet 2>> $W/ref.log
  "$PRT" render $W/$s.prt --probe "$DATA/probes/city.exr" --size 64x48 -o $W/x.exr --vertices $W/$s.v.csv 2>/dev/null
  ff=$("$PRT" info $W/$s.prt | awk '/^ *floor: [0-9]+ vertices \(from vertex/ { gsub(/\)/, ""); print $NF }')
  med=$(awk -F, -v f="$ff" 'NR > 1 && $1 >= f { print $2 + $3 + $4 }' $W/$s.vref.csv | sort -g | awk '{ a[NR] = $1 } END { print a[int((NR + 1) / 2)] }')
  awk -F, -v f="$ff" -v m="$med" 'NR == 1 || ($1 >= f && $2 + $3 + $4 < 0.6 * m)' $W/$s.vref.csv > $W/$s.vref-sh.csv
  awk -F, 'NR == FNR { k[$1] = 1; next } FNR == 1 || ($1 in k)' $W/$s.vref-sh.csv $W/$s.v.csv > $W/$s.v-sh.csv
  ratio=$(awk -F, 'NR == FNR { if (FNR > 1) r[$1] = $2 + $3 + $4; next } FNR > 1 && ($1 in r) { a += $2 + $3 + $4; t += r[$1] } END { printf "%.4f", a / t }' $W/$s.vref-sh.csv $W/$s.v.csv)
  echo "$s, per vertex: all $("$PRT" compare $W/$s.v.csv $W/$s.vref.csv); floor shadow ($(($(wc -l < $W/$s.vref-sh.csv) - 1)) vertices) $("$PRT" compare $W/$s.v-sh.csv $W/$s.vref-sh.csv), mean ratio $ratio"
done
/usr/bin/python3 - "$W" "$SPP" <<'P'
import sys
from PIL import Image, ImageDraw
w, spp = sys.argv[1], sys.argv[2]
box, z = (440, 250, 720, 460), 1.5
names = [("teapot-floor", "teapot-floor.json (defaults)"), ("teapot-shadows", "teapot-shadows.json (prior, refined 3x)"),
         ("ref", "prt reference, %s spp" % spp)]
pw, ph = int((box[2] - box[0]) * z), int((box[3] - box[1]) * z)
out = Image.new("RGB", (3 * pw + 40, 2 * ph + 90), "white")
d = ImageDraw.Draw(out)
d.text((10, 6), "Teapot (paper-phong) over its floor under city.exr, direct light, N = 128, 8-bit: the handle's shadow", fill="black")
for i, (f, label) in enumerate(names):
    im = Image.open("%s/%s.png" % (w, f)).convert("RGB").crop(box).resize((pw, ph), Image.LANCZOS)
    out.paste(im, (10 + i * (pw + 10), 40))
    d.text((10 + i * (pw + 10), 26), label, fill="black")
    im = Image.open("%s/%s-90.png" % (w, f)).convert("RGB").resize((pw, ph), Image.LANCZOS)   # 400x300 -> the panel's size
    out.paste(im, (10 + i * (pw + 10), ph + 80))
    d.text((10 + i * (pw + 10), ph + 66), label + ", light turned 90 degrees", fill="black")
out.save("docs/shadows_teapot.png")
print("wrote docs/shadows_teapot.png")
P
