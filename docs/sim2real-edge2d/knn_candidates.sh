#!/bin/sh
# Body candidates for the whole-turn edge taps, screened by their pin motion alone (issue 85):
# each is the edge dome preset (tactip-331-edge2d-dome) with one change, 1,500 taps of the
# fitted dome's recipe (docs/sim2real-edge2d/edge-2d-dome-fit.toml, 20-35 s each on 2 cores
# with the dome's response built), read by field_knn.py (nearest pin-motion fields in the
# edge's frame) and by edge_profile.py (where the pins spread from, shallow against deep).
# Needs python3 with numpy, scipy and pillow, and a release build (`cargo build --release`).
#
#   sh docs/sim2real-edge2d/knn_candidates.sh WORK [NAME...]
#
# Names: base (the preset), lever1 / lever03 (pins 1.0 / 0.3 mm long, the skin thickened so
# the tips stay), skinthin (skin 0.5 mm), gelnu45 (gel Poisson 0.45), gelsoft / gelstiff (gel
# 0.05 / 5 MPa), gel5l1 (gel 5 MPa and pins 1.0 mm), base45 (the base 45 mm below the apex).
set -e
WORK=${1:?usage: knn_candidates.sh WORK [NAME...]}
shift
NAMES=${*:-base lever1 lever03 skinthin gelnu45 gelsoft gelstiff gel5l1 base45}
REAL=${REAL:-../shared/data/real-tactip-edge2d-full}
PRESET=sim/presets/tactip-331-edge2d-dome.toml
RECIPE=docs/sim2real-edge2d/edge-2d-dome-fit.toml
PY=${PYTHON:-python3}
mkdir -p "$WORK"
case $WORK in /*) ABS=$WORK ;; *) ABS=$PWD/$WORK ;; esac
change() {
    case $1 in
        base) echo "" ;;
        lever1) echo "s/^length_mm = .*/length_mm = 1.0/;s/^skin_thickness_mm = .*/skin_thickness_mm = 2.5/" ;;
        lever03) echo "s/^length_mm = .*/length_mm = 0.3/;s/^skin_thickness_mm = .*/skin_thickness_mm = 3.2/" ;;
        skinthin) echo "s/^skin_thickness_mm = .*/skin_thickness_mm = 0.5/" ;;
        gelnu45) echo "s/^gel_poisson = .*/gel_poisson = 0.45/" ;;
        gelsoft) echo "s/^gel_youngs_modulus_mpa = .*/gel_youngs_modulus_mpa = 0.05/" ;;
        gelstiff) echo "s/^gel_youngs_modulus_mpa = .*/gel_youngs_modulus_mpa = 5.0/" ;;
        gel5l1) echo "s/^gel_youngs_modulus_mpa = .*/gel_youngs_modulus_mpa = 5.0/;s/^length_mm = .*/length_mm = 1.0/;s/^skin_thickness_mm = .*/skin_thickness_mm = 2.5/" ;;
        base45) echo "s/^base_depth_mm = .*/base_depth_mm = 45.0/" ;;
        *) echo "unknown candidate $1" >&2; exit 2 ;;
    esac
}
ARGS=""
for name in $NAMES; do
    sed -e "s/^name = .*/name = \"$name\"/" -e "$(change "$name")" "$PRESET" > "$WORK/$name.sensor.toml"
    sed -e 's/^per_shape = 5000/per_shape = 1500/' -e "s|^sensor = .*|sensor = \"$ABS/$name.sensor.toml\"|" \
        "$RECIPE" > "$WORK/$name.toml"
    [ -f "$WORK/$name/meta.json" ] || target/release/tacsim generate "$WORK/$name.toml" --out "$WORK/$name" -q
    # The fitted dome's sim2real map (lab lateral = 3.53 - x, lab depth = depth - 0.05 mm).
    ARGS="$ARGS $WORK/$name 3.53 -0.05"
done
$PY docs/sim2real-edge2d/field_knn.py "$REAL" real $ARGS
$PY docs/sim2real-edge2d/edge_profile.py "$REAL" $ARGS
