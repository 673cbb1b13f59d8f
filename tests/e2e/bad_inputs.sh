# End-to-end: every kind of bad input gets one clear error through the command
# line (#25 item 7; the table "Bad inputs and what each gets" in
# tests/README.md). Each case runs at np 1 and np 2 and must
#   - exit with the documented code (README "Exit codes"),
#   - name the file and the line, key or byte in the message (the fragments
#     given per case),
#   - report the error once: one "error (KIND): ..." line and no error line
#     printed twice (by two ranks), no MPI_ABORT banner, no signal, no
#     sanitizer report,
#   - print no control byte taken from the file (a terminal escape sequence
#     in a PNG chunk name used to reach the terminal raw).
# Every run is limited to 2 GB of address space and 60 s: a bad file that
# makes geosynth allocate what it declares (14 GB for an 11 KB HDF5 file)
# fails here instead of swapping the machine.
source "$GS_ROOT/tests/e2e/lib.bash"
PY=/usr/bin/python3
FQ=$GS_ROOT/configs/field/quick.ini
MQ=$GS_ROOT/configs/model/demo.ini
PQ=$GS_ROOT/configs/points/quick.ini
UQ=$GS_ROOT/configs/micro/quick.ini

# ---- the bad files --------------------------------------------------------------
printf '[example]\nkind = grid\nsize = 32\n\n[field]\nblok = 16\n' >badkey.ini
printf '[example]\nkind = grid\nsize = 32\n\n[field]\nblock = 12x\n' >badvalue.ini
printf 'ply\nformat ascii 1.0\nelement vertex 8\nproperty float x\nproperty float y\nproperty float z\nelement face 12\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n' >cut.ply
printf 'ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\nend_header\n0 0 0 0 0 1\n1 0 0 0 zero 1\n' >points.ply
printf 'castle\nseed\nfree\n1024 1024 1000\n1 2 3\n' >huge.txt
printf '1, 2, 3\n4, 5\n' >ragged.csv
# a 4x4x2 lattice with one label id 65534 (rows are x, columns y): its rules,
# sized by the largest id, took 4 GB of address space
printf 'sparse\n\nx, y, and z extents\n4 4 2\n1 1 1 1\n1 1 1 1\n1 65534 1 1\n1 1 1 1\n2 2 2 2\n2 2 2 2\n2 2 2 2\n2 2 2 2\n' >sparse.txt
# 300 distinct labels (1..300 over a 20x20 layer, an empty layer above):
# more than a lattice.vox palette holds
$PY -c 'print("labels300\n\nx, y, and z extents\n20 20 2");[print(" ".join(str((y*20+x)%300+1) for x in range(20))) for y in range(20)];[print(" ".join(["0"]*20)) for y in range(20)]' >labels300.txt
printf '<set>\n<tiles>\n<tile name="a" symmetry="Z"/>\n</tiles>\n</set>\n' >badsym.xml
printf 'bin,positive,negative\n0,0.5,0.5\n1,1.5,0.5\n' >badtable.csv
$PY - <<'PYEOF'
import struct, zlib
def chunk(t, d, n=None):
    n = len(d) if n is None else n
    return struct.pack('>I', n) + t + d + struct.pack('>I', zlib.crc32(t + d) & 0xffffffff)
sig = b'\x89PNG\r\n\x1a\n'
ihdr = chunk(b'IHDR', struct.pack('>IIBBBBB', 64, 64, 8, 0, 0, 0, 0))
# a 64x64 grey PNG cut in the middle of its IDAT
idat = chunk(b'IDAT', zlib.compress(bytes(range(256)) * 17))
open('cut.png', 'wb').write((sig + ihdr + idat)[:60])
# a chunk whose name is a terminal escape sequence, with a length past the end
open('escape.png', 'wb').write(sig + ihdr + struct.pack('>I', 1 << 30) + b'\x1b[2J' + b'\0' * 8)
# a JPEG Huffman table declaring 300 codes (stb_image wrote past its table)
open('dht.jpg', 'wb').write(bytes([0xFF, 0xD8, 0xFF, 0xC4, 0x00, 0x13, 0x00, 0xFF, 0x2D]) + bytes(14) + b'\xff\xd9')
open('text.vdb', 'wb').write(b'not a vdb file at all, just text\n' * 4)
open('cut.vox', 'wb').write(b'VOX \x96\x00\x00\x00MAIN\x00\x00\x00\x00\xff\x00\x00\x00SIZE\x0c\x00\x00\x00')
open('text.h5', 'w').write('this is not an HDF5 file\n')
# a tile set whose one tile is 4096x4096 grey pixels: 17x17 tiles make a
# tiles.png of 69632 pixels a side, past what the PNG writer takes (65536)
import os
os.makedirs('bigtile', exist_ok=True)
raw = (b'\0' + b'\x80' * 4096) * 4096
open('bigtile/a.png', 'wb').write(sig + chunk(b'IHDR', struct.pack('>IIBBBBB', 4096, 4096, 8, 0, 0, 0, 0))
                                  + chunk(b'IDAT', zlib.compress(raw, 1)) + chunk(b'IEND', b''))
