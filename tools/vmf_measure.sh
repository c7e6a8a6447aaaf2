#!/bin/bash
# Builds tools/vmf_measure (the vMF transfer's measurements, until the effects plan drives it)
# against build/libprt.a and runs it: tools/vmf_measure.sh SCENE.json PROBE [options].
set -e
cd "$(dirname "$0")/.."
make -s build/libprt.a
INCS="$(make -s incs)"
cc -std=c11 -O2 -D_GNU_SOURCE -Wall -Wextra -Wno-unused-parameter -march=x86-64-v2 -pthread $INCS tools/vmf_measure.c \
   build/libprt.a $(make -s libs) -o build/vmf_measure
exec build/vmf_measure "$@"
