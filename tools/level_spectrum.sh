#!/bin/bash
# Builds tools/level_spectrum (the probes' per-level light energy, docs/design/shadows.md)
# against build/libprt.a and runs it: tools/level_spectrum.sh PROBE.exr....
set -e
cd "$(dirname "$0")/.."
make -s build/libprt.a
INCS="$(make -s incs)"
cc -std=c11 -O2 -D_GNU_SOURCE -Wall -Wextra -Wno-unused-parameter -march=x86-64-v2 -pthread $INCS tools/level_spectrum.c \
   build/libprt.a $(make -s libs) -o build/level_spectrum
exec build/level_spectrum "$@"
