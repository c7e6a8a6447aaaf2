#!/bin/bash
# Builds tools/prefilter_lights (the prefiltered probe's error at each probe's brightest spot, with
# lights taken out of the ladder and without: src/image/prefilter.h "Lights") against build/libprt.a
# and runs it: tools/prefilter_lights.sh THRESHOLD LIGHTS PROBE.exr...
set -e
cd "$(dirname "$0")/.."
make -s build/libprt.a
INCS="$(make -s incs)"
cc -std=c11 -O2 -D_GNU_SOURCE -Wall -Wextra -Wno-unused-parameter -march=x86-64-v2 -pthread $INCS tools/prefilter_lights.c \
   build/libprt.a $(make -s libs) -o build/prefilter_lights
exec build/prefilter_lights "$@"
