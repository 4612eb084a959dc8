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
# plain release build (the arithmetic is the same; docs/performance-history.md). It
# takes two release builds (about 10 minutes on 2 cores) and needs
# llvm-profdata of the compiler's own LLVM version, which rustup's
# `llvm-tools` component has (added here if it is missing).
#
# The profile flags are added to the build's own flags: the target CPU of
# .cargo/config.toml, or RUSTFLAGS where it is set (which, as in any cargo
# build, replaces the config's).
set -euo pipefail
cd "$(dirname "$0")/.."

host=$(rustc -vV | sed -n 's/^host: //p')
bin_dir="$(rustc --print sysroot)/lib/rustlib/$host/bin"
if [ ! -x "$bin_dir/llvm-profdata" ]; then
    echo "pgo-build: adding rustup's llvm-tools component (for llvm-profdata)" >&2
    rustup component add llvm-tools
fi
profdata="$bin_dir/llvm-profdata"

# cargo joins every matching [target] entry's rustflags, so a cfg(all())
# entry given on the command line adds to the config's target CPU; RUSTFLAGS
# replaces all of them, so there the flags go into it.
build() { # target dir, profile flag
    if [ -n "${RUSTFLAGS:-}" ]; then
        RUSTFLAGS="$RUSTFLAGS $2" cargo build --release --quiet --target-dir "$1"
    else
        cargo build --release --quiet --target-dir "$1" \
            --config "target.'cfg(all())'.rustflags = [\"$2\"]"
    fi
}

root=$PWD/target/pgo
profiles=$root/profiles
rm -rf "$profiles"
mkdir -p "$profiles"

echo "pgo-build: 1/3 instrumented build" >&2
build "$root/instrumented" "-Cprofile-generate=$profiles"

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
build "$root" "-Cprofile-use=$root/prism.profdata"
echo "pgo-build: wrote $root/release/prism" >&2
