#!/bin/bash
# Runs each WFC tile-set config (configs/model/wfc-*.ini, not the overlapping
# ones) over seeds 1..N (default 20) at np 1 without the tile picture and
# prints per tile set: seeds with 0 violations and every cell covered by an
# accepted region, synthesis seconds (mean, max), failed regions (total).
# Usage: scripts/bench-wfc.sh [N] [names...]   (from the repository root)
set -u
N=${1:-20}; shift || true
names=${*:-knots rooms circuit summer castle floorplan circles}
tmp=$(mktemp -d)
for t in $names; do
    ok=0; sum=0; max=0; failed=0
    for s in $(seq 1 "$N"); do
        bin/geosynth model -c configs/model/wfc-$t.ini --set run.seed=$s \
            --set model.tile_image=false -o "$tmp/r" >"$tmp/log" 2>&1 || { echo "$t seed $s: exit $?"; continue; }
        m="$tmp/r/summary.json"
        v=$(grep -o '"violations": *[0-9]*' "$m" | head -1 | grep -o '[0-9]*$')
        cov=$(grep -o '"min_coverage": *[0-9]*' "$m" | head -1 | grep -o '[0-9]*$')
        f=$(grep -o '"failed_regions": *[0-9]*' "$m" | head -1 | grep -o '[0-9]*$')
        sec=$(grep -o '"synthesis_seconds": *[0-9.e+-]*' "$m" | head -1 | grep -o '[0-9.e+-]*$')
        [ "$v" = 0 ] && [ "${cov:-0}" -ge 1 ] && ok=$((ok + 1))
        failed=$((failed + f))
        sum=$(awk -v a="$sum" -v b="$sec" 'BEGIN{print a+b}')
        max=$(awk -v a="$max" -v b="$sec" 'BEGIN{print (b>a)?b:a}')
    done
    printf '%-10s ok %d/%d  synthesis mean %.3f s max %.3f s  failed regions %d\n' "$t" "$ok" "$N" \
        "$(awk -v a="$sum" -v n="$N" 'BEGIN{print a/n}')" "$max" "$failed"
done
rm -rf "$tmp"
