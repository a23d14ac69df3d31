#!/bin/sh
# The candidate models for the edge recordings' TacTip (issue 30), compared two ways:
#  1. image change: how much each tap changes the pin image, real against simulated, through
#     the depth and lateral map that fits best on the fitting 80% (image_change_fit.py), scored
#     on the held-out 20%;
#  2. sim-to-real: `tacsim sim2real` with each candidate (with --sim2real; about 6 minutes
#     each on 2 cores), the pose network trained on its images and scored on the held-out 20%.
# Each candidate is the calibrated default with one change, then `tacsim calibrate
# --camera-only` on the edge recordings (camera, ring layout, framing), so every candidate
# matches the undeformed real image.
#
#   cargo build --release && sh docs/sim2real-edge2d/candidates.sh target/edge-candidates [--sim2real]
set -eu
W=$1
S2R=${2:-}
REAL=${REAL:-../shared/data/real-tactip-edge2d}
TACSIM=${TACSIM:-target/release/tacsim}
mkdir -p "$W"
W=$(cd "$W" && pwd)

# name | sed expression on the calibrated preset | skin | sim2real depth range (mm)
CANDIDATES="
r20|s/^outer_radius_mm = .*/outer_radius_mm = 20.0/|half-space|0.1, 1.1
r20-layer|s/^outer_radius_mm = .*/outer_radius_mm = 20.0/|layer|0.1, 1.1
r20-skin-on-gel|s/^outer_radius_mm = .*/outer_radius_mm = 20.0/|skin-on-gel|0.1, 0.9
r20-lever-1.4|s/^length_mm = .*/length_mm = 1.4/|half-space|0.2, 1.6
r20-lever-0.35|s/^length_mm = .*/length_mm = 0.35/|half-space|0.3, 2.3
r26|s/^outer_radius_mm = .*/outer_radius_mm = 26.0/|half-space|0.15, 1.4
r32|s/^outer_radius_mm = .*/outer_radius_mm = 32.0/|half-space|0.25, 1.7
r40|s/^outer_radius_mm = .*/outer_radius_mm = 40.0/|half-space|0.35, 2.2
"

recipe() { # name sensor skin depth_range(indentation, mm: the recipe's [rig] dropped) per_shape out
    sed -e "0,/^name = .*/s//name = \"$1\"/" -e "s|^sensor = .*|sensor = \"$2\"\nskin = \"$3\"|" \
        -e "s/^depth_mm = .*/depth_mm = [$4]/" -e "s/^per_shape = .*/per_shape = $5/" \
        -e "/^\[rig\]/d" -e "/^depth_offset_mm/d" \
        scenarios/datasets/edge-2d.toml > "$6"
}

SETS=""
echo "$CANDIDATES" | while IFS='|' read -r name expr skin depth; do
    [ -n "$name" ] || continue
    sed "$expr" sim/presets/tactip-331-calibrated.toml > "$W/$name-base.toml"
    "$TACSIM" calibrate --real "$REAL" --camera-only --sensor "$W/$name-base.toml" -o "$W/$name.toml" --report "$W/$name-calibration" -q > /dev/null
    recipe "$name-wide" "$W/$name.toml" "$skin" "0.05, 3.0" 1500 "$W/$name-wide.toml"
    rm -rf "$W/$name-wide"
    "$TACSIM" generate "$W/$name-wide.toml" --out "$W/$name-wide" -q > /dev/null
done
python3 docs/sim2real-edge2d/image_change_fit.py "$REAL" $(echo "$CANDIDATES" | cut -d'|' -f1 | sed "/^$/d; s|.*|$W/&-wide|")

if [ "$S2R" = "--sim2real" ]; then
    echo "$CANDIDATES" | while IFS='|' read -r name expr skin depth; do
        [ -n "$name" ] || continue
        recipe "$name" "$W/$name.toml" "$skin" "$depth" 2000 "$W/$name-s2r.toml"
        "$TACSIM" sim2real --real "$REAL" --recipe "$W/$name-s2r.toml" --out "$W/$name-s2r" -q | grep -E "^\| pose_" | sed "s/^/$name /"
    done
fi
