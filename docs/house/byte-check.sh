#!/bin/sh
# Byte check for refactors (issue 33): two `tacsim` binaries (before and after a change) make
# the same outputs: `generate quick`, every closed-loop scenario of scenarios/explore/ (`run
# --json`), a pose network and an unshear model trained one short epoch on that dataset, and
# `eval` of both. Compared byte for byte after dropping what is not reproducible by design:
# wall-clock fields (`wall_s`, `steps_per_s`), the output directory's own path, logs, and
# burn's optimizer record (checkpoint/optimizer.bpk, the resume state, whose header order
# varies from run to run even with one binary). Prints the files that differ; exits non-zero
# when any does. About 2 minutes on 2 cores.
#
#   sh docs/house/byte-check.sh BEFORE_BINARY AFTER_BINARY WORK
set -eu
[ $# -eq 3 ] || { sed -n '2,11p' "$0"; exit 2; }
make() {
    bin=$1; out=$2
    rm -rf "$out"; mkdir -p "$out"
    "$bin" generate quick --out "$out/quick" -q > "$out/generate.log"
    "$bin" run scenarios/explore/*.toml --out "$out/explore" --json > "$out/explore.json" || true
    "$bin" train posenet --data "$out/quick" --out "$out/posenet" --size 64 --epochs 1 -q > "$out/posenet.log" 2>&1
    "$bin" train unshear --data "$out/quick" --out "$out/unshear" --size 64 --epochs 1 --max-batches 2 -q \
        > "$out/unshear.log" 2>&1
    "$bin" eval --data "$out/quick" --out "$out/eval" "$out/unshear" "$out/posenet" > "$out/eval.log" 2>&1
    find "$out" -name '*.json' -o -name '*.md' | while read -r f; do
        sed -i -e "s|$out|OUT|g" -e '/"wall_s"/d' -e '/"steps_per_s"/d' "$f"
    done
}
W=$3
make "$1" "$W/before"
make "$2" "$W/after"
cd "$W"
status=0
for f in $(cd before && find . -type f ! -name '*.log' ! -name optimizer.bpk | sort); do
    cmp -s "before/$f" "after/$f" || { echo "differs: $f"; status=1; }
done
echo "$(cd before && find . -type f ! -name '*.log' ! -name optimizer.bpk | wc -l) files compared"
exit $status
