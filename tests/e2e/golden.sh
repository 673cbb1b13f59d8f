# End-to-end: golden digests. Every row of tests/golden/digests.tsv runs at each
# of its rank counts with --set run.expect_digest=DIGEST and must exit 0 and log
# "digest: DIGEST (verified)": an output change that is the same at every rank
# count (which the rank-count tests cannot see) fails here. A wrong digest must
# make the run fail (exit 2), which the last check proves on the first row.
# `tests/e2e/golden.sh --update` (run from the source tree, after `make`)
# re-pins every row instead, refusing rows whose rank counts disagree.
if [[ -z ${GS_ROOT:-} ]]; then GS_ROOT=$(cd "$(dirname "$0")/../.." && pwd); fi
source "$GS_ROOT/tests/e2e/lib.bash"
TABLE=$GS_ROOT/tests/golden/digests.tsv
update=0
[[ ${1:-} == --update ]] && update=1
if [[ $update -eq 1 ]]; then
  work=$(mktemp -d); trap 'rm -rf "$work"' EXIT; cd "$work"
fi

rows=()
while IFS=$'\t' read -r engine cfg ranks sets digest; do
  [[ -z $engine || $engine == \#* ]] && continue
  rows+=("$engine"$'\t'"$cfg"$'\t'"$ranks"$'\t'"$sets"$'\t'"$digest")
done <"$TABLE"

newtable=$(grep '^#' "$TABLE")
first_ok=""
for row in "${rows[@]}"; do
  IFS=$'\t' read -r engine cfg ranks sets digest <<<"$row"
  name=$(basename "$cfg" .ini)
  [[ $sets == - ]] || name+=-$(printf %s "$sets" | cksum | cut -d" " -f1)  # rows of one config with other --set
  extra=()
  if [[ $sets != - ]]; then read -ra kv <<<"$sets"; for s in "${kv[@]}"; do extra+=(--set "$s"); done; fi
  if ! need_config "golden $engine/$name" "$GS_ROOT/$cfg"; then
    newtable+=$'\n'"$row"
    continue
  fi
  IFS=, read -ra nps <<<"$ranks"
  if [[ $update -eq 1 ]]; then
    got=()
    for np in "${nps[@]}"; do
      run_gs "$np" "$engine" -c "$GS_ROOT/$cfg" -o "g-$engine-$name-$np" "${extra[@]}"
      [[ $rc -eq 0 ]] || { bad "update $engine/$name np=$np: exit $rc: ${err:0:400}"; got+=(failed); continue; }
      got+=("$(digest_of "g-$engine-$name-$np")")
    done
    uniq=$(printf '%s\n' "${got[@]}" | sort -u)
    if [[ $(wc -l <<<"$uniq") -eq 1 && $uniq != failed ]]; then
      [[ $uniq == "$digest" ]] && ok "$engine/$name: $digest unchanged" || ok "$engine/$name: $digest -> $uniq (re-pinned)"
      digest=$uniq
    else
      bad "$engine/$name: rank counts $ranks disagree (${got[*]}): not pinned"
    fi
    newtable+=$'\n'"$engine"$'\t'"$cfg"$'\t'"$ranks"$'\t'"$sets"$'\t'"$digest"
    continue
  fi
  for np in "${nps[@]}"; do
    run_gs "$np" "$engine" -c "$GS_ROOT/$cfg" -o "g-$engine-$name-$np" "${extra[@]}" \
      --set "run.expect_digest=$digest"
    if [[ $rc -eq 0 ]] && grep -qF "digest: $digest (verified)" <<<"$out$err"; then
      ok "golden $engine/$name np=$np: digest $digest (verified)"
      [[ -n $first_ok ]] || first_ok=$row
    else
      got=$(digest_of "g-$engine-$name-$np" 2>/dev/null)
      bad "golden $engine/$name np=$np: expected digest $digest, got ${got:-none} (exit $rc); if the change is intended, re-pin with tests/e2e/golden.sh --update: ${err: -300}"
    fi
  done
done

if [[ $update -eq 1 ]]; then
  printf '%s\n' "$newtable" >"$TABLE"
  echo "golden: wrote $TABLE"
elif [[ -n $first_ok ]]; then
  # A wrong expected digest must fail the run (exit 2, reported once).
  IFS=$'\t' read -r engine cfg ranks sets digest <<<"$first_ok"
  wrong=$(printf '%016x' $(( 0x$digest ^ 1 )))
  run_gs 2 "$engine" -c "$GS_ROOT/$cfg" -o g-wrong --set "run.expect_digest=$wrong"
  expect_rc 2 "a wrong run.expect_digest fails the run"
  expect_err "is not run.expect_digest = $wrong" "the mismatch is named"
  n=$(grep -c "is not run.expect_digest" <<<"$err")
  [[ $n -eq 1 ]] && ok "the mismatch is reported once" || bad "the mismatch is reported $n times"
  run_gs 0 "$engine" -c "$GS_ROOT/$cfg" -o g-bad --set run.expect_digest=xyz
  expect_rc 2 "run.expect_digest = xyz is refused"
  expect_err "expected 16 hex digits" "the bad value is named with what is expected"
fi
finish
