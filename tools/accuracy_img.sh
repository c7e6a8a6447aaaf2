#!/bin/bash
# Builds tools/accuracy_img (make accuracy's masks, masked rel_rmse and contact sheets) against
# build/libprt.a when missing or older than its source, and runs it: tools/accuracy_img.sh COMMAND ARGS...
set -e
cd "$(dirname "$0")/.."
make -s build/libprt.a
if [ ! -x build/accuracy_img ] || [ tools/accuracy_img.c -nt build/accuracy_img ] || [ build/libprt.a -nt build/accuracy_img ]; then
  INCS="$(make -s incs)"
  cc -std=c11 -O2 -D_GNU_SOURCE -Wall -Wextra -Wno-unused-parameter -march=x86-64-v2 -pthread $INCS tools/accuracy_img.c \
     build/libprt.a $(make -s libs) -o build/accuracy_img.tmp && mv build/accuracy_img.tmp build/accuracy_img
fi
exec build/accuracy_img "$@"
