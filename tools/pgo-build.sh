#!/usr/bin/env bash
# A profile-guided build of prism: the fastest binary this source gives.
#
#   tools/pgo-build.sh            # -> target/pgo/release/prism
#
# Three steps, as CPython's --enable-optimizations does them: build prism
# with counters in every branch and call (-C profile-generate), render the
# demo scenes small with it (tools/pgo-training.txt), then
# build again with the merged counts (-C profile-use), so that LLVM lays out
# hot paths straight, inlines where calls are frequent and keeps cold code
# (errors, rare materials) out of the way. Images are bit-identical to the
# plain release build (the arithmetic is the same; README, Performance). It
# takes two release builds (about 10 minutes on 2 cores) and needs
# llvm-profdata of the compiler's own LLVM version, which rustup's
# `llvm-tools` component has (added here if it is missing).
#
# RUSTFLAGS, if set, replaces the target CPU of .cargo/config.toml here as
# in any cargo build; the profile flags are added to it.
set -euo pipefail
cd "$(dirname "$0")/.."

host=$(rustc -vV | sed -n 's/^host: //p')
bin_dir="$(rustc --print sysroot)/lib/rustlib/$host/bin"
if [ ! -x "$bin_dir/llvm-profdata" ]; then
    echo "pgo-build: adding rustup's llvm-tools component (for llvm-profdata)" >&2
    rustup component add llvm-tools
fi
profdata="$bin_dir/llvm-profdata"

# RUSTFLAGS replaces the config's flags: keep its target CPU unless the
# caller chose one.
if [ -z "${RUSTFLAGS:-}" ] && [ "$(uname -m)" = x86_64 ]; then
    base="-C target-cpu=x86-64-v3"
else
    base="${RUSTFLAGS:-}"
fi

root=$PWD/target/pgo
profiles=$root/profiles
rm -rf "$profiles"
mkdir -p "$profiles"

echo "pgo-build: 1/3 instrumented build" >&2
RUSTFLAGS="$base -C profile-generate=$profiles" \
    cargo build --release --quiet --target-dir "$root/instrumented"

echo "pgo-build: 2/3 training renders" >&2
trainer=$root/instrumented/release/prism
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
n=0
# Each line of tools/pgo-training.txt: a scene and its render options.
while read -r scene options; do
    case $scene in '' | '#'*) continue ;; esac
    n=$((n + 1))
    # shellcheck disable=SC2086 # the options are words
    "$trainer" render "scenes/$scene.toml" -o "$out/$n" $options </dev/null >/dev/null 2>&1 ||
        { echo "pgo-build: the training render '$scene $options' failed" >&2; exit 1; }
done <tools/pgo-training.txt
"$profdata" merge -o "$root/prism.profdata" "$profiles"

echo "pgo-build: 3/3 optimised build" >&2
RUSTFLAGS="$base -C profile-use=$root/prism.profdata" \
    cargo build --release --quiet --target-dir "$root"
echo "pgo-build: wrote $root/release/prism" >&2
