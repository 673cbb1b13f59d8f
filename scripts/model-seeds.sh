#!/bin/bash
# Runs model configs over seeds 1..N through the CLI and prints one JSON
# line per config: seeds clean (0 violations, 0 rule violations and every
# cell in at least one accepted region, i.e. no region failed for good),
# failed regions summed (tries that kept the old content; the cells are
# then covered by overlapping regions or not), synthesis seconds and the
# busiest rank's synthesis CPU seconds mean/max (CPU time moves less with
# the other jobs' load than wall time), and the load average at the end.
# Issue 4 target (a): every config clean in N of N seeds.
#
# Usage: [N=20] [NP=1] [GS_BIN=bin/geosynth] scripts/model-seeds.sh CONFIG.ini ...   (repository root)
# Tile pictures are skipped (model.tile_image = false), meshes too.
set -u
N=${N:-20}
NP=${NP:-1}
GS_BIN=${GS_BIN:-bin/geosynth}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
for cfg in "$@"; do
    for s in $(seq 1 "$N"); do
        if ! mpirun -np "$NP" "$GS_BIN" model -c "$cfg" --set run.seed="$s" \
            --set model.tile_image=false --set model.mesh=none --set model.vox=false \
            -o "$tmp/r$s" >"$tmp/log$s" 2>&1; then
            echo "{\"config\": \"$cfg\", \"seed\": $s, \"failed_run\": true}" >"$tmp/r$s.fail"
        fi
    done
    /usr/bin/python3 - "$cfg" "$N" "$NP" "$tmp" <<'EOF'
import json, os, statistics, sys
cfg, n, np_, tmp = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
clean, failed, viol, runs_failed, secs, cpu, mincov, bad = 0, 0, 0, 0, [], [], None, []
for s in range(1, n + 1):
    p = os.path.join(tmp, "r%d" % s, "summary.json")
    if os.path.exists(os.path.join(tmp, "r%d.fail" % s)) or not os.path.exists(p):
        runs_failed += 1
        bad.append(s)
        continue
    m = json.load(open(p))["metrics"]
    v = m["violations"] + m.get("rule_violations", 0)
    failed += m["failed_regions"]
    viol += v
    secs.append(m["synthesis_seconds"])
    cpu.append(m["synthesis_cpu_seconds_max_rank"])
    mincov = m["min_coverage"] if mincov is None else min(mincov, m["min_coverage"])
    ok = v == 0 and m["min_coverage"] >= 1
    clean += ok
    if not ok:
        bad.append(s)
print(json.dumps({"config": cfg, "np": np_, "seeds": n, "clean_seeds": clean,
                  "unclean_seeds": bad, "runs_failed": runs_failed, "violations": viol,
                  "failed_regions": failed, "min_coverage": mincov,
                  "synthesis_seconds_mean": round(statistics.mean(secs), 4) if secs else None,
                  "synthesis_seconds_max": round(max(secs), 4) if secs else None,
                  "synthesis_cpu_seconds_mean": round(statistics.mean(cpu), 4) if cpu else None,
                  "synthesis_cpu_seconds_max": round(max(cpu), 4) if cpu else None,
                  "load_1min_end": float(open("/proc/loadavg").read().split()[0])}), flush=True)
EOF
    rm -rf "$tmp"/r* "$tmp"/log*
done