open('bigtile.xml', 'w').write('<set>\n<tiles>\n<tile name="a" symmetry="X"/>\n</tiles>\n'
                               '<neighbors>\n<neighbor left="a" right="a"/>\n</neighbors>\n</set>\n')
# a MarkovJunior voxel tile set of one 64^3-voxel tile (one voxel set): 20^3
# tiles make a tiles.vox of 1280^3 voxels, past the 2^28 a .vox may hold
os.makedirs('bigvox', exist_ok=True)
def vchunk(t, d, children=b''):
    return t + struct.pack('<II', len(d), len(children)) + d + children
kids = vchunk(b'SIZE', struct.pack('<3I', 64, 64, 64)) + vchunk(b'XYZI', struct.pack('<I4B', 1, 0, 0, 0, 1))
open('bigvox/A.vox', 'wb').write(b'VOX ' + struct.pack('<I', 150) + vchunk(b'MAIN', b'', kids))
open('bigvox.xml', 'w').write('<tileset>\n<tiles>\n<tile name="A"/>\n</tiles>\n<neighbors>\n'
                              '<neighbor left="A" right="A"/>\n<neighbor top="A" bottom="A"/>\n'
                              '</neighbors>\n</tileset>\n')
PYEOF
mkdir -p ckptdir && cp text.h5 ckptdir/checkpoint.h5
printf '[field]\n' >ckptdir/start.ini

# ---- the cases ------------------------------------------------------------------
# case LABEL CODE "FRAGMENT[|FRAGMENT...]" ENGINE-ARGS... : runs at np 1 and 2
case_() {
  local label=$1 code=$2 frags=$3 np f missing lines dup; shift 3
  for np in 1 2; do
    rm -rf run-out
    local o e
    o=$(mktemp) e=$(mktemp)
    ( ulimit -v 2000000; timeout -s KILL 60 mpirun -np "$np" "$GS_BIN" "$@" >"$o" 2>"$e" )
    rc=$?
    err=$(cat "$e"); rm -f "$o" "$e"
    missing=""
    IFS='|' read -ra parts <<<"$frags"
    for f in "${parts[@]}"; do grep -qF -- "$f" <<<"$err" || missing+=" '$f'"; done
    lines=$(grep -cE '^(\[rank [0-9]+\] )?error \(' <<<"$err")
    dup=$(grep -E '^(\[rank [0-9]+\] )?(error|warning)' <<<"$err" | sed -E 's/^\[rank [0-9]+\] //' | sort | uniq -d | head -1)
    if [[ $rc -ne $code ]]; then
      bad "$label (np $np): exit $rc, expected $code; stderr: ${err:0:400}"
    elif [[ -n $missing ]]; then
      bad "$label (np $np): the message lacks$missing; stderr: ${err:0:400}"
    elif [[ $lines -ne 1 || -n $dup ]]; then
      bad "$label (np $np): reported $lines times${dup:+ (twice: $dup)}; stderr: ${err:0:400}"
    elif grep -qE 'MPI_ABORT|AddressSanitizer|runtime error:|Segmentation fault|core dumped' <<<"$err"; then
      bad "$label (np $np): abort banner or crash: ${err:0:400}"
    elif LC_ALL=C grep -qP '[\x00-\x08\x0b-\x1f\x7f]' <<<"$err"; then
      bad "$label (np $np): a control byte reached the terminal"
    else
      ok "$label (np $np): exit $code, one message naming ${frags//|/, }"
    fi
  done
}

