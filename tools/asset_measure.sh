#!/bin/bash
# Builds tools/asset_measure (load times of prt's OBJ parser against assimp's glTF, PLY and OBJ
# readers on a model subdivided to about 1 M triangles; docs/design/assets.md) against
# build/libprt.a and runs it: tools/asset_measure.sh MODEL.obj [LEVELS] [OUTDIR].
set -e
cd "$(dirname "$0")/.."
make -s build/libprt.a
INCS="$(make -s incs)"
cc -std=c11 -O2 -D_GNU_SOURCE -Wall -Wextra -Wno-unused-parameter -march=x86-64-v2 -pthread $INCS tools/asset_measure.c \
   build/libprt.a $(make -s libs) -o build/asset_measure
exec build/asset_measure "$@"
