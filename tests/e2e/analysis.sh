# End-to-end: analysis/campaign_table.py over real run directories: it must
# tabulate every run, agree that runs differing only in rank count share a
# digest, and fail loudly when a digest differs.
source "$GS_ROOT/tests/e2e/lib.bash"
PY=/usr/bin/python3
config=$GS_ROOT/configs/model/demo.ini
for np in 1 2; do
  run_gs "$np" model -c "$config" -o "campaign/model-demo-np$np"
  expect_rc 0 "model demo at np=$np"
done
table=$($PY "$GS_ROOT/analysis/campaign_table.py" campaign --json table.json 2>&1)
rc=$?
[[ $rc -eq 0 ]] && ok "campaign table: digests agree across rank counts" || bad "campaign table failed (rc=$rc): $table"
grep -q "model-demo-np1" <<<"$table" && grep -q "model-demo-np2" <<<"$table" && ok "table lists both runs" || bad "table: $table"
grep -q "speed-up model-demo-np2" <<<"$table" && ok "table reports the speed-up over np=1" || bad "no speed-up line: $table"
$PY -c 'import json,sys; t=json.load(open("table.json")); sys.exit(0 if len(t)==2 and all("digest" in r for r in t) else 1)' \
  && ok "JSON table has both runs with digests" || bad "table.json wrong"
# A tampered digest must be reported as a mismatch.
/usr/bin/python3 -c 'import json,sys; p=sys.argv[1]; s=json.load(open(p)); s["digest"]="f"+s["digest"][1:] if s["digest"][0]!="f" else "e"+s["digest"][1:]; json.dump(s,open(p,"w"))' campaign/model-demo-np2/summary.json  # the run digest (outputs carry digests too)
table=$($PY "$GS_ROOT/analysis/campaign_table.py" campaign 2>&1)
rc=$?
[[ $rc -ne 0 ]] && grep -q "DIGEST MISMATCH" <<<"$table" && ok "a differing digest is reported (exit $rc)" \
  || bad "tampered digest not caught (rc=$rc): $table"
finish
