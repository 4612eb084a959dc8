#!/usr/bin/env bash
# Packs Mitsuba 3's llvm_ad_spectral variant (and what tools/bench.py needs
# beside numpy and matplotlib) for a machine that cannot reach a package
# registry, such as the lent `device` machine, in under 50 MB: the wheels
# for that machine's Python, less the other variants and the plugins the
# peer scenes do not use, stripped; libLLVM 19 from this machine
# (`apt-get install libllvm19`), with stub libraries standing in for the
# Z3 and libxml2 it links but Dr.Jit's JIT never calls.
#
#   tools/offline_peers.sh [-p PYTHON_VERSION] OUT_DIR
#
# There: `source OUT_DIR/unpack.sh` (unpacks into /tmp/peers and sets
# PYTHONPATH, LD_LIBRARY_PATH and DRJIT_LIBLLVM_PATH), then run
# tools/bench.py as usual. Measured with it: docs/performance.md, "At 16
# threads, on a 16-core AVX-512 machine".
set -euo pipefail
py=3.12
while getopts "p:" opt; do
    case $opt in p) py=$OPTARG ;; *) sed -n '2,15p' "$0"; exit 2 ;; esac
done
shift $((OPTIND - 1))
[ $# -eq 1 ] || { sed -n '2,15p' "$0"; exit 2; }
out=$(realpath -m "$1")
llvm=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1
[ -f "$llvm" ] || { echo "needs $llvm (apt-get install libllvm19)" >&2; exit 1; }
mkdir -p "$out"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# The versions tools/bench-requirements.txt pins.
mapfile -t pins < <(grep -E '^(mitsuba|drjit|OpenEXR|flip-evaluator)==' \
    "$(dirname "$0")/bench-requirements.txt")
python3 -m pip download -q --no-deps --only-binary=:all: --python-version "$py" \
    --implementation cp --platform manylinux_2_28_x86_64 --platform manylinux_2_27_x86_64 \
    --platform manylinux_2_17_x86_64 --platform manylinux2014_x86_64 -d "$work/wheels" "${pins[@]}"
cp "$work"/wheels/openexr-*.whl "$work"/wheels/flip_evaluator-*.whl "$out/"

# Mitsuba: the LLVM spectral variant and the plugins of tools/peer_scenes.py.
keep="area box gaussian diffuse dielectric hdrfilm independent obj merge path perspective
      rectangle sphere cube regular irregular uniform srgb d65 constant twosided envmap bitmap"
mkdir "$work/site"
(cd "$work/site" && for w in "$work"/wheels/mitsuba-*.whl "$work"/wheels/drjit-*.whl; do unzip -q "$w"; done)
cd "$work/site/mitsuba"
ls ./*.so | grep -v -e "^./lib" -e llvm_ad_spectral. -e mitsuba_ext -e mitsuba_alias | xargs rm -f
rm -rf include cmake pkgconfig mitsuba_stubs data/sunsky ../share ../drjit/include ../drjit/cmake
for f in plugins/*.so; do
    n=$(basename "$f" .so)
    echo " $(echo $keep) " | grep -q " $n " || rm "$f"
done
cd "$work/site"
find . -name "*.so" -exec strip --strip-unneeded {} +
tar -cf - . | xz -T0 -9 >"$out/site.tar.xz"

# libLLVM and the libraries it links that a bare machine may lack.
mkdir "$work/lib"
cd "$work/lib"
# libLLVM's undefined symbols matching $1, as "(VERSION) name" lines.
undefined() { objdump -T "$llvm" | awk -v p="$1" '/\*UND\*/ && $NF ~ p { print $(NF-1), $NF }' | sort -u; }
# A C function that traps for each such line: never called, only bound.
stubs() { awk '{ print "void " $2 "(void) { __builtin_trap(); }" }' "$@"; }
undefined '^Z3_' | stubs >z3.c
gcc -shared -fPIC -o libz3.so.4 -Wl,-soname,libz3.so.4 z3.c
undefined '^xml' >xml.txt
stubs xml.txt >xml.c
{   # libLLVM asks for libxml2's symbol versions: the stub must define them.
    echo "LIBXML2_2.4.30 {"; awk '$1 == "(LIBXML2_2.4.30)" { print "  " $2 ";" }' xml.txt; echo "};"
    echo "LIBXML2_2.6.0 {"; awk '$1 == "(LIBXML2_2.6.0)" { print "  " $2 ";" }' xml.txt; echo "} LIBXML2_2.4.30;"
} >xml.map
gcc -shared -fPIC -o libxml2.so.2 -Wl,-soname,libxml2.so.2 -Wl,--version-script=xml.map xml.c
rm z3.c xml.c xml.txt xml.map
for l in libedit.so.2 libbsd.so.0 libmd.so.0 libffi.so.8 libtinfo.so.6; do cp -L "/lib/x86_64-linux-gnu/$l" .; done
cp "$llvm" .
tar -cf - . | xz -T0 -6 >"$out/lib.tar.xz"

cat >"$out/unpack.sh" <<'EOF'
# source this: unpacks the bundle beside it into /tmp/peers.
here=$(dirname "$(realpath "${BASH_SOURCE[0]}")")
mkdir -p /tmp/peers/site /tmp/peers/lib
python3 -m pip install -q --no-index --no-deps --no-compile --target /tmp/peers/site "$here"/*.whl
tar -xJf "$here/site.tar.xz" -C /tmp/peers/site
tar -xJf "$here/lib.tar.xz" -C /tmp/peers/lib
# The machine's own copies of these, where it has them, win.
for l in libffi.so.8 libtinfo.so.6 libbsd.so.0 libmd.so.0; do
    ldconfig -p | grep -q "$l " && rm -f "/tmp/peers/lib/$l"
done
export PYTHONPATH=/tmp/peers/site LD_LIBRARY_PATH=/tmp/peers/lib
export DRJIT_LIBLLVM_PATH=/tmp/peers/lib/libLLVM.so.19.1
EOF
du -sh "$out"