case_ "config: unknown key" 2 "badkey.ini:6|blok|did you mean 'block'" \
  field -c badkey.ini -o run-out
case_ "config: bad value" 2 "badvalue.ini:6|block = 12x" \
  field -c badvalue.ini -o run-out
case_ "config: missing file" 3 "nosuch.ini" \
  field -c nosuch.ini -o run-out
case_ "--set: bad value" 2 "field.block=3" \
  field -c "$FQ" -o run-out --set field.block=3
case_ "mesh: truncated PLY" 4 "cut.ply" \
  field -c "$FQ" -o run-out --set example.kind=file --set example.path=cut.ply --set example.sign=unsigned
case_ "point-set PLY: a word for a number" 4 "points.ply|line 12" \
  points -c "$PQ" -o run-out --set input.kind=ply --set input.path=points.ply \
  --set "input.box_lo=0 0 0" --set "input.box_hi=1 1 1"
case_ "Merrell .txt: extents the file cannot hold" 4 "huge.txt:4|1024 x 1024 x 1000" \
  model -c "$MQ" -o run-out --set model.example=huge.txt
case_ "Merrell .txt: one label id 65534 among 3 labels" 4 "sparse.txt|label 65534 (at x 2 y 1 z 0)|renumber" \
  model -c "$MQ" -o run-out --set model.example=sparse.txt
case_ "Merrell .txt: 300 distinct labels with model.vox on, refused before synthesis" 2 \
  "model.vox|labels300.txt|300 distinct|255" \
  model -c "$MQ" -o run-out --set model.example=labels300.txt --set model.vox=true
[[ -e run-out/lattice.h5 ]] && bad "300 labels with model.vox: lattice.h5 written, the synthesis ran before the refusal" \
  || ok "300 labels with model.vox: no lattice.h5, refused before the synthesis"
case_ "DeBroglie .csv: ragged row" 4 "ragged.csv:2" \
  model -c "$MQ" -o run-out --set model.example=ragged.csv
case_ "tile set XML: unknown symmetry" 4 "badsym.xml:3|symmetry" \
  model -c "$MQ" -o run-out --set model.example= --set model.tileset=badsym.xml --set model.size=8x8x1 --set model.region=8x8x1
# refused at setup, before the synthesis: no lattice.h5 (it used to be
# written, then tiles.png failed after the whole synthesis, no summary.json)
case_ "tile set: tiles.png past 65536 pixels a side, refused before synthesis" 2 \
  "model.tile_image|bigtile.xml|69632x69632|65536" \
  model -c "$MQ" -o run-out --set model.example= --set model.tileset=bigtile.xml --set model.size=17x17x1 --set model.region=17x17x1
[[ -e run-out/lattice.h5 ]] && bad "tile set: tiles.png past 65536 pixels: lattice.h5 written, the synthesis ran before the refusal" \
  || ok "tile set: tiles.png past 65536 pixels: no lattice.h5, refused before the synthesis"
# the other pictures and voxel files a model run writes after its synthesis,
# refused at setup (the 2D output's lattice.png failed after the synthesis
# with "image: image of 70000x1 pixels", naming no file)
case_ "2D model output: lattice.png past 65536 pixels a side, refused before synthesis" 2 \
  "model.size = 70000x1x1|lattice.png|65536" \
  model -c "$MQ" -o run-out --set model.size=70000x1x1 --set model.region=0
[[ -e run-out/lattice.h5 ]] && bad "2D output past 65536 pixels: lattice.h5 written, the synthesis ran before the refusal" \
  || ok "2D output past 65536 pixels: no lattice.h5, refused before the synthesis"
case_ "overlapping model: image.png past 65536 pixels a side, refused before synthesis" 2 \
  "model.tile_image|disc-64.png|65538x4|65536" \
  model -c "$MQ" -o run-out --set model.example= --set "model.sample=$GS_ROOT/configs/model/disc-64.png" \
  --set model.size=65536x2x1 --set model.region=64x2x1 --set model.vox=false --set model.mesh=none
[[ -e run-out/lattice.h5 ]] && bad "overlapping model past 65536 pixels: lattice.h5 written, the synthesis ran before the refusal" \
  || ok "overlapping model past 65536 pixels: no lattice.h5, refused before the synthesis"
