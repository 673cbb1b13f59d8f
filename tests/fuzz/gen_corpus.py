#!/usr/bin/python3
"""Seed corpora of the file-format fuzz targets added for #25 item 5:
pointply, lattice, tileset, table, image (tests/fuzz/corpus/NAME/).

    /usr/bin/python3 tests/fuzz/gen_corpus.py     # rewrites those folders' gen-* files

Seeds are small on purpose (libFuzzer's -max_len defaults to the largest
seed): a few hundred bytes each. The h5example and vdb seeds are files
written by geosynth itself (see tests/fuzz/corpus/README.md). Needs numpy
and Pillow (the JPEG/PNG seeds)."""
import io
import os
import struct
import sys

import numpy as np
from PIL import Image

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "corpus")


def put(target, name, data):
    d = os.path.join(ROOT, target)
    os.makedirs(d, exist_ok=True)
    if isinstance(data, str):
        data = data.encode()
    with open(os.path.join(d, "gen-" + name), "wb") as f:
        f.write(data)


# ---- point-set PLY: first byte bit 0 = normals required --------------------
CUBE = [(x, y, z) for x in (0, 1) for y in (0, 1) for z in (0, 1)]


def ply_points(fmt, typ, normals, extra_face=False, prefix=b"\x01"):
    props = ["x", "y", "z"] + (["nx", "ny", "nz"] if normals else [])
    head = "ply\nformat %s 1.0\ncomment seed\nelement vertex %d\n" % (fmt, len(CUBE))
    head += "".join("property %s %s\n" % (typ, p) for p in props)
    if extra_face:
        head += "element face 1\nproperty list uchar int vertex_indices\n"
    head += "end_header\n"
    body = b""
    for p in CUBE:
        n = [c - 0.5 for c in p]
        vals = list(p) + (n if normals else [])
        if fmt == "ascii":
            body += (" ".join(repr(float(v)) for v in vals) + "\n").encode()
        else:
            e = "<" if fmt == "binary_little_endian" else ">"
            c = {"float": "f", "double": "d"}[typ]
            body += struct.pack(e + c * len(vals), *vals)
    if extra_face:
        if fmt == "ascii":
            body += b"3 0 1 2\n"
        else:
            e = "<" if fmt == "binary_little_endian" else ">"
            body += struct.pack(e + "Biii", 3, 0, 1, 2)
    return prefix + head.encode() + body


put("pointply", "ascii_normals", ply_points("ascii", "float", True))
put("pointply", "ascii_no_normals", ply_points("ascii", "float", False, prefix=b"\x00"))
put("pointply", "le_float", ply_points("binary_little_endian", "float", True))
put("pointply", "be_double", ply_points("binary_big_endian", "double", True))
put("pointply", "le_face", ply_points("binary_little_endian", "float", True, extra_face=True))
put("pointply", "ascii_face", ply_points("ascii", "double", True, extra_face=True))
put("pointply", "normal_x_names", b"\x01" + b"ply\nformat ascii 1.0\nelement vertex 2\n"
    b"property double x\nproperty double y\nproperty double z\nproperty float normal_x\n"
    b"property float normal_y\nproperty float normal_z\nproperty uchar red\nend_header\n"
    b"0 0 0 0 0 1 255\n1 0 0 0 0 2 7\n")

# ---- lattices: first byte even = Merrell .txt, odd = DeBroglie .csv --------
rng = np.random.default_rng(25)
for name, (X, Y, Z) in {"2x3x2": (2, 3, 2), "4x4x1": (4, 4, 1), "1x1x1": (1, 1, 1)}.items():
    lab = rng.integers(0, 4, size=(Z, X, Y))
    txt = "castle\nseed\nfree line\n%d %d %d\n" % (X, Y, Z)
    txt += "\n".join(" ".join(str(v) for v in lab[z].ravel()) for z in range(Z)) + "\n"
    put("lattice", "txt_" + name, b"\x00" + txt.encode())
    csv = "\n\n".join("\n".join(", ".join(str(v) for v in row) for row in lab[z])
                      for z in range(Z)) + "\n"
    put("lattice", "csv_" + name, b"\x01" + csv.encode())
put("lattice", "txt_objects", b"\x00a\nb\nc\n2 1 1\n1 2\n<Objects>\n1 0 0 0\n")
put("lattice", "csv_crlf_blank", b"\x01\r\n1,2\r\n3,4\r\n\r\n\r\n0,1\r\n1,0\r\n\r\n")
put("lattice", "txt_big_label", b"\x00h\nh\nh\n1 2 1\n65535 0\n")
# 4D (geosynth's fourth extent, frames): 2x2x1 in 3 frames
put("lattice", "txt_4d_2x2x1x3", b"\x00a\nb\nc\n2 2 1 3\n1 0\n0 1\n\n0 1\n1 0\n\n1 1\n0 0\n")

