#!/bin/bash
# Builds tools/probe_downsample (a latlong probe shrunk with its power kept; data/README.md) against
# build/libprt.a and runs it: tools/probe_downsample.sh IN.exr OUT.exr FACTOR.
set -e
cd "$(dirname "$0")/.."
make -s build/libprt.a
INCS="$(make -s incs)"
cc -std=c11 -O2 -D_GNU_SOURCE -Wall -Wextra -Wno-unused-parameter -march=x86-64-v2 -pthread $INCS tools/probe_downsample.c \
   build/libprt.a $(make -s libs) -o build/probe_downsample
exec build/probe_downsample "$@"
