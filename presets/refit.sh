#!/usr/bin/env bash
# Regenerates every fitted preset from the recordings (docs/presets.md, "Regenerating the
# fitted presets"). The fit is deterministic: only `provenance.date` changes between runs.
#   bash presets/refit.sh            # all fitted presets
#   bash presets/refit.sh wood metal # only these (file stems of presets/*.json)
# Recordings: $TACTUS_RECORDINGS (default ../shared/recordings) and $TACTUS_RECORDINGS_KITS
# (default ../shared/recordings-kits), both beside the checkout.
set -euo pipefail
cd "$(dirname "$0")/.."
R=${TACTUS_RECORDINGS:-../shared/recordings}
K=${TACTUS_RECORDINGS_KITS:-../shared/recordings-kits}
for d in "$R" "$K"; do
    [ -f "$d/manifest.csv" ] || { echo "error: recordings folder $d not found (set TACTUS_RECORDINGS / TACTUS_RECORDINGS_KITS)" >&2; exit 1; }
done
cargo build --release --quiet --bin tactus
T=target/release/tactus
only=" $* "
# One strike per kit object: its hardest velocity layer, the strike nearest the default hit
# (1 m/s, MIDI velocity 127) that fitted levels are compensated for. The contact exponent
# still learns from all of the object's layers (src/fit/pool/velocity.rs). Columns 1-8 of the kits'
# manifest hold no quoted commas.
hardest() { # COLUMN VALUE: one file per object whose column COLUMN (2 material, 3 instrument) is VALUE
    awk -F, -v col="$1" -v val="$2" 'NR > 1 && $col == val {
        if (!($4 in lay) || $8 + 0 > lay[$4]) { lay[$4] = $8 + 0; best[$4] = $1 }
    } END { for (o in best) print best[o] }' "$K/manifest.csv" | sort | sed "s|^|$K/|"
}
fit() {
    local stem=$1; shift
    if [ -n "${only// /}" ] && [[ "$only" != *" $stem "* ]]; then return; fi
    echo "==> presets/$stem.json" >&2
    "$T" fit "$@" -o "presets/$stem.json"
}
# Materials: every family of the material, family-balanced (each family weighs the same).
fit wood          "$R"/wood_*.wav  $(hardest 2 wood)  --material wood
fit metal         "$R"/metal_*.wav $(hardest 2 metal) --material metal --dense
# Object families.
fit marimba-bar   "$R"/wood_marimba_*.wav                                       --material wood  --name "Marimba Bar"
fit wood-block    "$R"/wood_wood-block_*.wav                                    --material wood  --name "Wood Block"
fit claves        "$R"/wood_claves_*.wav                                        --material wood  --name "Claves"
fit cowbell       "$R"/metal_cowbell_*.wav $(hardest 3 cowbell)                   --material metal --name "Cowbell"
fit steel-pan     "$R"/metal_steel-drum_*.wav                                   --material metal --name "Steel Pan"
fit ride-cymbal   "$R"/metal_ride-cymbal_*.wav $(hardest 3 ride-cymbal)    --material metal --name "Ride Cymbal" --dense
fit crash-cymbal  $(hardest 3 crash-cymbal)                                     --material metal --name "Crash Cymbal" --dense
fit china-cymbal  $(hardest 3 china-cymbal)                                     --material metal --name "China Cymbal" --dense
fit splash-cymbal $(hardest 3 splash-cymbal)                                    --material metal --name "Splash Cymbal" --dense
fit agogo-bell    $(hardest 3 agogo-bell)                                       --material metal --name "Agogo Bell"
