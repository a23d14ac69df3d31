#!/bin/sh
# How far an edge contact reaches the pins, screened in seconds per candidate (issue 30): each
# candidate is the edge preset (its camera and pressed layout kept) with one change, 1,500 taps
# of the edge-2d recipe, compared with the real taps by ring_response.py at the sim2real map's
# lateral offset (2.74 mm). With GEL=1 the candidates include a load-proportional dilation of
# the pin field (`pins.gel_dilation_per_n`), which needs a binary built with
# docs/sim2real-edge2d/spread.patch applied (`git apply`); the option is not in tacsim.
#
# The dome candidates (`skin.model = "dome"`, the base at the equator of the preset's 40 mm
# dome) build their dome into the cache folder on first use. NAMES="preset dome" runs only the
# candidates named; REAL=../shared/data/real-tactip-edge2d-full compares with the lab's whole
# turn. PRESET=FILE starts every candidate from another sensor file, DOME_BASE_MM=D puts the
# dome candidates' base D mm below the apex (default 40, the 40 mm dome's equator).
# RECIPE=FILE generates from another recipe than the built-in edge-2d (its sensor replaced by
# the candidate's, its depth map kept), OFFSET=MM compares at another lateral offset than 2.74
# mm (the label map of that recipe's sim2real run).
#
#   cargo build --release && sh docs/sim2real-edge2d/reach.sh target/reach
set -eu
W=$1
REAL=${REAL:-../shared/data/real-tactip-edge2d}
TACSIM=${TACSIM:-target/release/tacsim}
PRESET=${PRESET:-sim/presets/tactip-331-edge2d.toml}
BASE=${DOME_BASE_MM:-40.0}
RECIPE=${RECIPE:-scenarios/datasets/edge-2d.toml}
OFFSET=${OFFSET:-2.74}
mkdir -p "$W"
W=$(cd "$W" && pwd)

# name | sed expressions (;-separated) on the preset
CANDIDATES="
preset|
skin-on-gel|s/^model = .*/model = \"skin-on-gel\"/
skin-on-gel-0.02|s/^model = .*/model = \"skin-on-gel\"/;s/^gel_youngs_modulus_mpa = .*/gel_youngs_modulus_mpa = 0.02/
skin-on-gel-0.002|s/^model = .*/model = \"skin-on-gel\"/;s/^gel_youngs_modulus_mpa = .*/gel_youngs_modulus_mpa = 0.002/
layer|s/^model = .*/model = \"layer\"/
patch-3|s/^patch_radius_mm = .*/patch_radius_mm = 3.0/
patch-5|s/^patch_radius_mm = .*/patch_radius_mm = 5.0/
lever-1.4|s/^length_mm = .*/length_mm = 1.4/
poisson-0.30|s/^poisson = .*/poisson = 0.3/
poisson-0.49|s/^poisson = .*/poisson = 0.49/
dome|s/^model = .*/model = \"dome\"/;s/^base_depth_mm = .*/base_depth_mm = $BASE/
dome-gel-0.02|s/^model = .*/model = \"dome\"/;s/^base_depth_mm = .*/base_depth_mm = $BASE/;s/^gel_youngs_modulus_mpa = .*/gel_youngs_modulus_mpa = 0.02/
dome-gel-0.005|s/^model = .*/model = \"dome\"/;s/^base_depth_mm = .*/base_depth_mm = $BASE/;s/^gel_youngs_modulus_mpa = .*/gel_youngs_modulus_mpa = 0.005/
dome-gel-0.002|s/^model = .*/model = \"dome\"/;s/^base_depth_mm = .*/base_depth_mm = $BASE/;s/^gel_youngs_modulus_mpa = .*/gel_youngs_modulus_mpa = 0.002/
dome-gel-0.001|s/^model = .*/model = \"dome\"/;s/^base_depth_mm = .*/base_depth_mm = $BASE/;s/^gel_youngs_modulus_mpa = .*/gel_youngs_modulus_mpa = 0.001/
dome-gel-0.3|s/^model = .*/model = \"dome\"/;s/^base_depth_mm = .*/base_depth_mm = $BASE/;s/^gel_youngs_modulus_mpa = .*/gel_youngs_modulus_mpa = 0.3/
dome-gel-1.0|s/^model = .*/model = \"dome\"/;s/^base_depth_mm = .*/base_depth_mm = $BASE/;s/^gel_youngs_modulus_mpa = .*/gel_youngs_modulus_mpa = 1.0/
skin-on-gel-0.005|s/^model = .*/model = \"skin-on-gel\"/;s/^gel_youngs_modulus_mpa = .*/gel_youngs_modulus_mpa = 0.005/
"
if [ "${GEL:-0}" = 1 ]; then
    for k in 0.00002 0.0001 0.0002 0.001; do
        CANDIDATES="$CANDIDATES
gel-$k|s/^patch_radius_mm = 1.5/patch_radius_mm = 1.5\ngel_dilation_per_n = $k/"
    done
fi

SETS=""
for line in $(printf "%s\n" "$CANDIDATES" | sed 's/ /@/g'); do
    name=${line%%|*}
    case " ${NAMES:-$name} " in *" $name "*) ;; *) continue ;; esac
    expr=$(printf "%s" "${line#*|}" | sed 's/@/ /g')
    sed "$expr" "$PRESET" > "$W/$name.toml"
    sed -e "s/^per_shape = .*/per_shape = 1500/" -e "s|^sensor = .*|sensor = \"$W/$name.toml\"|" \
        "$RECIPE" > "$W/$name-recipe.toml"
    rm -rf "$W/$name"
    "$TACSIM" generate "$W/$name-recipe.toml" --out "$W/$name" -q > /dev/null
    SETS="$SETS $W/$name"
done
python3 docs/sim2real-edge2d/ring_response.py "$REAL" "$OFFSET" $SETS
python3 docs/sim2real-edge2d/ring_response.py "$REAL" free "$W/preset"
