# End-to-end: the data root (${data}/... in configs; include/geosynth/data.h).
# - default: the tree's data/ (compiled in), GS_DATA absolute or relative to the
#   current directory, an installed program's PREFIX/share/geosynth/data;
# - --check, --set and the resolved config (summary.json, resume) see the real
#   absolute path;
# - a missing ${data} file: exit 3 before anything runs, one message (also at
#   np 2, no MPI_Abort) naming the config, the key, the file, the data root and
#   the command that fetches it; the same for a line of a micro mesh list;
# - "${database}/x" is an ordinary relative path, not the variable.
source "$GS_ROOT/tests/e2e/lib.bash"
EX=model-synthesis/debroglie-samples-merrell/parliament.csv   # in the repository
FETCHED=model-synthesis/merrell42-model-synthesis/samples/castle.txt   # fetched by make data

printf '[model]\nexample = ${data}/%s\nsize = 12x12x8\n' "$EX" > in_repo.ini
printf '[model]\nexample = ${data}/%s\nsize = 12x12x8\n' "$FETCHED" > fetched.ini

# --- where the root is ---------------------------------------------------------
run_gs 0 model -c in_repo.ini --check
expect_rc 0 "--check of a \${data} config with the default root"
expect_out "example = $GS_ROOT/data/$EX" "default root: the tree's data/ (resolved to the real absolute path)"

mkdir -p alt/model-synthesis/debroglie-samples-merrell
cp "$GS_ROOT/data/$EX" alt/$EX
GS_DATA=$PWD/alt run_gs 0 model -c in_repo.ini --check
expect_out "example = $PWD/alt/$EX" "GS_DATA absolute"
mkdir -p sub && (cd sub && GS_DATA=../alt run_gs 0 model -c ../in_repo.ini --check && echo "$out" > ../rel.out)
grep -qF "example = $PWD/alt/$EX" rel.out && ok "GS_DATA relative to the current directory" \
  || bad "GS_DATA=../alt from sub/: $(grep '^example' rel.out)"

run_gs 0 model -c in_repo.ini --check --set 'model.example=${data}/vox/sylefeb-VoxModSynth/exemplars/towers.slab.vox'
expect_out "example = $GS_ROOT/data/vox/sylefeb-VoxModSynth/exemplars/towers.slab.vox" "--set with \${data}/"

printf '[model]\nexample = ${database}/x.txt\n' > notvar.ini
run_gs 0 model -c notvar.ini --check
expect_rc 3 "\${database}/x.txt is a relative path (missing here)"
expect_err "$PWD/\${database}/x.txt" "... resolved against the config's directory, not the data root"

# an installed program (PREFIX/bin/geosynth) uses PREFIX/share/geosynth/data
mkdir -p prefix/bin prefix/share/geosynth/data/model-synthesis/debroglie-samples-merrell
cp "$GS_BIN" prefix/bin/geosynth
cp "$GS_ROOT/data/$EX" prefix/share/geosynth/data/$EX
GS_BIN=$PWD/prefix/bin/geosynth run_gs 0 model -c in_repo.ini --check
expect_out "example = $PWD/prefix/share/geosynth/data/$EX" "installed program: PREFIX/share/geosynth/data"
GS_DATA=$PWD/alt GS_BIN=$PWD/prefix/bin/geosynth run_gs 0 model -c in_repo.ini --check
expect_out "example = $PWD/alt/$EX" "installed program: GS_DATA still overrides"

# --- a run records the real path, and resume uses it ------------------------------
run_gs 2 model -c in_repo.ini -o run1
expect_rc 0 "a run of a \${data} config at np 2"
/usr/bin/python3 - run1/summary.json "$GS_ROOT/data/$EX" <<'PY' && ok "summary.json's resolved config has the absolute path" || bad "summary.json config"
import json, sys
s = json.load(open(sys.argv[1]))
text = json.dumps(s)
assert sys.argv[2] in text and "${data}" not in text, text[:400]
PY
GS_STOP_AFTER_UNITS=1 run_gs 0 model -c in_repo.ini -o stop --set model.region=6x6x0
expect_rc 9 "stopped after one region"
(cd sub && GS_DATA=/nonexistent run_gs 0 resume ../stop && echo "$rc" > ../resume.rc)
[[ $(cat resume.rc) == 0 ]] && ok "resume from another directory with another GS_DATA (the stored path is absolute)" \
  || bad "resume failed: rc $(cat resume.rc)"

# --- a missing ${data} file -----------------------------------------------------
mkdir -p empty
for np in 0 2; do
  GS_DATA=$PWD/empty run_gs $np model -c fetched.ini -o miss$np
  expect_rc 3 "missing \${data} file at np=$np: exit 3"
  expect_err "fetched.ini: model.example = $PWD/empty/$FETCHED: No such file or directory" "names the config, key and file (np=$np)"
  expect_err "the data root is $PWD/empty (GS_DATA)" "names the data root and where it came from (np=$np)"
  expect_err 'fetched with `make data`' "names make data (np=$np)"
  expect_err "GS_DATA=$PWD/empty scripts/fetch-data.sh $FETCHED" "names the script with the item and the root (np=$np)"
  n=$(grep -c "No such file or directory" <<<"$err")
  [[ $n -eq 1 ]] && ok "reported once (np=$np)" || bad "reported $n times (np=$np): ${err:0:800}"
  grep -q "MPI_ABORT" <<<"$err" && bad "MPI_Abort at np=$np" || ok "no MPI_Abort (np=$np)"
  [[ ! -e miss$np ]] && ok "nothing created (np=$np)" || bad "miss$np was created"
  expect_no_crash "missing data at np=$np"
done
GS_DATA=$PWD/empty run_gs 0 model -c fetched.ini --check
expect_rc 3 "--check: missing \${data} file is exit 3"
expect_err "make data" "--check names make data"
"$GS_ROOT/scripts/fetch-data.sh" --has "$FETCHED" && ok "the hint's item is one the script knows" \
  || bad "$FETCHED is not in scripts/data-manifest.tsv"

# a missing file outside the data root gets no fetch hint
printf '[model]\nexample = nowhere/x.txt\n' > plain.ini
run_gs 0 model -c plain.ini --check
expect_rc 3 "missing plain file: exit 3"
grep -q "make data" <<<"$err" && bad "a file outside the data root got the fetch hint" || ok "no fetch hint outside the data root"

# a micro mesh list line naming a missing ${data} file
printf '# list\n${data}/meshes/spot.obj\n${data}/meshes/bunny-closed.off\n' > meshes.txt
printf '[micro]\nshape = file\nmesh_list = meshes.txt\nscale_units = 8\n' > list.ini
mkdir -p partial/meshes && cp "$GS_ROOT/data/meshes/spot.obj" partial/meshes/
GS_DATA=$PWD/partial run_gs 0 micro -c list.ini -o listrun
expect_rc 3 "micro.mesh_list with a missing \${data} mesh: exit 3"
expect_err "meshes.txt, line 3: \${data}/meshes/bunny-closed.off: No such file or directory" "names the list, the line and the entry"
expect_err "GS_DATA=$PWD/partial scripts/fetch-data.sh meshes/bunny-closed.off" "names the fetch command"
# with the default root (the tree's data/) the command needs no GS_DATA
run_gs 0 model -c fetched.ini --set 'model.example=${data}/meshes/not-fetched.txt' --check
expect_err "(scripts/fetch-data.sh meshes/not-fetched.txt fetches only this file)" "default root: the script without GS_DATA"
finish
