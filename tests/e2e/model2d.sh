# End-to-end: the model engine's 2D WaveFunctionCollapse inputs (mxgmn tile
# sets and the overlapping model). Tile set run at np 1 and 2 with identical
# digests, the assembled picture seamless (tile edges meet pixel for pixel,
# which only holds when symmetries, rotations and neighbour expansion agree),
# model-check against the tile set, an overlapping run, bad tile-set XML and
# bad keys named. About 10 s here. The tile sets and samples are not
# redistributable: fetched by `make data`, skipped without them.
source "$GS_ROOT/tests/e2e/lib.bash"
W=$DATA/wfc/mxgmn-WaveFunctionCollapse
r=wfc/mxgmn-WaveFunctionCollapse
need_data "2D tile set and overlapping model runs" $r/tilesets/Knots.xml \
  $r/tilesets/Knots/{corner,cross,empty,line,t}.png $r/samples/Knot.png || finish
metric() { /usr/bin/python3 -c 'import json,sys;print(json.load(open(sys.argv[1]+"/summary.json"))["metrics"][sys.argv[2]])' "$1" "$2"; }

cat > knots.ini <<EOF
[model]
tileset = $W/tilesets/Knots.xml
subset = Standard
size = 64x64x1
region = 8x8x1
passes = 2
max_passes = 2
attempts = 4
backtracks = 100
weights = frequency
mesh = none
txt = true
EOF

# --- same digest at np 1 and 2 ----------------------------------------------
run_gs 0 model -c knots.ini -o run1
expect_rc 0 "Knots/Standard 64x64 at np=1"
run_gs 2 model -c knots.ini -o run2
expect_rc 0 "Knots/Standard 64x64 at np=2"
d1=$(digest_of run1) d2=$(digest_of run2)
[[ $d1 == "$d2" ]] && ok "np=1 and np=2 digest $d1" || bad "np=2 digest $d2 != np=1 $d1"
[[ $(metric run1 violations) == 0 && $(metric run1 min_coverage) -ge 1 ]] \
  && ok "0 violations, every cell in an accepted region" || bad "violations/coverage in summary"
[[ $(metric run1 labels_used) -ge 6 ]] && ok "uses $(metric run1 labels_used) of 9 oriented tiles" \
  || bad "only $(metric run1 labels_used) oriented tiles used"

# --- stop + resume at another rank count -------------------------------------
GS_STOP_AFTER_UNITS=40 run_gs 0 model -c knots.ini -o stop
expect_rc 9 "GS_STOP_AFTER_UNITS=40 stops with exit 9"
run_gs 2 resume stop
expect_rc 0 "resume at np=2"
[[ $(digest_of stop) == "$d1" ]] && ok "stop at np=1 + resume at np=2: digest $d1" \
  || bad "resume digest $(digest_of stop) != $d1"

# --- model-check against the tile set ---------------------------------------
run_gs 0 model-check "$W/tilesets/Knots.xml#Standard" run1/lattice.h5
[[ $rc -eq 0 ]] && grep -q "^violations: 0$" <<<"$out" && ok "model-check Knots.xml#Standard: 0 violations" \
  || bad "model-check rc=$rc ${out:0:300} ${err:0:300}"
run_gs 0 model-check "$W/tilesets/Knots.xml#Standard" run2/lattice.txt
[[ $rc -eq 0 ]] && ok "model-check on lattice.txt: 0 violations" || bad "model-check txt rc=$rc ${err:0:300}"
# broken outputs: cell (0, 0) set to another tile until a neighbour pair breaks,
# and to a label that is no tile at all
break_cell() { # break_cell LABEL OUT
  /usr/bin/python3 - run1/lattice.txt "$2" "$1" <<'EOF'
import sys, re
lines = open(sys.argv[1]).read().split("\n")
body = "\n".join(lines[4:])  # 3 free lines and the extents, then cell (0, 0, 0) first
m = re.search(r"\d+", body)
body = body[:m.start()] + sys.argv[3] + body[m.end():]
open(sys.argv[2], "w").write("\n".join(lines[:4]) + "\n" + body)
EOF
}
found=""
for l in 1 2 3 4 5 6 7 8 9; do
  break_cell $l broken.txt
  run_gs 0 model-check "$W/tilesets/Knots.xml#Standard" broken.txt
  if [[ $rc -eq 2 ]] && grep -q "pair never adjacent" <<<"$out"; then found=$l; break; fi
done
[[ -n $found ]] && ok "cell (0,0) = tile $found: $(grep -m1 'pair never' <<<"$out")" \
  || bad "no replacement of cell (0,0) reported by model-check"
break_cell 99 broken.txt
run_gs 0 model-check "$W/tilesets/Knots.xml#Standard" broken.txt
[[ $rc -eq 2 ]] && grep -q "label 99 never occurs" <<<"$out" && ok "label 99 (no tile) reported" \
  || bad "label 99 not reported: rc=$rc ${out:0:300}"

