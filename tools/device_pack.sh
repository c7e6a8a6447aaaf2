#!/usr/bin/env bash
# device_pack.sh - packs built binaries with the shared libraries they load, for a lent machine that
# has none of Debian's packages (a GPU host with only its driver and the C runtime).
#
# usage: tools/device_pack.sh OUT.tar.xz BINARY...
#
# The archive holds bin/ (the binaries), lib/ (every library ldd names that the other machine may
# lack) and run.sh (runs a command with LD_LIBRARY_PATH set to lib/). The C runtime (libc, libm,
# libpthread, libdl, librt, ld-linux) stays the host's. OpenImageIO links about 250 libraries for
# formats prt never reads (video, DICOM, GDAL, OpenVDB, ...) and Mesa's OSMesa links LLVM: together
# they are over 500 MB, past what a transfer can carry. Each of those is replaced by a stand-in: a
# library with the same SONAME, symbols and symbol versions, whose data is zero and whose functions
# return a pointer to 4 KB of zeros (read as a string: empty; as a struct: all fields 0; as a count:
# not 0, so nothing is looked up in it): OpenImageIO lists its format libraries' version strings, and
# a NULL there aborts it. OpenImageIO is linked with BIND_NOW, so a stand-in must define every symbol, not only the
# SONAME; its static constructors call into the format libraries (DICOM's codec registry), so the
# functions must return rather than trap. A stand-in is not the library: asking OpenImageIO for a
# format it stands in for (a file that is no image: OpenImageIO tries every reader) may crash, and
# OSMesa does not work (the GL paths there use EGL). Use the archive for device checks only.
set -euo pipefail
[ $# -ge 2 ] || { sed -n '2,15p' "$0" | sed 's/^# \{0,1\}//'; exit 2; }
out=$1; shift
work=$(mktemp -d); trap 'rm -rf "$work"' EXIT
mkdir -p "$work/pack/bin" "$work/pack/lib" "$work/stub"

# Libraries replaced by stand-ins (extended regular expression on the file name).
STUB_RE='^lib(LLVM|OSMesa|gallium|opencv_|dcm|oflog|ofstd|av(codec|format|util|device|filter)|sw(scale|resample)|heif|openjp2|openvdb|raw_r|OpenColorIO|gdal|gdcm|jxl|webp|gif|poppler|rsvg|x26|aom|dav1d|SvtAv1|codec2|z3|icu|spatialite|hdf5|netcdf|gst|cairo|pango|gio|glib|gobject|gdk|xml2|proj|geos|xerces|cfitsio|openmpt|vpx|rav1e|bluray|gnutls|nss|curl|mariadb|pq|ldap|kml)'
# The host's own C runtime.
HOST_RE='^(libc|libm|libpthread|libdl|librt|ld-linux-x86-64)\.so'

# stub LIB DEST: writes a stand-in for LIB (same SONAME, every exported symbol at its version).
stub() {
    local lib=$1 dest=$2 name s
    name=$(basename "$dest")
    local soname; soname=$(objdump -p "$lib" | awk '/SONAME/{print $2}')
    : "${soname:=$name}"
    # objdump -T: ADDRESS FLAGS SECTION SIZE [VERSION] SYMBOL; defined symbols only
    # A symbol that a real library in the pack (or the host's C runtime) also defines is left out
    # (inline C++ templates, std:: instantiations): a stand-in's would interpose on the real one.
    objdump -T "$lib" | awk '$0 ~ /^[0-9a-f]+ / && $0 !~ /\*UND\*/ && $0 !~ /\*ABS\*/ {
        k = 0; for (i = 2; i <= NF; i++) if ($i ~ /^[.*]/) { k = i; break }
        if (!k) next
        size = $(k+1); sym = $NF; ver = (NF == k + 3) ? $(k+2) : "-"
        gsub(/[()]/, "", ver); kind = ($0 ~ / DF / || $(k) == ".text") ? "f" : "o"
        print kind, sym, ver, size }' | sort -u | awk 'NR == FNR { real[$1] = 1; next } !($2 in real)' "$work/real.syms" - \
        > "$work/stub/$name.syms"
    {
        echo '.text'
        awk '$1 == "f" {printf ".globl \"%s\"\n.type \"%s\",@function\n\"%s\": lea prt_stub_zero(%%rip), %%rax; ret\n", $2, $2, $2}' "$work/stub/$name.syms"
        printf '.bss\n.balign 64\nprt_stub_zero: .zero 4096\n.text\n'
        echo '.bss'
        awk '$1 == "o" {sz = 0; h = tolower($4); for (i = 1; i <= length(h); i++) sz = sz * 16 + index("0123456789abcdef", substr(h, i, 1)) - 1; if (sz < 1) sz = 8; printf ".globl \"%s\"\n.type \"%s\",@object\n.size \"%s\", %d\n\"%s\": .zero %d\n", $2, $2, $2, sz, $2, sz}' "$work/stub/$name.syms"
    } | awk '!seen[$0]++' > "$work/stub/$name.s"
    # One version node per version the library defines (the base version, its file name, is skipped).
    awk -v base="$soname" '$3 != "-" && $3 != "Base" && $3 != base {v[$3] = v[$3] "\"" $2 "\";"} END {for (k in v) printf "%s { global: %s };\n", k, v[k]}' \
        "$work/stub/$name.syms" > "$work/stub/$name.map"
    local map=()
    [ -s "$work/stub/$name.map" ] && map=(-Wl,--version-script="$work/stub/$name.map")
    gcc -shared -nostdlib -Wl,-soname,"$soname" "${map[@]}" -o "$dest" "$work/stub/$name.s"
}

# First the libraries each binary loads, real or stood in for; then the real ones' symbols, which no
# stand-in may define; then the copies and the stand-ins.
declare -A seen
: > "$work/libs"
for bin in "$@"; do
    cp "$bin" "$work/pack/bin/"
    while read -r name path; do
        [ -n "$path" ] && [ -f "$path" ] || continue
        [ -n "${seen[$name]:-}" ] && continue
        seen[$name]=1
        echo "$name $path" >> "$work/libs"
    done < <(ldd "$bin" | awk '$2 == "=>" {print $1, $3}')
done
while read -r name path; do
    [[ $name =~ $STUB_RE ]] || nm -D --defined-only "$path" 2>/dev/null | awk '{print $NF}' | sed 's/@.*//'
done < "$work/libs" | sort -u > "$work/real.syms"
while read -r name path; do
    [[ $name =~ $HOST_RE ]] && continue
    if [[ $name =~ $STUB_RE ]]; then stub "$path" "$work/pack/lib/$name"
    else cp -L "$path" "$work/pack/lib/$name"; fi
done < "$work/libs"
cat > "$work/pack/run.sh" <<'EOF'
#!/usr/bin/env bash
# run.sh COMMAND...: runs COMMAND with the packed libraries first on the search path.
here=$(cd "$(dirname "$0")" && pwd)
export LD_LIBRARY_PATH="$here/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}" PATH="$here/bin:$PATH"
exec "$@"
EOF
chmod +x "$work/pack/run.sh"
XZ_OPT="${XZ_OPT:--T0}" tar -C "$work/pack" -cJf "$out.tmp" . && mv "$out.tmp" "$out"
echo "device_pack: $out: $(ls "$work/pack/bin" | wc -l) binaries, $(ls "$work/pack/lib" | wc -l) libraries ($(ls "$work/pack/lib" | grep -cE "$STUB_RE") stand-ins), $(du -h "$out" | cut -f1) compressed"
