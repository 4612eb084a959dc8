#!/usr/bin/env bash
# Parallel scaling of prism: wall and CPU seconds of one scene at several
# thread counts, binaries alternated run by run (so that a drift in the
# machine's speed hits all alike). Prepared for a many-core machine (the
# `device` machine: build here, carry the binaries, run this once).
#
#   tools/scaling.sh [-s SCENE] [-r WxH] [-p SPP] [-t "1 2 4 8 16"] [-n RUNS] BINARY [BINARY...]
#
# Writes CSV to stdout (binary,threads,run,wall_s,cpu_s) and, to stderr,
# each binary's median wall time per thread count with its speed-up and
# parallel efficiency against 1 thread.
set -euo pipefail
scene=scenes/cornell-box.toml resolution=512x512 spp=16 threads="1 2 4 8 16" runs=3
while getopts "s:r:p:t:n:" opt; do
    case $opt in
        s) scene=$OPTARG ;; r) resolution=$OPTARG ;; p) spp=$OPTARG ;;
        t) threads=$OPTARG ;; n) runs=$OPTARG ;;
        *) sed -n '2,12p' "$0"; exit 2 ;;
    esac
done
shift $((OPTIND - 1))
[ $# -ge 1 ] || { sed -n '2,12p' "$0"; exit 2; }
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
rows=$out/rows.csv
echo "binary,threads,run,wall_s,cpu_s" | tee "$rows"
for t in $threads; do
    for run in $(seq 1 "$runs"); do
        for bin in "$@"; do
            # bash's `time`: real, then user + system of the child.
            TIMEFORMAT='%R %U %S'
            times=$( { time "$bin" render "$scene" -q -o "$out/img" --threads "$t" \
                --resolution "$resolution" --spp "$spp" --no-spectral >/dev/null 2>&1; } 2>&1 )
            read -r wall user sys <<<"$times"
            cpu=$(awk -v u="$user" -v s="$sys" 'BEGIN { printf "%.3f", u + s }')
            echo "$bin,$t,$run,$wall,$cpu" | tee -a "$rows"
        done
    done
done
# Median wall time per binary and thread count; speed-up and efficiency.
awk -F, 'NR > 1 { key = $1 "," $2; n[key]++; w[key, n[key]] = $4; bins[$1] = 1; ts[$2] = 1 }
END {
    for (b in bins) {
        printf "%s\n", b > "/dev/stderr"
        for (t in ts) {
            key = b "," t; m = n[key]
            for (i = 1; i <= m; i++) v[i] = w[key, i]
            for (i = 1; i <= m; i++) for (j = i + 1; j <= m; j++) if (v[j] < v[i]) { x = v[i]; v[i] = v[j]; v[j] = x }
            med[t] = v[int((m + 1) / 2)]
        }
        for (t in ts) printf "  %3d threads: %8.3f s median, speed-up %5.2f, efficiency %4.0f%%\n", t, med[t], med[1] / med[t], 100 * med[1] / med[t] / t > "/dev/stderr"
    }
}' "$rows"
