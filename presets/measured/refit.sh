#!/usr/bin/env bash
# Regenerates the measured materials from Traer et al.'s mode tables as PyImpact ships them
# (docs/measured.md). The fit is deterministic: only `provenance.date` changes between runs.
#   bash presets/measured/refit.sh             # all fourteen
#   bash presets/measured/refit.sh glass metal # only these (file stems)
# Tables: $TACTUS_MEASURED/materials (default ../shared/measured/materials, beside the checkout).
# Every size class's table of a material is pooled; --table-objects 1 keeps the rows PyImpact
# draws an object from (the first ten of each table).
set -euo pipefail
cd "$(dirname "$0")/../.."
M=${TACTUS_MEASURED:-../shared/measured}/materials
[ -f "$M/metal_0_mm.json" ] || { echo "error: mode tables $M not found (set TACTUS_MEASURED)" >&2; exit 1; }
cargo build --quiet --bin tactus
T=target/debug/tactus
only=" $* "
fit() { # STEM PYIMPACT-NAME CLASS NAME
    local stem=$1 py=$2 class=$3 name=$4
    if [ -n "${only// /}" ] && [[ "$only" != *" $stem "* ]]; then return; fi
    local files=()
    for c in 0 1 2 3 4 5; do
        # PyImpact's ceramic size-3 table is shipped as Ceramic_3_mm.json (capital C).
        if [ -f "$M/${py}_${c}_mm.json" ]; then files+=("$M/${py}_${c}_mm.json"); else files+=("$M/${py^}_${c}_mm.json"); fi
    done
    echo "==> presets/measured/$stem.json" >&2
    "$T" fit "${files[@]}" --material "$class" --name "$name" --table-objects 1 -o "presets/measured/$stem.json"
}
fit ceramic           ceramic           ceramic   "Ceramic (measured)"
fit glass             glass             glass     "Glass (measured)"
fit stone             stone             stone     "Stone (measured)"
fit metal             metal             metal     "Metal (measured)"
fit wood-hard         wood_hard         wood      "Hard Wood (measured)"
fit wood-medium       wood_medium       wood      "Medium Wood (measured)"
fit wood-soft         wood_soft         wood      "Soft Wood (measured)"
fit plastic-hard      plastic_hard      plastic   "Hard Plastic (measured)"
fit plastic-soft-foam plastic_soft_foam plastic   "Soft Plastic Foam (measured)"
fit rubber            rubber            rubber    "Rubber (measured)"
fit cardboard         cardboard         cardboard "Cardboard (measured)"
fit paper             paper             paper     "Paper (measured)"
fit leather           leather           leather   "Leather (measured)"
fit fabric            fabric            fabric    "Fabric (measured)"
