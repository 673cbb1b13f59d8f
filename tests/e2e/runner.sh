# End-to-end: tests/run.sh itself, on a fake tree of tests whose outcomes are
# known: cmocka-style unit programs (passed, skipped, failed) and e2e scripts
# (checks ok, skipped, failed, no checks, unexpected output, a log that
# disappears: the runner of before printed "passed + : syntax error" for a
# failed test whose log could not be read and dropped every later suite). Every suite is counted even after the odd ones, skipped cases
# are counted as skipped (never passed) with their reasons, the closing line
# is "N passed, N failed, N skipped", the exit code is non-zero on failure.
source "$GS_ROOT/tests/e2e/lib.bash"
T0=$PWD/tree
mkdir -p "$T0/tests/e2e" "$T0/build/tests/unit"
cp "$GS_ROOT/tests/run.sh" "$T0/tests/run.sh"

unit() { # unit NAME BODY: a fake cmocka program
  printf '#!/usr/bin/env bash\n%s\n' "$2" > "$T0/build/tests/unit/$1"
  chmod +x "$T0/build/tests/unit/$1"
}
unit test_fake_ok 'echo "[==========] Running 3 test(s)."; echo "[  PASSED  ] 3 test(s)."'
unit test_fake_skip 'echo "check skipped: needs \${data}/meshes/armadillo.obj, not under the data root"
echo "[  SKIPPED ] big"; echo "[  PASSED  ] 2 test(s)."; echo "[  SKIPPED ] 1 test(s), listed below:"; echo "[  SKIPPED ] big"'
unit test_fake_fail 'echo "[  PASSED  ] 1 test(s)."; echo "[  FAILED  ] 1 test(s), listed below:"; exit 1'

cat > "$T0/tests/e2e/a_ok.sh" <<'EOF'
echo "check ok: one"; echo "check ok: two"
EOF
cat > "$T0/tests/e2e/b_skip.sh" <<'EOF'
echo "check ok: runs"
echo 'check skipped: castle: needs ${data}/model-synthesis/x/castle.txt'
echo 'check skipped: city: needs ${data}/model-synthesis/x/city.txt'
EOF
cat > "$T0/tests/e2e/c_garbage.sh" <<'EOF'
printf 'passed + : \x00\xff\xfe binary junk\n[  PASSED  ] x\n'
echo "check ok: after the junk"
EOF
cat > "$T0/tests/e2e/d_nolog.sh" <<'EOF'
echo "check ok: then my log vanishes"
rm -f "$GS_ROOT/build/test-logs/e2e-d_nolog.log"
EOF
cat > "$T0/tests/e2e/d_nolog_fail.sh" <<'EOF'
echo "check ok: then my log vanishes and I fail"
rm -f "$GS_ROOT/build/test-logs/e2e-d_nolog_fail.log"
exit 1
EOF
cat > "$T0/tests/e2e/e_fail.sh" <<'EOF'
echo "check ok: fine"; echo "check FAILED: broken"; exit 1
EOF
cat > "$T0/tests/e2e/f_empty.sh" <<'EOF'
true
EOF

(cd "$T0" && BUILD=build BIN=bin NP=1 T= tests/run.sh unit e2e) > runner.out 2>&1
rc=$?
last=$(tail -1 runner.out)
[[ $last == "12 passed, 4 failed, 3 skipped" ]] && ok "closing line: $last" || bad "closing line '$last'; output: $(tail -c 1500 runner.out)"
[[ $rc -ne 0 ]] && ok "exit code $rc with failures" || bad "exit code 0 despite failures"
grep -q "ok   e2e/f_empty" runner.out && grep -q "FAIL: e2e/e_fail" runner.out \
  && ok "the suites after the vanished log still ran" || bad "suites after d_nolog missing: $(cat runner.out)"
grep -q "FAIL: e2e/d_nolog (rc=0; its log .* could not be written or read)" runner.out \
  && grep -q "FAIL: e2e/d_nolog_fail (rc=1; its log .* could not be written or read)" runner.out \
  && ok "a test whose log vanished fails, with the reason" || bad "d_nolog not reported: $(grep d_nolog runner.out)"
grep -q "syntax error" runner.out && bad "bash syntax error in the runner" || ok "no arithmetic error"
grep -q "ok   unit/test_fake_skip (2 cases, 1 skipped)" runner.out && ok "unit: cmocka skips counted" \
  || bad "unit skip line: $(grep test_fake_skip runner.out)"
grep -q "ok   e2e/b_skip (1 checks, 2 skipped)" runner.out && ok "e2e: check skipped lines counted" \
  || bad "e2e skip line: $(grep b_skip runner.out)"
grep -qF "e2e/b_skip: city: needs \${data}/model-synthesis/x/city.txt" runner.out \
  && grep -qF "unit/test_fake_skip: needs \${data}/meshes/armadillo.obj" runner.out \
  && ok "skip reasons listed at the end" || bad "skip reasons: $(sed -n '/^skipped/,$p' runner.out)"
n=$(wc -l < "$T0/build/test-logs/skipped.tsv")
[[ $n -eq 3 ]] && grep -qP '^e2e/b_skip\tcastle' "$T0/build/test-logs/skipped.tsv" \
  && ok "skipped.tsv: 3 lines, suite/name and reason" || bad "skipped.tsv: $(cat "$T0/build/test-logs/skipped.tsv")"

# T selects by substring and by exact SUITE/NAME
(cd "$T0" && BUILD=build BIN=bin T="e2e/a_ok,fake_ok" tests/run.sh unit e2e) > sel.out 2>&1
[[ $(tail -1 sel.out) == "5 passed, 0 failed, 0 skipped" ]] && grep -q "ok   e2e/a_ok" sel.out \
  && ! grep -q "b_skip" sel.out && ok "T=\"e2e/a_ok,fake_ok\" runs exactly those" || bad "selection: $(cat sel.out)"
(cd "$T0" && BUILD=build BIN=bin tests/run.sh nosuch) > bad.out 2>&1
[[ $? -ne 0 ]] && grep -q "unknown suite 'nosuch'" bad.out && ok "an unknown suite is a failure" || bad "unknown suite: $(cat bad.out)"
finish
