#!/usr/bin/env bash
# Renders one frame as PARTS sample ranges with GNU parallel, then merges them.
#
#   tools/farm/render-parallel.sh SCENE.toml OUT SPP PARTS [GNU parallel options...]
#
# On this machine, 2 jobs at a time:
#   tools/farm/render-parallel.sh scenes/cornell-box.toml renders/cbox 1024 8 -j 2
# Over ssh hosts that share this file system (same paths everywhere), one
# job per host at a time, each using all its cores:
#   tools/farm/render-parallel.sh scenes/cornell-box.toml renders/cbox 1024 8 \
#       --sshlogin node1,node2,node3 -j 1 --workdir "$PWD"
#
# Each part writes OUT.partI.spectral.exr (plus its RGB preview); the merge
# writes OUT.spectral.exr, OUT.exr and OUT.png. PRISM names the binary
# (default: prism on the PATH).
set -euo pipefail
if [ $# -lt 4 ]; then
    sed -n '2,17p' "$0" >&2
    exit 2
fi
scene=$1 out=$2 spp=$3 parts=$4
shift 4
prism=${PRISM:-prism}
mkdir -p "$(dirname "$out")"
rm -f "$out".part*.spectral.exr
for ((i = 0; i < parts; i++)); do
    echo "$((i * spp / parts)) $(((i + 1) * spp / parts)) $i"
done | parallel --will-cite --colsep ' ' --halt now,fail=1 "$@" \
    "$prism" render "$scene" -q --samples '{1}..{2}' -o "$out.part{3}"
parts_written=("$out".part*.spectral.exr)
"$prism" merge -o "$out" "${parts_written[@]}"
