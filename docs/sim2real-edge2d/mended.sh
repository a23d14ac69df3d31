#!/bin/sh
# The sim-to-real rows measured after the reference was mended (issue 30,
# docs/guide/sim2real.md, "The reference was not undeformed"): the candidates' sensors as
# `candidates.sh WORK` fits them (camera against the taps that touch nothing, the default
# `--consensus alike`), pressed over the range the image-change fit gives, 5,000 taps each;
# then the recipe with the edge preset refitted the same way. About 12-20 minutes a row on 2
# cores after the first (the real-trained network is trained once and copied).
#
#   cargo build --release && sh docs/sim2real-edge2d/candidates.sh WORK && sh docs/sim2real-edge2d/mended.sh WORK
set -eu
W=$(cd "$1" && pwd)
REAL=${REAL:-../shared/data/real-tactip-edge2d}
TACSIM=${TACSIM:-target/release/tacsim}
"$TACSIM" calibrate --real "$REAL" --camera-only --sensor docs/calibration-edge2d/base.toml \
    -o "$W/edge2d-alike.toml" --report "$W/edge2d-alike-calibration" -q > /dev/null
run() { # name sensor depth_range (indentation, mm; empty: the recipe's labels and [rig])
    if [ -n "$3" ]; then
        sed -e "0,/^name = .*/s//name = \"$1\"/" -e "s|^sensor = .*|sensor = \"$2\"|" \
            -e "s/^depth_mm = .*/depth_mm = [$3]/" -e "/^\[rig\]/d" -e "/^depth_offset_mm/d" \
            scenarios/datasets/edge-2d.toml > "$W/$1.toml"
    else
        sed -e "0,/^name = .*/s//name = \"$1\"/" -e "s|^sensor = .*|sensor = \"$2\"|" \
            scenarios/datasets/edge-2d.toml > "$W/$1.toml"
    fi
    if [ -d "$W/r26-mended/real-posenet" ] && [ ! -d "$W/$1-mended" ]; then
        mkdir -p "$W/$1-mended" && cp -r "$W/r26-mended/real-posenet" "$W/$1-mended/"
    fi
    "$TACSIM" sim2real --real "$REAL" --recipe "$W/$1.toml" --out "$W/$1-mended" -q | grep -E "^\| pose_" | sed "s/^/$1 /"
}
run r26 "$W/r26.toml" "0.63, 2.03"
run r20 "$W/r20.toml" "0.63, 2.03"
run r40 "$W/edge2d-alike.toml" "0.8, 2.4"
run recipe-alike "$W/edge2d-alike.toml" ""
