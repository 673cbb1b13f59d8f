#!/usr/bin/env bash
# Benchmark: micro gallery throughput (candidates per minute) with 1 and 2
# ranks side by side, on configs/micro/gallery.ini (GS_BENCH_GALLERY_COUNT
# candidates, default 24). Prints JSON on stdout (tests/bench/run.sh puts it
# into bench-results/bench_gallery.json). "gallery_seconds" is the gallery
# phase on rank 0's clock (what summary.json reports), "process_seconds" the
# whole mpirun including start-up. Both ranks' digests must agree.
set -u
: "${GS_BIN:?}" "${GS_ROOT:?}"
count=${GS_BENCH_GALLERY_COUNT:-24}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
printf '{"benchmark": "micro_gallery", "config": "configs/micro/gallery.ini", "candidates": %d,\n  "runs": [\n' "$count"
first=1
declare -A dg cpm
for np in 1 2; do
  t0=$(date +%s.%N)
  if ! mpirun -np $np "$GS_BIN" micro -c "$GS_ROOT/configs/micro/gallery.ini" -o "$work/np$np" \
       --set micro.explore.count=$count >"$work/np$np.log" 2>&1; then
    echo "gallery at np=$np failed:" >&2; tail -20 "$work/np$np.log" >&2; exit 1
  fi
  t1=$(date +%s.%N)
  line=$(/usr/bin/python3 - "$work/np$np/summary.json" "$np" "$t0" "$t1" <<'EOF'
import json, sys
s = json.load(open(sys.argv[1]))
m = s["metrics"]
np_, t0, t1 = int(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4])
print(json.dumps({"np": np_, "gallery_seconds": round(m["gallery_seconds"], 3),
                  "candidates_per_minute": round(m["candidates_per_minute"], 1),
                  "process_seconds": round(t1 - t0, 3),
                  "candidates_per_minute_process": round(60 * m["candidates"] / (t1 - t0), 1),
                  "candidate_cpu_seconds": round(m["candidate_cpu_seconds"], 3),
                  "triangles": m["triangles"], "digest": s["digest"]}))
EOF
)
  dg[$np]=$(/usr/bin/python3 -c 'import json,sys;print(json.loads(sys.argv[1])["digest"])' "$line")
  cpm[$np]=$(/usr/bin/python3 -c 'import json,sys;print(json.loads(sys.argv[1])["candidates_per_minute"])' "$line")
  [[ $first == 1 ]] || printf ',\n'
  printf '    %s' "$line"
  first=0
done
speedup=$(/usr/bin/python3 -c 'import sys;print(round(float(sys.argv[2]) / float(sys.argv[1]), 2))' "${cpm[1]}" "${cpm[2]}")
printf '\n  ],\n  "speedup_2_over_1": %s,\n  "digests_agree": %s\n}\n' "$speedup" \
  "$([[ ${dg[1]} == "${dg[2]}" ]] && echo true || echo false)"
[[ ${dg[1]} == "${dg[2]}" ]]
