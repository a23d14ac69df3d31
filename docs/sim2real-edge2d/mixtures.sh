#!/bin/sh
# The mixtures tried for the edge recordings (issue 30), each 4 x 1,250 simulated taps joined
# into one set (join_datasets.py) and passed to `tacsim sim2real --sim`:
#  - domes: the edge preset's dome radius 26, 32, 40 and 50 mm (camera, rings and framing
#    refitted by `calibrate --camera-only`), each pressed over its own indentation range
#    (image_change_fit.py's, 40 mm: the recipe's [rig]) and labelled 3..5 mm;
#  - gain: the edge preset pressed 0.9-2.35 mm instead of 0.35-2.35 (5,000 taps), labelled 3..5;
#  - convex: pressed 0.1-2.36 mm, labelled through the convex map i = c + 0.087 c^1.5,
#    c = pose_3 - 2.9 mm (the image growing faster with the press at depth).
# Every set has its own seed, so the mixtures hold 5,000 distinct poses as `edge-2d` does.
#
#   cargo build --release && sh docs/sim2real-edge2d/mixtures.sh target/edge-mixtures
set -eu
W=$1
REAL=${REAL:-../shared/data/real-tactip-edge2d}
TACSIM=${TACSIM:-target/release/tacsim}
mkdir -p "$W"
W=$(cd "$W" && pwd)
recipe() { # name sensor depth_range seed per_shape [keep_rig] > file
    if [ "${6:-}" = rig ]; then drop=""; else drop="/^\[rig\]/d; /^depth_offset_mm/d;"; fi
    sed -e "0,/^name = .*/s//name = \"$1\"/" -e "s|^sensor = .*|sensor = \"$2\"|" \
        -e "s/^depth_mm = .*/depth_mm = [$3]/" -e "s/^seed = .*/seed = $4/" -e "s/^per_shape = .*/per_shape = $5/" \
        -e "$drop" scenarios/datasets/edge-2d.toml
}
for v in "r26|26.0|0.15, 1.4|1" "r32|32.0|0.25, 1.7|2" "r50|50.0|0.45, 2.7|4"; do
    name=${v%%|*}; rest=${v#*|}; radius=${rest%%|*}; rest=${rest#*|}; depth=${rest%%|*}; seed=${rest#*|}
    sed "s/^outer_radius_mm = .*/outer_radius_mm = $radius/" docs/calibration-edge2d/base.toml > "$W/$name-base.toml"
    "$TACSIM" calibrate --real "$REAL" --camera-only --sensor "$W/$name-base.toml" -o "$W/$name.toml" --report "$W/$name-cal" -q > /dev/null
    recipe "edge-2d-$name" "$W/$name.toml" "$depth" $seed 1250 > "$W/$name-recipe.toml"
    rm -rf "$W/$name-sim"; "$TACSIM" generate "$W/$name-recipe.toml" --out "$W/$name-sim" -q > /dev/null
done
recipe edge-2d-r40 tactip-331-edge2d "3.0, 5.0" 3 1250 rig > "$W/r40-recipe.toml"
rm -rf "$W/r40-sim"; "$TACSIM" generate "$W/r40-recipe.toml" --out "$W/r40-sim" -q > /dev/null
rm -rf "$W/domes"
python3 docs/sim2real-edge2d/join_datasets.py "$W/domes" "$W/r26-sim:0.15:1.4" "$W/r32-sim:0.25:1.7" "$W/r40-sim" "$W/r50-sim:0.45:2.7"
recipe edge-2d-gain tactip-331-edge2d "0.9, 2.35" 0 5000 > "$W/gain-recipe.toml"
rm -rf "$W/gain-sim" "$W/gain"; "$TACSIM" generate "$W/gain-recipe.toml" --out "$W/gain-sim" -q > /dev/null
python3 docs/sim2real-edge2d/join_datasets.py "$W/gain" "$W/gain-sim:0.9:2.35"
recipe edge-2d-convex tactip-331-edge2d "0.1, 2.36" 0 5000 > "$W/convex-recipe.toml"
rm -rf "$W/convex-sim" "$W/convex"; "$TACSIM" generate "$W/convex-recipe.toml" --out "$W/convex-sim" -q > /dev/null
python3 docs/sim2real-edge2d/join_datasets.py "$W/convex" "$W/convex-sim:convex:0.087:2.9"
for set in domes gain convex; do
    "$TACSIM" sim2real --real "$REAL" --sim "$W/$set" --out "$W/$set-s2r" -q | grep -E "^\| pose_" | sed "s/^/$set /"
done