# ---- tile sets: byte 0 bit 0 json, bit 1 images, bit 2 subset "s" ----------
MX = """<set size="2">
<tiles>
<tile name="A" symmetry="X" weight="2.0"/>
<tile name="B" symmetry="T"/>
<tile name="C" symmetry="L" weight="0.5"/>
</tiles>
<neighbors>
<neighbor left="A" right="A"/>
<neighbor left="A" right="B 1"/>
<neighbor left="B" right="C 2"/>
<neighbor left="C 3" right="C"/>
</neighbors>
<subsets>
<subset name="s"><tile name="A"/><tile name="B"/></subset>
</subsets>
</set>
"""
put("tileset", "mxgmn", b"\x00" + MX.encode())
put("tileset", "mxgmn_images", b"\x02" + MX.encode())
put("tileset", "mxgmn_subset", b"\x06" + MX.encode())
put("tileset", "mxgmn_unique", b"\x02" + b"""<?xml version="1.0"?>
<!-- comment -->
<set unique="True">
<tiles><tile name="A" symmetry="I"/><tile name="B" symmetry="\\"/></tiles>
<neighbors><neighbor left="A 1" right="B"/><neighbor left="B 1" right="A &amp; "/></neighbors>
</set>
""")
MJ = """<tileset fullSymmetry="%s">
  <tiles>
    <tile name="A"/>
    <tile name="B" weight="0.5"/>
    <tile name="C"/>
  </tiles>
  <neighbors>
    <neighbor left="A" right="A"/>
    <neighbor left="A" right="B"/>
    <neighbor left="y B" right="zz C"/>
    <neighbor left="C" right="x A"/>
  </neighbors>
</tileset>
"""
put("tileset", "mj_full", b"\x00" + (MJ % "True").encode())
put("tileset", "mj_plain", b"\x00" + (MJ % "False").encode())
put("tileset", "debroglie", b"\x01" + b"""{
  "srcType": "voxSet",
  "symmetry": 8,
  // a comment
  "tiles": [
    {"src": "A.vox", "value": "a", "tileSymmetry": "X"},
    {"src": "B.vox", "value": "b", "tileSymmetry": "L", "multiplyFrequency": 0.3},
    {"src": "C.vox", "value": "c"},
  ],
  "autoAdjacency": true,
  "adjacencies": [
    {"left": ["a"], "right": ["b", "c"]},
    {"above": ["a"], "below": ["c"]}
  ]
}
""")

# ---- micro tables ------------------------------------------------------------
put("table", "header", "# comment\nbin,positive,negative\n0,0.3,0.3\n1,0.2,0.1\n2,0,0.1\n")
put("table", "plain", "0, 0.5, 0.25\n1, 0.5, 0.75\n")
put("table", "crlf_blank", "bin,pos,neg\r\n\r\n0,1e-1,0.4\r\n1,4E-1,0.1\r\n")
put("table", "sums_one_each", "0,1,1\n")

# ---- images -------------------------------------------------------------------
def png(arr, mode=None, **kw):
    b = io.BytesIO()
    Image.fromarray(arr, mode).save(b, "PNG", **kw)
    return b.getvalue()


g = (np.arange(36).reshape(6, 6) * 7 % 256).astype(np.uint8)
put("image", "grey8.png", png(g))
put("image", "grey16.png", png((g.astype(np.uint16) * 257).astype(np.uint16), "I;16"))
put("image", "rgb.png", png(np.stack([g, g[::-1], 255 - g], -1)))
put("image", "rgba.png", png(np.stack([g, g, g, g], -1)))
put("image", "la.png", png(np.stack([g, 255 - g], -1), "LA"))
put("image", "bw.png", png(((g > 100) * 255).astype(np.uint8)))
pal = Image.fromarray(np.stack([g, g[::-1], 255 - g], -1)).convert("P", palette=Image.ADAPTIVE, colors=4)
b = io.BytesIO()
pal.save(b, "PNG")
put("image", "palette.png", b.getvalue())
for prog in (False, True):
    b = io.BytesIO()
    Image.fromarray(np.stack([g, g[::-1], 255 - g], -1)).save(b, "JPEG", quality=80, progressive=prog)
    put("image", "progressive.jpg" if prog else "baseline.jpg", b.getvalue())
b = io.BytesIO()
Image.fromarray(g).save(b, "JPEG", quality=90)
put("image", "grey.jpg", b.getvalue())
print("corpora written under", ROOT)
