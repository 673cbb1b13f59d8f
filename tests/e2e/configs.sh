# End-to-end: every config in configs/ loads with the real parser
# (`geosynth ENGINE -c FILE --check`: every key, value and input path), and
# every key in them has a comment (scripts/config-comments.py --check).
# --check itself: a bad key is exit 2, a missing input file exit 3.
source "$GS_ROOT/tests/e2e/lib.bash"
n=0 nbad=0
for f in "$GS_ROOT"/configs/*/*.ini; do
  engine=$(basename "$(dirname "$f")")
  run_gs 0 "$engine" -c "$f" --check
  n=$((n + 1))
  if [[ $rc -ne 0 ]]; then
    bad "${f#$GS_ROOT/}: geosynth $engine --check exit $rc: ${err:0:400}"; nbad=$((nbad + 1))
  elif ! grep -q "^\[run\]" <<<"$out"; then
    bad "${f#$GS_ROOT/}: --check printed no resolved config"; nbad=$((nbad + 1))
  fi
done
[[ $n -gt 50 && $nbad -eq 0 ]] && ok "all $n configs in configs/ load with the real parser (--check)"
doc=$(/usr/bin/python3 "$GS_ROOT/scripts/config-comments.py" --check "$GS_ROOT"/configs/*/*.ini 2>&1)
[[ $? -eq 0 ]] && ok "every key of every config has a comment" || bad "keys without a comment: ${doc:0:1000}"
printf '[field]\nblock = 8\ntarget = 16\n' >undocumented.ini
/usr/bin/python3 "$GS_ROOT/scripts/config-comments.py" --check undocumented.ini >/dev/null 2>&1 \
  && bad "an undocumented key passes the comment check" || ok "the comment check flags an undocumented key"
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
