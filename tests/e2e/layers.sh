# End-to-end: the layers of src/ (docs/ARCHITECTURE.md, "Layers";
# tests/util/check_layers.py): core -> par -> io -> run -> engines -> cli, no
# include up the stack, no engine including another engine, plugin_api.h only
# in src/io and src/plugins, no MPI call outside src/par, every public header
# given a layer. The checker must also refuse each kind of violation, shown on
# a scratch copy of the tree with one violation planted at a time.
source "$GS_ROOT/tests/e2e/lib.bash"
check=$GS_ROOT/tests/util/check_layers.py
if out=$(/usr/bin/python3 "$check" "$GS_ROOT" 2>&1); then
  ok "layers: $(tail -1 <<<"$out")"
else
  bad "layers: $out"
fi

plant() { # WHAT FILE LINE-TO-APPEND EXPECTED-MESSAGE
  local what=$1 file=$2 line=$3 want=$4 tree
  tree=$(mktemp -d "$PWD/layers.XXXX")
  mkdir -p "$tree/tests/util"
  cp -r "$GS_ROOT/src" "$GS_ROOT/include" "$tree/"
  printf '%s\n' "$line" >>"$tree/$file"
  if out=$(/usr/bin/python3 "$check" "$tree" 2>&1); then
    bad "a planted violation passes: $what"
  elif grep -qF "$want" <<<"$out"; then
    ok "refused: $what ($(grep -F "$want" <<<"$out" | head -1))"
  else
    bad "$what: refused without naming it: $out"
  fi
  rm -rf "$tree"
}
plant "par includes run.h (up the stack)" src/par/partition.c '#include "geosynth/run.h"' \
  "par includes geosynth/run.h of the run layer"
plant "io includes an engine header" src/io/mesh.c '#include "geosynth/field.h"' \
  "io includes geosynth/field.h of the engines layer"
plant "core includes par.h" src/core/log.c '#include "geosynth/par.h"' \
  "core includes geosynth/par.h of the par layer"
plant "an engine includes another engine" src/points/engine.c '#include "geosynth/model.h"' \
  "engine points includes geosynth/model.h of engine model"
plant "an engine calls MPI" src/micro/engine_setup.c \
  'static void planted(MPI_Comm c) { MPI_Barrier(c); }' "calls MPI_Barrier outside src/par"
plant "cli includes plugin_api.h" src/cli/main.c '#include "plugins/plugin_api.h"' \
  "includes plugins/plugin_api.h, private to src/io and src/plugins"
plant "a public header without a layer" include/geosynth/new_module.h '/* new */' \
  "no layer: add it to tests/util/check_layers.py"
finish
