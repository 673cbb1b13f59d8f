#!/usr/bin/env bash
# The model engine's synthesis CPU against another build of it (a change
# that must keep every output, e.g. a faster arc consistency): each case
# runs with this tree's binary and with MODEL_BASELINE (a binary built from
# main before the change) alternately, one rank, MODEL_BASELINE_REPS times
# each (default 5), so both meet the same load. Cases: the fortress nobody
# tuned for with configs/model/fortress-yards.ini's settings (3D window
# labels: 400-500 labels) on scripts/gen-lattice.py fortress seeds
# MODEL_BASELINE_FORTRESS (default 3 4 5) and on the shipped fortress31.txt;
# castle.ini, parliament.ini, escheresque.ini, castle-10x.ini,
# escheresque-10x.ini and castle.txt at 100x100x10 in 20x20 regions (the
# issue's speed table). Extra configs as arguments replace the defaults.
# JSON on stdout, per case: synthesis CPU seconds (summary.json
# synthesis_cpu_seconds_max_rank) of every run, their median and minimum for
# each binary, cpu_ratio_new_over_old_median (median over median) and
# _pairs_median (median of each adjacent pair's ratio), cells per CPU second
# (output cells / median synthesis CPU), the digests and same_digest (1 =
# every run of both binaries wrote the same output). Without MODEL_BASELINE
# only this tree's figures.
#
#   MODEL_BASELINE=/tmp/main-before/bin/geosynth tests/bench/model_baseline.sh
#   (or: MODEL_BASELINE=... make bench T=model_baseline, JSON in bench-results/)
# A baseline binary outside a tree finds no plugins: copy bin/ and build/plugins
# together (the runs write no meshes or previews, so none are loaded).
set -u
cd "$(dirname "$0")/../.."
GS_BIN=${GS_BIN:-$PWD/bin/geosynth}
BASELINE=${MODEL_BASELINE:-}
REPS=${MODEL_BASELINE_REPS:-5}
FSEEDS=${MODEL_BASELINE_FORTRESS:-3 4 5}
PY=/usr/bin/python3
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
S=${GS_DATA:-$PWD/data}/model-synthesis/merrell42-model-synthesis/samples
[[ $S == /* ]] || S=$PWD/$S
cases=("$@")
if [[ ${#cases[@]} -eq 0 ]]; then
  for s in $FSEEDS; do
    "$PY" scripts/gen-lattice.py fortress "$s" "$work/fortress$s.txt" || exit 1
    sed -e "s|^example = .*|example = $work/fortress$s.txt|" configs/model/fortress-yards.ini \
      >"$work/fortress$s-yards.ini"
    cases+=("$work/fortress$s-yards.ini")
  done
  sed -e "s|^example = .*|example = $PWD/configs/model/fortress31.txt|" configs/model/fortress-yards.ini \
    >"$work/fortress31-yards.ini"
  sed -e "s|^example = .*|example = $S/castle.txt|" -e 's/^size = .*/size = 100x100x10/' \
    -e 's/^region = .*/region = 20x20x0/' configs/model/castle.ini >"$work/castle-100x100-r20.ini"
  cases+=("$work/fortress31-yards.ini" configs/model/castle.ini configs/model/parliament.ini
    configs/model/escheresque.ini configs/model/castle-10x.ini configs/model/escheresque-10x.ini
    "$work/castle-100x100-r20.ini")
fi
records=$work/records.txt
: >"$records"
kinds="new"
[[ -n $BASELINE ]] && kinds="new old"
for cfg in "${cases[@]}"; do
  name=$(basename "$cfg" .ini)
  for ((r = 1; r <= REPS; r++)); do
    for k in $kinds; do
      bin=$GS_BIN
      [[ $k == old ]] && bin=$BASELINE
      dir=$work/$name-$k-$r
      if "$bin" model -c "$cfg" -o "$dir" --set model.mesh=none --set model.preview=false \
        --set model.vox=false >"$dir.log" 2>&1; then
        echo "$name $k $r $dir/summary.json" >>"$records"
      else
        echo "model_baseline: $name ($k) failed, log:" >&2
        tail -5 "$dir.log" >&2
        exit 1
      fi
    done
  done
done
"$PY" - "$records" "$REPS" "${BASELINE:-}" <<'EOF'
import json, statistics, sys
path, reps, baseline = sys.argv[1], int(sys.argv[2]), sys.argv[3]
runs = {}
order = []
for line in open(path):
    name, kind, rep, summ = line.split()
    d = json.load(open(summ))
    m = d["metrics"]
    if name not in runs:
        runs[name] = {}
        order.append(name)
    # output cells: the synthesis phase's cells/s times its seconds
    cells = round(m["cells_per_second"] * m["synthesis_seconds"])
    runs[name].setdefault(kind, []).append((int(rep), m["synthesis_cpu_seconds_max_rank"],
                                            d["digest"], cells))
out = {"benchmark": "model_baseline", "baseline": baseline or None, "reps": reps, "cases": []}
for name in order:
    case = {"case": name}
    for kind, rows in sorted(runs[name].items()):
        cpu = [c for _, c, _, _ in rows]
        cells = rows[0][3]
        case["cells"] = cells
        case[kind] = {"synthesis_cpu_seconds": [round(c, 4) for c in cpu],
                      "median": round(statistics.median(cpu), 4), "min": round(min(cpu), 4),
                      "cells_per_cpu_second_median": round(cells / statistics.median(cpu)),
                      "digests": sorted({d for _, _, d, _ in rows})}
    if "old" in case:
        new = {r: c for r, c, _, _ in runs[name]["new"]}
        old = {r: c for r, c, _, _ in runs[name]["old"]}
        case["cpu_ratio_new_over_old_median"] = round(case["new"]["median"] / case["old"]["median"], 3)
        case["cpu_ratio_new_over_old_pairs_median"] = round(
            statistics.median(new[r] / old[r] for r in new if r in old), 3)
        case["same_digest"] = int(case["new"]["digests"] == case["old"]["digests"]
                                  and len(case["new"]["digests"]) == 1)
    out["cases"].append(case)
json.dump(out, sys.stdout, indent=1)
print()
EOF
