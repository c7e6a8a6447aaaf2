#!/usr/bin/env bash
# fuzz_pack.sh - packs the libFuzzer harnesses for a machine without this one's packages:
#   tools/fuzz_pack.sh DIR      builds them (make fuzz-build), then writes into DIR (made empty first)
#     build/fuzz/fuzz_*         the binaries (ASan + UBSan, with their debug information)
#     lib/                      the shared libraries they load that are not the C and C++ runtimes
#                               (ldd; glibc's own, libstdc++ and libgcc_s are left to the machine),
#                               copies stripped of debug information
#     tests/fuzz/               the seeds (corpus/) and each harness's libFuzzer options
#     tools/fuzz.sh, run.sh     run.sh runs tools/fuzz.sh on the packed binaries with lib/ first
#                               on LD_LIBRARY_PATH: `DIR/run.sh --runs 10000000` with FUZZ_JOBS=16
#                               runs every harness to 10 M executions on 16 processes and prints
#                               the table; T=prt selects harnesses; findings in DIR/build/fuzz/findings/
# and prints DIR's size and the newest glibc and libstdc++ symbol versions the binaries need (the
# machine's must be at least those). The harnesses link only libc, libstdc++, zlib and cJSON (and assimp,
# the asset harnesses': gltf, ply, objmtl)
# (tests/fuzz/absent.c), so DIR is a few tens of MB. ASan prints unsymbolized stacks where there
# is no llvm-symbolizer: replay the finding here (build/fuzz/fuzz_NAME FILE) for the lines.
set -eu
[ $# -eq 1 ] && [ -n "$1" ] || { echo "usage: tools/fuzz_pack.sh DIR"; exit 2; }
cd "$(dirname "$0")/.."
dir=$1
if [ -e "$dir" ] && [ -n "$(ls -A "$dir")" ] && [ ! -f "$dir/run.sh" ]; then
  echo "fuzz_pack: $dir holds files and no earlier pack (run.sh): not replacing it"; exit 2
fi
if ! log=$(make --no-print-directory -j"$(nproc)" fuzz-build 2>&1); then
  printf '%s\n' "$log" | tail -n 20
  echo "fuzz_pack: building the harnesses failed"; exit 1
fi
bins=(build/fuzz/fuzz_*)
[ -x "${bins[0]}" ] || { echo "fuzz_pack: no harness in build/fuzz/"; exit 1; }
rm -rf "$dir"
mkdir -p "$dir/build/fuzz" "$dir/lib" "$dir/tests/fuzz" "$dir/tools"
cp "${bins[@]}" "$dir/build/fuzz/"
cp -r tests/fuzz/corpus "$dir/tests/fuzz/"
cp tests/fuzz/*.options "$dir/tests/fuzz/" 2>/dev/null || true
cp tools/fuzz.sh "$dir/tools/"
# Every library ldd resolves for any binary, but the C runtime's (glibc: libc, libm, libpthread,
# libdl, librt, libresolv, libutil, the loader), libstdc++ and libgcc_s, which the machine has
# and which must match its loader.
system='^(linux-vdso|ld-linux|libc|libm|libpthread|libdl|librt|libresolv|libutil|libanl|libstdc\+\+|libgcc_s)\.so'
for b in "${bins[@]}"; do ldd "$b"; done | awk '$2 == "=>" && $3 ~ /^\// { print $1, $3 }' | sort -u |
  while read -r soname path; do
    [[ "$soname" =~ $system ]] && continue
    cp -L "$path" "$dir/lib/$soname"
    chmod u+w "$dir/lib/$soname"
    strip --strip-debug "$dir/lib/$soname"
  done
cat > "$dir/run.sh" <<'EOF'
#!/usr/bin/env bash
# run.sh - the harnesses packed by tools/fuzz_pack.sh: tools/fuzz.sh on the binaries of build/fuzz/
# (no build), with the packed libraries first. `./run.sh --runs 10000000` (FUZZ_JOBS=16: 16
# processes of each harness), `./run.sh --seconds 600`, `./run.sh` (the smoke run).
cd "$(dirname "$0")"
export LD_LIBRARY_PATH="$PWD/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
FUZZ_NO_BUILD=1 exec tools/fuzz.sh "$@"
EOF
chmod +x "$dir/run.sh"
# every library the binaries load is either packed or one of the machine's runtimes
missing=$(for b in "$dir"/build/fuzz/fuzz_*; do LD_LIBRARY_PATH="$dir/lib" ldd "$b"; done |
  awk '$2 == "=>" { print $1, $3 }' | sort -u | while read -r soname path; do
    [[ "$soname" =~ $system ]] || [[ "$path" == "$dir"/lib/* ]] || [[ "$path" == "$(cd "$dir" && pwd)"/lib/* ]] || echo "$soname"
  done)
[ -z "$missing" ] || { echo "fuzz_pack: not packed: $missing"; exit 1; }
need() { objdump -T "$dir"/build/fuzz/fuzz_* "$dir"/lib/* 2>/dev/null | grep -o "$1[0-9.]*" | sort -u -V | tail -n 1; }
echo "fuzz_pack: $dir: $(du -sh "$dir" | cut -f1) ($(ls "$dir/build/fuzz" | wc -l) harnesses, $(du -sh "$dir/build/fuzz" | cut -f1);" \
     "$(ls "$dir/lib" | wc -l) libraries: $(ls "$dir/lib" | tr '\n' ' ' | sed 's/ $//'), $(du -sh "$dir/lib" | cut -f1))"
echo "fuzz_pack: the machine needs $(need 'GLIBC_2\.') and $(need 'GLIBCXX_3\.') (here: glibc $(ldd --version | head -n 1 | awk '{print $NF}'))"
