#!/bin/sh
# The edge fit's three near-tied gap profiles mixed into one simulated set (issue 85): the
# fitted dome (`dome-gap-30.toml`) with the contact's gap on the dome's own 40 mm profile, on
# 30 mm and on 20 mm, each with the depth map the edge fit gave it (`docs/guide/calibration.md`,
# "The gap profile"; own: that of `edge-2d-dome-fit.toml`), 1,667 taps each from
# `edge-2d-dome-gap30.toml` with a seed of its own (5,001 distinct poses, the recipe's 5,000),
# joined by join_datasets.py and read by `tacsim sim2real --sim` in the edge's frame.
#
#   cargo build --release && sh docs/sim2real-edge2d/gap_mix.sh WORK [SEED]
set -eu
W=$1
SEED=${2:-0}
REAL=${REAL:-../shared/data/real-tactip-edge2d-full}
TACSIM=${TACSIM:-target/release/tacsim}
R=docs/sim2real-edge2d
mkdir -p "$W"
W=$(cd "$W" && pwd)
sed 's/^gap_radius_mm = 30.0/gap_radius_mm = 20.0/; s/^name = .*/name = "edge-dome-gap-20"/' $R/dome-gap-30.toml > "$W/gap20.toml"
cp $R/dome-gap-30.toml "$W/gap30.toml"
grep -v '^gap_radius_mm' $R/dome-gap-30.toml | sed 's/^name = .*/name = "edge-dome-gap-own"/' > "$W/gapown.toml"
recipe() { # name sensor seed depth_offset yield > file
    sed -e "s|^sensor = .*|sensor = \"$2\"|" -e "s/^per_shape = .*/per_shape = 1667/" -e "s/^seed = .*/seed = $3/" \
        -e "s/^depth_offset_mm = .*/depth_offset_mm = $4/" -e "s/^depth_compliance = .*/depth_compliance = $5/" \
        -e "0,/^name = .*/s//name = \"$1\"/" $R/edge-2d-dome-gap30.toml
}
recipe dr-own gapown.toml 10 -2.352 0.16 > "$W/dr-own.toml"
recipe dr-30 gap30.toml 11 -2.352 0.11 > "$W/dr-30.toml"
recipe dr-20 gap20.toml 12 -2.252 0.05 > "$W/dr-20.toml"
for n in dr-own dr-30 dr-20; do
    [ -f "$W/$n/meta.json" ] || "$TACSIM" generate "$W/$n.toml" --out "$W/$n" -q > /dev/null
done
[ -f "$W/mix3/meta.json" ] || python3 $R/join_datasets.py "$W/mix3" "$W/dr-own" "$W/dr-30" "$W/dr-20"
"$TACSIM" sim2real --real "$REAL" --sim "$W/mix3" --out "$W/run-s$SEED" --input motion --turns 16 --edge-frame \
    --match-motion --seed "$SEED" -q | grep -E '^\| pose_'
