#!/bin/sh
# Two levers on where the edge taps' pins spread from (issue 30, docs/guide/sim2real.md):
# the edge sensor scaled up 1.5 times, and a skin patch that grows with the press
# (`pins.patch_growth_per_mm`, an option only in a binary built with
# docs/sim2real-edge2d/spread.patch applied: PATCHED=path/to/that/tacsim). Each candidate is
# screened on 1,500 taps by edge_profile.py (where the pins spread from, by lateral and depth
# band); with --sim2real each also runs `tacsim sim2real` (5,000 taps, about 12 minutes) and
# lateral_bias.py on its predictions. The skin-on-gel row needs no patch.
#
#   cargo build --release && sh docs/sim2real-edge2d/spread.sh target/spread [--sim2real]
set -eu
W=$1
S2R=${2:-}
REAL=${REAL:-../shared/data/real-tactip-edge2d}
TACSIM=${TACSIM:-target/release/tacsim}
PATCHED=${PATCHED:-}
PRESET=$(pwd)/sim/presets/tactip-331-edge2d.toml
RECIPE=scenarios/datasets/edge-2d.toml
mkdir -p "$W"
W=$(cd "$W" && pwd)

# The preset with every length (mm) times $1.
scaled() {
    python3 - "$1" "$PRESET" <<'PY'
import re, sys
s, text = float(sys.argv[1]), open(sys.argv[2]).read()
for key in ["outer_radius_mm", "skin_thickness_mm", "length_mm", "tip_radius_mm", "patch_radius_mm", "distance_mm"]:
    text = re.sub(rf"^{key} = (\S+)", lambda m: f"{key} = {float(m.group(1)) * s!r}", text, flags=re.M)
print(text, end="")
PY
}

# name | binary | sensor file | sed expressions on the recipe (;-separated)
scaled 1.5 > "$W/x1.5.toml"
sed 's/^model = .*/model = "skin-on-gel"/; s/^gel_youngs_modulus_mpa = .*/gel_youngs_modulus_mpa = 0.02/' "$PRESET" > "$W/skin-on-gel-0.02.toml"
CANDIDATES="
preset|$TACSIM|$PRESET|
skin-on-gel-0.02|$TACSIM|$W/skin-on-gel-0.02.toml|
x1.5-rig|$TACSIM|$W/x1.5.toml|s/^x_mm = .*/x_mm = [-7.0, 7.0]/;s/^depth_offset_mm = .*/depth_offset_mm = -1.97/
x1.5-gain|$TACSIM|$W/x1.5.toml|s/^x_mm = .*/x_mm = [-7.0, 7.0]/;s/^depth_mm = .*/depth_mm = [0.525, 3.525]/;/^\\[rig\\]/d;/^depth_offset_mm/d
"
if [ -n "$PATCHED" ]; then
    for g in 3.0 4.5; do
        sed "s/^patch_radius_mm = .*/patch_radius_mm = 0.0\npatch_growth_per_mm = $g/" "$PRESET" > "$W/growth-$g.toml"
        CANDIDATES="$CANDIDATES
growth-$g|$PATCHED|$W/growth-$g.toml|"
    done
fi

PROFILES=""
for line in $(printf "%s\n" "$CANDIDATES" | sed 's/ /@/g'); do
    name=$(echo "$line" | cut -d'|' -f1)
    binary=$(echo "$line" | cut -d'|' -f2)
    sensor=$(echo "$line" | cut -d'|' -f3)
    expr=$(printf "%s" "$line" | cut -d'|' -f4 | sed 's/@/ /g')
    sed -e "s|^sensor = .*|sensor = \"$sensor\"|" -e "$expr" "$RECIPE" > "$W/$name-recipe.toml"
    sed "s/^per_shape = .*/per_shape = 1500/" "$W/$name-recipe.toml" > "$W/$name-screen.toml"
    rm -rf "$W/$name-screen"
    "$binary" generate "$W/$name-screen.toml" --out "$W/$name-screen" -q > /dev/null
    # Labels that are the indentation (no [rig]) back into the lab's pose_3 for the table.
    if [ "$name" = x1.5-gain ]; then
        python3 - "$W/$name-screen/targets.csv" <<'PY'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
for r in rows:
    r["pose_z"] = repr(2.65 + float(r["pose_z"]) / 1.5)
out = csv.DictWriter(open(sys.argv[1], "w"), fieldnames=list(rows[0]))
out.writeheader()
out.writerows(rows)
PY
    fi
    PROFILES="$PROFILES $W/$name-screen 0 0"
done
python3 docs/sim2real-edge2d/edge_profile.py "$REAL" $PROFILES

if [ "$S2R" = "--sim2real" ]; then
    for line in $(printf "%s\n" "$CANDIDATES" | sed 's/ /@/g'); do
        name=$(echo "$line" | cut -d'|' -f1)
        binary=$(echo "$line" | cut -d'|' -f2)
        [ "$name" = preset ] && continue
        "$binary" sim2real --real "$REAL" --recipe "$W/$name-recipe.toml" --out "$W/$name" -q | grep -E "^\| pose_" | sed "s/^/$name /"
        python3 docs/sim2real-edge2d/lateral_bias.py "$W/$name/predictions.csv"
    done
fi
