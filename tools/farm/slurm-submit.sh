#!/usr/bin/env bash
# Submits a prism render as a Slurm job array of PARTS tasks and a merge job
# that runs when all of them have succeeded.
#
#   tools/farm/slurm-submit.sh SCENE.toml OUT SPP PARTS [extra sbatch options...]
#   tools/farm/slurm-submit.sh scenes/cornell-box.toml renders/cbox 4096 32 --partition=cpu
set -euo pipefail
if [ $# -lt 4 ]; then
    sed -n '2,6p' "$0" >&2
    exit 2
fi
scene=$1 out=$2 spp=$3 parts=$4
shift 4
prism=${PRISM:-prism}
here=$(cd "$(dirname "$0")" && pwd)
mkdir -p "$(dirname "$out")"
array=$(sbatch --parsable "$@" --array="0-$((parts - 1))" \
    --export="ALL,SCENE=$scene,OUT=$out,SPP=$spp,PRISM=$prism" "$here/slurm-array.sbatch")
sbatch "$@" --dependency="afterok:${array%%;*}" --job-name=prism-merge \
    --wrap "$prism merge -o '$out' '$out'.part*.spectral.exr"
