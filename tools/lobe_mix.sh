#!/bin/bash
# Builds tools/lobe_mix (one vMF lobe against two per view elevation: brdf/lobefit.h "Two lobes")
# against build/libprt.a and runs it: tools/lobe_mix.sh [SPEC...]
set -e
cd "$(dirname "$0")/.."
make -s build/libprt.a
INCS="$(make -s incs)"
cc -std=c11 -O2 -D_GNU_SOURCE -Wall -Wextra -Wno-unused-parameter -march=x86-64-v2 -pthread $INCS tools/lobe_mix.c \
   build/libprt.a $(make -s libs) -o build/lobe_mix
exec build/lobe_mix "$@"