case_ "voxel tile set: tiles.vox past 2^28 voxels, refused before synthesis" 2 \
  "model.tile_image|bigvox.xml|1280x1280x1280|268435456" \
  model -c "$MQ" -o run-out --set model.example= --set model.tileset=bigvox.xml --set model.size=20x20x20 --set model.region=10x10x10
[[ -e run-out/lattice.h5 ]] && bad "tiles.vox past 2^28 voxels: lattice.h5 written, the synthesis ran before the refusal" \
  || ok "tiles.vox past 2^28 voxels: no lattice.h5, refused before the synthesis"
# an output past 2^28 cells: lattice.vox (model.vox = true, the default)
# would hold more than geosynth's .vox reader takes; it was only found out
# after the synthesis of 269 million cells
case_ "model output: lattice.vox past 2^28 voxels, refused before synthesis" 2 \
  "model.vox|model.size = 1024x1024x257|lattice.vox|268435456" \
  model -c "$MQ" -o run-out --set model.size=1024x1024x257 --set model.region=32x32x32
[[ -e run-out/lattice.h5 ]] && bad "lattice.vox past 2^28 voxels: lattice.h5 written, the synthesis ran before the refusal" \
  || ok "lattice.vox past 2^28 voxels: no lattice.h5, refused before the synthesis"
# a value with a terminal escape sequence: refused, and the refusal, which
# quotes the value, printed it raw
case_ "--set: a value with an escape sequence" 2 "model.example=a?[31mb|control character 0x1b" \
  model -c "$MQ" -o run-out --set $'model.example=a\e[31mb'
# geosynth inspect lists names and strings of the file: an object name with
# an escape sequence reached the terminal raw
$PY -c 'import h5py; f = h5py.File("escname.h5", "w"); f["a\x1b[2Jb"] = [1, 2]; f.attrs["note"] = "x\x1b]0;title\x07y"'
run_gs 0 inspect escname.h5
if LC_ALL=C grep -qP '[\x00-\x08\x0b-\x1f\x7f]' <<<"$out$err"; then
  bad "inspect: a control byte of the file reached the terminal"
elif grep -qF 'a?[2Jb' <<<"$out$err"; then
  ok "inspect: an object name with an escape sequence is listed as a?[2Jb (exit $rc)"
else
  bad "inspect: the object name is not listed (exit $rc): ${out:0:300} ${err:0:300}"
fi
case_ "micro CSV: probability above 1" 2 "badtable.csv:3|1.5" \
  micro -c "$UQ" -o run-out --set micro.dist=csv --set micro.table_csv=badtable.csv
case_ "PNG height map: truncated" 4 "cut.png" \
  field -c "$FQ" -o run-out --set example.kind=file --set example.path=cut.png
case_ "PNG: chunk name with an escape sequence, length past the end" 4 "escape.png|chunk '???J'|declares 1073741824 bytes" \
  field -c "$FQ" -o run-out --set example.kind=file --set example.path=escape.png
case_ "JPEG: Huffman table of 300 codes" 4 "dht.jpg|Huffman table at byte 6 declares 300 codes" \
  field -c "$FQ" -o run-out --set example.kind=file --set example.path=dht.jpg
case_ "HDF5 field example: not HDF5" 4 "text.h5|not an HDF5 file" \
  field -c "$FQ" -o run-out --set example.kind=file --set example.path=text.h5
case_ "HDF5 field example: declared, never written" 4 "regress-unwritten-1024cubed.h5|stores only 0 bytes" \
  field -c "$FQ" -o run-out --set example.kind=file --set "example.path=$GS_ROOT/tests/fuzz/corpus/h5example/regress-unwritten-1024cubed.h5"
case_ ".vdb example: not a VDB file" 4 "text.vdb|not a VDB file" \
  field -c "$FQ" -o run-out --set example.kind=file --set example.path=text.vdb
case_ ".vox example: truncated" 4 "cut.vox" \
  model -c "$MQ" -o run-out --set model.example=cut.vox
case_ "field target far beyond memory: refused before any large allocation" 5 "memory estimate per rank 393217 MiB|MiB are available|reduce field.target" \
  field -c "$FQ" -o run-out --set field.target=4096
case_ "resume: checkpoint that is not HDF5" 4 "checkpoint.h5|not an HDF5 file" \
  resume ckptdir
finish
