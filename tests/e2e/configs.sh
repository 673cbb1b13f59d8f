# End-to-end: every config in configs/ loads with the real parser
# (`geosynth ENGINE -c FILE --check`: every key, value and input path), and
# every key in them has a comment (scripts/config-comments.py --check).
# A config naming third-party data that is not under the data root (fetched
# by `make data`) is checked for keys and values with its input files
# replaced (--set KEY=/dev/null) and counted as skipped for its inputs.
# --check itself: a bad key is exit 2, a missing input file exit 3 with the
# data root and the fetch command for a ${data} file.
source "$GS_ROOT/tests/e2e/lib.bash"
n=0 nbad=0 nskip=0
for f in "$GS_ROOT"/configs/*/*.ini; do
  engine=$(basename "$(dirname "$f")")
  name=${f#$GS_ROOT/}
  n=$((n + 1))
  if ! need_config "$name --check (its input files)" "$f"; then
    nskip=$((nskip + 1))
    # keys and values still parse: the same file with each ${data} input replaced
    mapfile -t keys < <(/usr/bin/python3 - "$f" <<'PY'
import re, sys
sec = ""
for line in open(sys.argv[1]):
    m = re.match(r"\s*\[([^\]]+)\]", line)
    if m: sec = m.group(1).strip(); continue
    m = re.match(r"\s*([A-Za-z0-9_]+)\s*[=:]\s*\$\{data\}/", line)
    if m: print("%s.%s" % (sec, m.group(1)))
PY
)
    sets=()
    for k in "${keys[@]}"; do sets+=(--set "$k=/dev/null"); done
    run_gs 0 "$engine" -c "$f" --check "${sets[@]}"
  else
    run_gs 0 "$engine" -c "$f" --check
  fi
  if [[ $rc -ne 0 ]]; then
    bad "$name: geosynth $engine --check exit $rc: ${err:0:400}"; nbad=$((nbad + 1))
  elif ! grep -q "^\[run\]" <<<"$out"; then
    bad "$name: --check printed no resolved config"; nbad=$((nbad + 1))
  fi
done
[[ $n -gt 50 && $nbad -eq 0 ]] && ok "all $n configs in configs/ load with the real parser (--check; $nskip without their fetched inputs)"
# no config names a path outside the repository or the data root
if grep -nE '(^|[=[:space:]])(\.\./)+shared|/work/' "$GS_ROOT"/configs/*/*; then
  bad "a config names a path outside the repository (use \${data}/...)"
else
  ok "configs name their inputs inside the repository or as \${data}/..."
fi
doc=$(/usr/bin/python3 "$GS_ROOT/scripts/config-comments.py" --check "$GS_ROOT"/configs/*/*.ini 2>&1)
[[ $? -eq 0 ]] && ok "every key of every config has a comment" || bad "keys without a comment: ${doc:0:1000}"
printf '[field]\nblock = 8\ntarget = 16\n' >undocumented.ini
/usr/bin/python3 "$GS_ROOT/scripts/config-comments.py" --check undocumented.ini >/dev/null 2>&1 \
  && bad "an undocumented key passes the comment check" || ok "the comment check flags an undocumented key"
# the docs name no path outside the repository, and FORMATS.md every output file name
if grep -nE '\.\./shared|/work/' "$GS_ROOT/README.md" "$GS_ROOT"/docs/*.md "$GS_ROOT"/tests/README.md "$GS_ROOT"/configs/README.md; then
  bad "a doc names a path outside the repository"
else
  ok "README.md, docs/, tests/README.md, configs/README.md name no path outside the repository"
fi
missing=$(grep -rhoE 'gs_run_output\(run, "[a-z_]+", "[a-z_]+", "[^"]+"' "$GS_ROOT/src" | sed -E 's/.*, "([^"]+)"$/\1/' | sort -u |
  while IFS= read -r f; do grep -qF "$f" "$GS_ROOT/docs/FORMATS.md" || echo "$f"; done)
[[ -z $missing ]] && ok "docs/FORMATS.md describes every output file the engines record" \
  || bad "outputs missing from docs/FORMATS.md: $missing"
run_gs 0 field -c "$GS_ROOT/configs/field/quick.ini" --check --set field.blok=8
expect_rc 2 "--check with an unknown key"
expect_err "did you mean 'field.block'" "--check names the key"
run_gs 0 model -c "$GS_ROOT/configs/model/demo.ini" --check --set model.example=missing.txt
expect_rc 3 "--check with a missing input file"
expect_err "model.example" "--check names the input key"
run_gs 0 resume somewhere --check
expect_rc 1 "--check is refused outside an engine"
[[ ! -e runs ]] && ok "--check wrote nothing" || bad "--check created $(ls runs)"
finish
