# End-to-end: the run digest covers every output file a user gets (#25).
# 1. For a run of each engine (and the model's tile, pattern and text
#    outputs), every file in the run directory other than the run's own
#    bookkeeping (summary.json, metrics.jsonl, start.ini, .lock) is listed in
#    summary.json "outputs" with its own "digest", or is a report (kind json
#    or html, which hold measured seconds, and config, which holds the run
#    directory) marked "digest_excluded". A new
#    output written without gs_run_output, or a kind left out of the digest,
#    fails here.
# 2. The issue's case: garbage written into /field/provenance of a field
#    checkpoint taken in the last iteration changed copied.ply on resume
#    while the digest stayed the same. Now a resumed run whose copied.ply
#    differs from the uninterrupted one must have another digest.
if [[ -z ${GS_ROOT:-} ]]; then GS_ROOT=$(cd "$(dirname "$0")/../.." && pwd); fi
source "$GS_ROOT/tests/e2e/lib.bash"
work=$(mktemp -d); trap 'rm -rf "$work"' EXIT; cd "$work"
PY=/usr/bin/python3

# covered DIR WHAT: the completeness check of a finished run directory.
covered() {
  local dir=$1 what=$2 msg
  if msg=$("$PY" - "$dir" <<'EOF'
import json, os, sys
d = sys.argv[1]
s = json.load(open(os.path.join(d, "summary.json")))
outs = {o["path"]: o for o in s["outputs"]}
book = {"summary.json", "metrics.jsonl", "start.ini", ".lock"}
problems = []
for root, _, files in os.walk(d):
    for f in files:
        rel = os.path.relpath(os.path.join(root, f), d)
        if rel in book:
            continue
        o = outs.get(rel)
        if o is None:
            problems.append(rel + ": not in summary.json outputs (so not in the digest)")
        elif "digest" not in o:
            if o["kind"] not in ("json", "html", "config") or "digest_excluded" not in o:
                problems.append(rel + ": left out of the digest (kind %s)" % o["kind"])
        elif len(o["digest"]) != 16:
            problems.append(rel + ": digest %r" % o["digest"])
n = sum(1 for o in outs.values() if "digest" in o)
if problems:
    print("; ".join(problems)); sys.exit(1)
print("%d output files, each with its own digest; %d reports excluded" % (n, len(outs) - n))
EOF
  ); then ok "$what: $msg"; else bad "$what: $msg"; fi
}

runs=(
  "field configs/field/quick.ini -"
  "points configs/points/quick.ini -"
  "micro configs/micro/quick.ini -"
  "micro configs/micro/gallery.ini micro.explore.count=2"
  "model configs/model/demo.ini model.txt=true"
  "model configs/model/wfc-knots.ini model.schedule_log=true"
  "model configs/model/wfc-overlap-simpleknot.ini -"
)
for r in "${runs[@]}"; do
  read -r eng cfg sets <<<"$r"
  name=$(basename "$cfg" .ini)
  need_config "digest $eng/$name" "$GS_ROOT/$cfg" || continue
  extra=()
  [[ $sets == - ]] || extra=(--set "$sets")
  run_gs 0 "$eng" -c "$GS_ROOT/$cfg" -o "run-$eng-$name" "${extra[@]}"
  if [[ $rc -ne 0 ]]; then bad "$eng/$name: exit $rc: ${err: -300}"; continue; fi
  covered "run-$eng-$name" "$eng/$name"
done

# 2. The provenance case (one rank; the checkpoint is taken at 90% of the
# blocks, in the last iteration, where the provenance is recorded; a stop in
# the advance that finishes the synthesis would not stop).
cfg=$GS_ROOT/configs/field/quick.ini
run_gs 0 field -c "$cfg" -o whole
d0=$(digest_of whole)
blocks=$("$PY" -c 'import json,sys
for l in open(sys.argv[1]):
    j = json.loads(l)
    if j["phase"] == "synthesis": print(j["blocks"])' whole/metrics.jsonl)
GS_STOP_AFTER_UNITS=$((blocks * 9 / 10)) run_gs 0 field -c "$cfg" -o stopped
[[ $rc -eq 9 ]] && ok "field stopped at block $((blocks * 9 / 10)) of $blocks (exit 9)" || bad "field stop: exit $rc, expected 9"
cp -r stopped garbage
"$PY" - garbage/checkpoint.h5 <<'EOF' || bad "no provenance to damage in the checkpoint"
import sys, h5py, numpy as np
with h5py.File(sys.argv[1], "r+") as f:
    d = f["/field/provenance"]
    a = d[...]
    m = a >= 0
    assert m.any(), "no provenance recorded in this checkpoint"
    a[m] = np.random.default_rng(1).integers(0, a.max() + 1, size=int(m.sum()))
    d[...] = a
EOF
run_gs 0 resume stopped
d1=$(digest_of stopped)
[[ $rc -eq 0 && $d1 == "$d0" ]] && ok "the untouched checkpoint resumes to the uninterrupted digest $d0" \
  || bad "untouched resume: exit $rc, digest $d1, expected $d0"
run_gs 0 resume garbage
d2=$(digest_of garbage 2>/dev/null)
if [[ $rc -ne 0 ]]; then
  ok "the damaged provenance is refused on resume (exit $rc)"
elif cmp -s whole/copied.ply garbage/copied.ply; then
  bad "garbage in /field/provenance left copied.ply unchanged: the check proves nothing"
else
  ok "garbage in /field/provenance changed copied.ply"
  [[ $d2 != "$d0" ]] && ok "and the digest with it ($d0 -> $d2)" \
    || bad "copied.ply changed but the digest stayed $d0"
fi
exit $e2e_failed
