#!/usr/bin/env bash
# Runs every fuzz target for a bounded time (the long suite; docs/bench/README.md).
#   bash fuzz/run.sh [seconds per target, default 60]
# Needs cargo-fuzz (`cargo install cargo-fuzz`) and the nightly toolchain. The shipped presets and
# scenes seed the corpora; new inputs go to fuzz/corpus/<target> (not committed), crashes to
# fuzz/artifacts/<target>, and the script exits non-zero on the first crash.
set -euo pipefail
secs="${1:-60}"
cd "$(dirname "$0")"
for target in preset_json:../presets scene_json:../scenes; do
    name="${target%%:*}"
    seeds="${target#*:}"
    mkdir -p "corpus/$name"
    echo "== $name: ${secs} s"
    cargo +nightly fuzz run "$name" "corpus/$name" "$seeds" -- -max_total_time="$secs" -max_len=65536
done
