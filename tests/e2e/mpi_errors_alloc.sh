# End-to-end: a rank that cannot allocate the room for what rank 0 parsed
# and broadcasts never leaves rank 0 waiting in the broadcast (#25 "never
# hang"). Every input is parsed on rank 0 and broadcast; the other ranks
# allocate first, and used to broadcast without agreeing on that allocation
# (field's example, model's example lattice, micro's mesh and distribution
# tables, the config text): had it failed, rank 0 sat in MPI_Bcast while the
# failing rank went on to the next collective. Now the allocation is agreed
# (gs_par_bcast_alloc or gs_par_agree, src/par). The test-only hook
# GS_FAIL_RANK=1 GS_FAIL_ALLOC=NAME (gs_mem_fail_alloc, include/geosynth/mem.h)
# makes rank 1's allocation NAME fail as out of memory would. Each case at
# np 2 must end within 60 s with exit 5 (memory), one error line naming the
# array, from rank 1, raised where the broadcast site allocates (its stack
# line), no MPI_ABORT banner. Watched failing: field's site without the
# agreement hangs (rank 0 in the broadcast of the 262 KB example, rank 1 in
# the driver's agreement) until the 60 s limit; micro's distribution tables
# without it did not hang (a few hundred bytes: Open MPI sends them eagerly
# and rank 0 goes on) - tests/mpi/bcast_alloc.c shows what an unagreed
# broadcast then does (the next collective receives its bytes).
source "$GS_ROOT/tests/e2e/lib.bash"
LIMIT=60
# a closed cube (OFF) for micro.mesh: read on rank 0 and broadcast
printf 'OFF\n8 12 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n1 0 1\n1 1 1\n0 1 1\n3 0 2 1\n3 0 3 2\n3 4 5 6\n3 4 6 7\n3 0 1 5\n3 0 5 4\n3 1 2 6\n3 1 6 5\n3 2 3 7\n3 2 7 6\n3 3 0 4\n3 3 4 7\n' >cube.off

# NAME|SITE|ENGINE ARGS...: SITE is the stack line of the broadcast site.
cases=(
  "quantized field|in build_source()|field -c $GS_ROOT/configs/field/quick.ini"
  "label lattice|in bcast_lattice()|model -c $GS_ROOT/configs/model/demo.ini"
  "distribution|in setup_dist()|micro -c $GS_ROOT/configs/micro/coral.ini"
  "mesh positions|in load_mesh_file()|micro -c $GS_ROOT/configs/micro/quick.ini --set micro.shape=file --set micro.mesh=$PWD/cube.off"
  "broadcast text|in gs_par_bcast_string()|field -c $GS_ROOT/configs/field/quick.ini"
)
for spec in "${cases[@]}"; do
  IFS='|' read -r name site args <<<"$spec"
  read -ra argv <<<"$args"
  rm -rf run-out
  start=$SECONDS
  GS_FAIL_RANK=1 GS_FAIL_ALLOC=$name timeout -s KILL "$LIMIT" mpirun -np 2 "$GS_BIN" "${argv[@]}" \
    -o run-out >out.txt 2>err.txt </dev/null
  rc=$? secs=$((SECONDS - start))
  err=$(cat err.txt)
  lines=$(grep -cE '^(\[rank [0-9]+\] )?error \(' <<<"$err")
  what="rank 1 cannot allocate '$name' (${argv[0]})"
  if [[ $rc -eq 137 ]]; then
    bad "$what: still running after $LIMIT s (killed): a hang; stderr: $(tail -c 600 <<<"$err")"
  elif [[ $rc -ne 5 ]]; then
    bad "$what: exit $rc after $secs s, expected 5 (memory); stderr: $(tail -c 600 <<<"$err")"
  elif ! grep -q "^\[rank 1\] error (out of memory): $name: cannot allocate" <<<"$err" || [[ $lines -ne 1 ]]; then
    bad "$what: expected one error line from rank 1 naming '$name', got $lines: $(tail -c 600 <<<"$err")"
  elif ! grep -qF "$site" <<<"$err"; then
    bad "$what: the failure was not at the broadcast site ('$site'): $(grep '  at' <<<"$err" | head -6)"
  elif grep -q 'MPI_ABORT' <<<"$err"; then
    bad "$what: MPI_ABORT banner: the failure was not agreed; $(tail -c 600 <<<"$err")"
  else
    ok "$what: exit 5 after $secs s, one message from rank 1 naming it, raised $site, no abort"
  fi
done
finish