# --- the assembled picture is seamless -----------------------------------------
/usr/bin/python3 - run1/tiles.png 10 64 <<'EOF' && ok "tiles.png 640x640 RGBA, every tile edge meets its neighbour's edge pixel for pixel" || bad "tiles.png seams (see above)"
import sys, zlib, struct
path, T, n = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
data = open(path, "rb").read()
assert data[:8] == b"\x89PNG\r\n\x1a\n"
pos, idat, w = 8, b"", 0
while pos < len(data):
    ln, typ = struct.unpack(">I4s", data[pos:pos + 8]); body = data[pos + 8:pos + 8 + ln]; pos += 12 + ln
    if typ == b"IHDR":
        w, h, bd, ct = struct.unpack(">IIBB", body[:10]); assert (w, h, bd, ct) == (T * n, T * n, 8, 6), (w, h, bd, ct)
    elif typ == b"IDAT": idat += body
raw, bpp, stride = zlib.decompress(idat), 4, w * 4
rows, prev, i = [], bytearray(stride), 0
for y in range(h):
    f = raw[i]; line = bytearray(raw[i + 1:i + 1 + stride]); i += 1 + stride
    for x in range(stride):
        a = line[x - bpp] if x >= bpp else 0; b = prev[x]; c = prev[x - bpp] if x >= bpp else 0
        if f == 1: line[x] = (line[x] + a) & 255
        elif f == 2: line[x] = (line[x] + b) & 255
        elif f == 3: line[x] = (line[x] + (a + b) // 2) & 255
        elif f == 4:
            p = a + b - c; pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
            line[x] = (line[x] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
    rows.append(bytes(line)); prev = line
px = lambda x, y: rows[y][4 * x:4 * x + 4]
bad = 0
for ty in range(n):
    for tx in range(n):
        for k in range(T):
            if tx + 1 < n and px(tx * T + T - 1, ty * T + k) != px((tx + 1) * T, ty * T + k): bad += 1
            if ty + 1 < n and px(tx * T + k, ty * T + T - 1) != px(tx * T + k, (ty + 1) * T): bad += 1
print("seam pixels differing:", bad)
sys.exit(1 if bad else 0)
EOF

# --- overlapping model ---------------------------------------------------------
cat > over.ini <<EOF
[model]
sample = $W/samples/Knot.png
overlap_n = 3
symmetry = 8
size = 32x32x1
region = 16x16x1
weights = frequency
mesh = none
vox = false
EOF
run_gs 0 model -c over.ini -o over1
expect_rc 0 "overlapping model Knot.png N=3 32x32"
[[ $(metric over1 violations) == 0 ]] && ok "overlapping: 0 overlap disagreements" || bad "overlapping violations $(metric over1 violations)"
[[ -s over1/image.png && $(/usr/bin/python3 -c 'import struct,sys;d=open(sys.argv[1],"rb").read(24);print(struct.unpack(">II",d[16:24]))' over1/image.png) == "(34, 34)" ]] \
  && ok "image.png is 34x34 (32 + N - 1)" || bad "image.png missing or wrong size"
run_gs 2 model -c over.ini -o over2
[[ $rc -eq 0 && $(digest_of over1) == $(digest_of over2) ]] && ok "overlapping np=2 digest equal" || bad "overlapping np=2 rc=$rc"

# --- bad inputs ------------------------------------------------------------------
mkdir -p bad
cp -r "$W/tilesets/Knots" bad/Knots
sed '10s|right="empty"|right="emtpy"|' "$W/tilesets/Knots.xml" > bad/Knots.xml
sed -i "s|^tileset = .*|tileset = $PWD/bad/Knots.xml|; s|^subset = .*|subset =|" knots.ini
run_gs 0 model -c knots.ini -o badrun
[[ $rc -ne 0 ]] && ok "unknown tile in a neighbour list fails (exit $rc)" || bad "bad XML accepted"
expect_err "Knots.xml:10:" "error names the file and line"
expect_err "no tile named 'emtpy'" "error names the unknown tile"
sed '20s|/>|>|' "$W/tilesets/Knots.xml" > bad/Knots.xml
run_gs 0 model -c knots.ini -o badrun
expect_err "Knots.xml:" "unclosed tag: file named"
expect_err "does not match" "unclosed tag: mismatch explained"
printf '<set>\n  <tiles>\n    <tile name="a" symmetry="Q"/>\n  </tiles>\n</set>\n' > bad/Knots.xml
run_gs 0 model -c knots.ini -o badrun
expect_err "Knots.xml:3: tile a: symmetry=\"Q\"" "bad symmetry: file, line, value"
run_gs 0 model -c knots.ini -o badrun --set model.tileset="$W/tilesets/Knots.xml" --set model.subset=Nope
expect_err "no subset named 'Nope'" "unknown subset named with the list"
run_gs 0 model -c knots.ini -o badrun --set model.example="$W/x.txt"
expect_rc 2 "tileset and example together"
expect_err "model.example" "conflicting inputs: key named"
run_gs 0 model -c knots.ini -o badrun --set model.tileset="$W/tilesets/Knots.xml" --set model.size=8x8x2
expect_err "model.size z = 2: $W/tilesets/Knots.xml is a 2D tile set" "3D size with a 2D tile set: key and file named"
finish
