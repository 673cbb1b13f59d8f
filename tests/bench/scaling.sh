#!/usr/bin/env bash
# Whole runs through the CLI at 1 and 2 MPI ranks, side by side: for each
# config, wall seconds and per-phase times from summary.json at each rank
# count, the speedup, and whether the digests agree (they must). JSON on
# stdout (tests/bench/run.sh puts it into bench-results/scaling.json).
#
#   tests/bench/scaling.sh [CONFIG ...]       (default: the list below)
#   NP="1 2" (rank counts), SCALING_REPEAT=1 (runs per rank count; the
#   fastest counts: on a shared machine the minimum is the least noisy)
#
# Every config here is an engine's paper-scale case: the field engine's
# default 64^3 -> 128^3 three-iteration synthesis (issue target: < 30 s at
# 2 ranks; grid-sharded is the same with the tree sharded over the ranks, its
# tree_bytes_rank_max falls with the rank count), the points engine's large chain mail (2.9M points, < 30 s at 2
# ranks) and small cases, the model engine at the author's sizes and 10x (2
# ranks should give 1.8x the cells/s of one: cells_per_second_ratio_best and
# _median over the repeats; ideal_speedup, the load balance, next to it).
set -u
cd "$(dirname "$0")/../.."
GS_BIN=${GS_BIN:-$PWD/bin/geosynth}
NP=${NP:-1 2}
REPEAT=${SCALING_REPEAT:-1}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
export OMPI_MCA_pml=${OMPI_MCA_pml:-ob1} # one machine: see tests/bench/run.sh
PY=/usr/bin/python3

configs=("$@")
if [[ ${#configs[@]} -eq 0 ]]; then
  configs=(
    configs/field/grid.ini configs/field/grid-sharded.ini
    configs/points/heightfield.ini configs/points/chainmail.ini configs/points/weave.ini
    configs/points/flowers.ini configs/points/chainmail-large.ini
    configs/model/castle.ini configs/model/castle-10x.ini configs/model/city.ini
    configs/model/escheresque.ini configs/model/escheresque-10x.ini configs/model/parliament.ini
    configs/model/parliament-10x.ini
  )
fi

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
records=()
for cfg in "${configs[@]}"; do
  engine=$(basename "$(dirname "$cfg")")
  name="$engine/$(basename "$cfg" .ini)"
  for np in $NP; do
    for ((r = 1; r <= REPEAT; r++)); do
      dir="$work/$engine-$(basename "$cfg" .ini)-np$np-r$r"
      echo "scaling: $name np=$np run $r" >&2
      if mpirun -np "$np" "$GS_BIN" "$engine" -c "$cfg" -o "$dir" >"$dir.log" 2>&1; then
        records+=("$name" "$np" "$dir/summary.json")
      else
        echo "scaling: $name np=$np failed (exit $?), log:" >&2
        tail -5 "$dir.log" >&2
        records+=("$name" "$np" "FAILED")
      fi
    done
  done
done

"$PY" - "${records[@]}" <<'EOF'
import json, sys
args = sys.argv[1:]
runs = {}
for name, np, path in zip(args[0::3], args[1::3], args[2::3]):
    if path == "FAILED":
        s = None
    else:
        with open(path) as f:
            s = json.load(f)
    runs.setdefault(name, {}).setdefault(int(np), []).append(s)
out, ok = [], True
for name, by_np in runs.items():
    case = {"config": name, "ranks": {}}
    digests = set()
    for np, summaries in sorted(by_np.items()):
        good = [s for s in summaries if s]
        if not good:
            case["ranks"][str(np)] = {"failed": True}
            ok = False
            continue
        best = min(good, key=lambda s: s["wall_seconds"])
        digests.update(s["digest"] for s in good)
        m = best.get("metrics", {})
        rec = {"wall_s": round(best["wall_seconds"], 3),
               "phases": {p["name"]: round(p["max"], 3) for p in best["phases"]},
               "digest": best["digest"], "runs": len(good)}
        # model: ideal_speedup = region seconds summed over ranks / the
        # busiest rank's (load balance, robust to a shared machine's noise)
        for k in ("cells", "cells_per_second", "output_points", "failed_regions", "violations",
                  "ideal_speedup", "synthesis_cpu_seconds_max_rank", "queue_wait_seconds_max_rank",
                  "tree_bytes_rank_max"):
            if k in m:
                rec[k] = m[k]
        cps = sorted(s["metrics"]["cells_per_second"] for s in good
                     if "cells_per_second" in s.get("metrics", {}))
        if cps:  # best and median over the repeats (SCALING_REPEAT)
            rec["cells_per_second_best"] = cps[-1]
            rec["cells_per_second_median"] = cps[len(cps) // 2] if len(cps) % 2 else \
                (cps[len(cps) // 2 - 1] + cps[len(cps) // 2]) / 2
        case["ranks"][str(np)] = rec
    walls = {np: r["wall_s"] for np, r in case["ranks"].items() if "wall_s" in r}
    nps = sorted(walls, key=int)
    if len(nps) > 1:
        case["speedup"] = round(walls[nps[0]] / walls[nps[-1]], 2)
        lo, hi = case["ranks"][nps[0]], case["ranks"][nps[-1]]
        for k in ("best", "median"):  # the model target: cells/s at 2 ranks over 1 rank
            a, b = lo.get("cells_per_second_" + k), hi.get("cells_per_second_" + k)
            if a and b:
                case["cells_per_second_ratio_" + k] = round(b / a, 2)
    case["digests_agree"] = len(digests) == 1
    ok &= case["digests_agree"]
    out.append(case)
print(json.dumps({"bench": "scaling", "cases": out, "ok": ok}, indent=1))
sys.exit(0 if ok else 1)
EOF
