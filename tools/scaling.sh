#!/usr/bin/env bash
# Parallel scaling of prism: wall, CPU and render seconds of one scene at
# several thread counts, binaries alternated run by run (so that a drift in
# the machine's speed hits all alike). Prepared for a many-core machine (the
# `device` machine: build here, carry the binaries, run this once).
#
#   tools/scaling.sh [-s SCENE] [-r WxH] [-p SPP] [-t "1 2 4 8 16"] [-n RUNS]
#                    [-i INTEGRATOR] [-c] BINARY [BINARY...]
#
# -c also runs, at every thread count T, T single-thread renders of the
# first binary at once: the machine's own ceiling (shared caches, memory bandwidth and clock
# speed under load), against which a T-thread render can be judged.
# Writes CSV to stdout (binary,mode,threads,run,wall_s,cpu_s,render_s;
# render_s is the render alone, as prism reports it, without loading and
# writing) and, to stderr, each binary's median times per thread count with
# speed-up and parallel efficiency against 1 thread.
set -euo pipefail
scene=scenes/cornell-box.toml resolution=512x512 spp=16 threads="1 2 4 8 16" runs=3
integrator="" ceiling=0
while getopts "s:r:p:t:n:i:c" opt; do
    case $opt in
        s) scene=$OPTARG ;; r) resolution=$OPTARG ;; p) spp=$OPTARG ;;
        t) threads=$OPTARG ;; n) runs=$OPTARG ;; i) integrator=$OPTARG ;;
        c) ceiling=1 ;;
        *) sed -n '2,16p' "$0"; exit 2 ;;
    esac
done
shift $((OPTIND - 1))
[ $# -ge 1 ] || { sed -n '2,16p' "$0"; exit 2; }
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
rows=$out/rows.csv
extra=()
[ -n "$integrator" ] && extra=(--integrator "$integrator")

# One render: prints "wall cpu render" (bash's `time`: real, user, system).
render() { # binary threads tag
    TIMEFORMAT='%R %U %S'
    local times
    times=$( { time "$1" render "$scene" -o "$out/img-$3" --threads "$2" "${extra[@]}" \
        --resolution "$resolution" --spp "$spp" --no-spectral >"$out/log-$3" 2>&1; } 2>&1 )
    local wall user sys rendered
    read -r wall user sys <<<"$times"
    rendered=$(sed -n 's/^rendered .* in \([0-9.]*\) s.*/\1/p' "$out/log-$3")
    awk -v w="$wall" -v u="$user" -v s="$sys" -v r="${rendered:-nan}" \
        'BEGIN { printf "%s %.3f %s\n", w, u + s, r }'
}

echo "binary,mode,threads,run,wall_s,cpu_s,render_s" | tee "$rows"
for t in $threads; do
    for run in $(seq 1 "$runs"); do
        for bin in "$@"; do
            read -r wall cpu rendered <<<"$(render "$bin" "$t" one)"
            echo "$bin,threads,$t,$run,$wall,$cpu,$rendered" | tee -a "$rows"
            if [ "$ceiling" = 1 ] && [ "$t" -gt 1 ] && [ "$bin" = "$1" ]; then
                # T one-thread renders at once; the slowest one counts.
                rm -f "$out"/c*
                for k in $(seq 1 "$t"); do render "$bin" 1 "c$k" >"$out/c$k" & done
                wait
                slowest=$(sort -k3 -g "$out"/c* | tail -1)
                read -r wall cpu rendered <<<"$slowest"
                echo "$bin,ceiling,$t,$run,$wall,$cpu,$rendered" | tee -a "$rows"
            fi
        done
    done
done
# Median render time per binary, mode and thread count; speed-up and
# efficiency against the same binary's 1-thread render. For the ceiling rows
# the "speed-up" is T times the one-thread render over the slowest of T
# concurrent ones: the most a T-thread render could reach on this machine.
awk -F, 'NR > 1 { key = $1 "," $2 "," $3; n[key]++; r[key, n[key]] = $7; w[key, n[key]] = $5
                  bins[$1] = 1; modes[$2] = 1; ts[$3] = 1 }
function median(key, arr,   m, i, j, x, v) {
    m = n[key]
    for (i = 1; i <= m; i++) v[i] = arr[key, i]
    for (i = 1; i <= m; i++) for (j = i + 1; j <= m; j++) if (v[j] + 0 < v[i] + 0) { x = v[i]; v[i] = v[j]; v[j] = x }
    return v[int((m + 1) / 2)]
}
END {
    for (b in bins) {
        printf "%s\n", b > "/dev/stderr"
        one = median(b ",threads,1", r)
        for (md in modes) for (t in ts) {
            key = b "," md "," t
            if (!(key in n)) continue
            rt = median(key, r); wt = median(key, w)
            printf "  %-8s %3d threads: render %8.3f s, wall %8.3f s median; speed-up %5.2f, efficiency %4.0f%%\n", \
                md, t, rt, wt, t * one / rt / (md == "threads" ? t : 1), 100 * one / rt / (md == "threads" ? t : 1) > "/dev/stderr"
        }
    }
}' "$rows"
