#!/usr/bin/env bash
# Benchmark: micro gallery throughput (candidates per minute) with 1 and 2
# ranks side by side, on configs/micro/gallery.ini (GS_BENCH_GALLERY_COUNT
# candidates, default 24). The two rank counts alternate GS_BENCH_REPEAT
# times (default 3) so load from other users of a shared machine hits both
# alike; per rank count the JSON gives every repeat, the best and the median.
# "gallery_seconds" is the gallery phase on rank 0's clock (what summary.json
# reports as candidates_per_minute), "process_seconds" the whole mpirun with
# start-up. Every run's digest must be the same. JSON on stdout
# (tests/bench/run.sh puts it into bench-results/bench_gallery.json).
set -u
: "${GS_BIN:?}" "${GS_ROOT:?}"
count=${GS_BENCH_GALLERY_COUNT:-24}
repeat=${GS_BENCH_REPEAT:-3}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
for r in $(seq 1 "$repeat"); do
  for np in 1 2; do
    dir=$work/np$np-$r
    t0=$(date +%s.%N)
    if ! mpirun -np $np "$GS_BIN" micro -c "$GS_ROOT/configs/micro/gallery.ini" -o "$dir" \
         --set micro.explore.count="$count" >"$dir.log" 2>&1; then
      echo "gallery at np=$np failed:" >&2; tail -20 "$dir.log" >&2; exit 1
    fi
    t1=$(date +%s.%N)
    echo "$np $dir $t0 $t1" >>"$work/runs.txt"
  done
done
/usr/bin/python3 - "$work/runs.txt" "$count" <<'EOF'
import json, statistics, sys
runs = {1: [], 2: []}
digests = set()
for line in open(sys.argv[1]):
    np_, d, t0, t1 = line.split()
    s = json.load(open(d + "/summary.json"))
    m = s["metrics"]
    digests.add(s["digest"])
    runs[int(np_)].append({"gallery_seconds": round(m["gallery_seconds"], 3),
                           "candidates_per_minute": round(m["candidates_per_minute"], 1),
                           "process_seconds": round(float(t1) - float(t0), 3),
                           "candidate_cpu_seconds": round(m["candidate_cpu_seconds"], 3),
                           "triangles": m["triangles"], "digest": s["digest"]})
out = {"benchmark": "micro_gallery", "config": "configs/micro/gallery.ini",
       "candidates": int(sys.argv[2]), "ranks": {}}
for np_, rs in runs.items():
    cpm = [r["candidates_per_minute"] for r in rs]
    out["ranks"][str(np_)] = {"candidates_per_minute_best": max(cpm),
                              "candidates_per_minute_median": statistics.median(cpm),
                              "runs": rs}
b1, b2 = (out["ranks"][k]["candidates_per_minute_best"] for k in ("1", "2"))
out["speedup_2_over_1_best"] = round(b2 / b1, 2)
out["digests_agree"] = len(digests) == 1
print(json.dumps(out, indent=1))
sys.exit(0 if len(digests) == 1 else 1)
EOF
