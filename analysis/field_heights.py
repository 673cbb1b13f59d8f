#!/usr/bin/python3
"""Height distribution of a height-field run, from field.h5 alone
(/field/levels, /source/levels): how common the example's low and high ground
is in the output (#19: terrain.ini's outputs held the example's highest ground
about half as often as the example).

  analysis/field_heights.py RUN_DIR...   -> one JSON line per run

The same figures as summary.json's height_* (src/measure/heights.c,
gs_measure_heights): the surface height of every column (field_repeats.py's
heights: the highest inside-to-outside crossing of the levels), the example's
heights at its 10th, 90th, 95th and 99th percentiles (numpy's linear
interpolation), the share of the output and of the example at or below the
10th (below_p10_*) and at or above the others (above_pNN_*), and the
two-sample Kolmogorov-Smirnov distance of the two height sets (ks).
"""
import json
import sys

import h5py
import numpy as np

from field_repeats import heights

PERCENTILES = (10, 90, 95, 99)


def ks(a, b):
    a = np.sort(a.ravel())
    b = np.sort(b.ravel())
    x = np.concatenate([a, b])
    fa = np.searchsorted(a, x, "right") / a.size
    fb = np.searchsorted(b, x, "right") / b.size
    return float(np.abs(fa - fb).max())


def measure(out, src):
    lv = [float(np.percentile(src, p)) for p in PERCENTILES]
    r = {"levels": lv}
    for name, h in (("out", out), ("src", src)):
        r["below_p10_" + name] = float((h <= lv[0]).mean())
        for p, t in zip(PERCENTILES[1:], lv[1:]):
            r["above_p%d_%s" % (p, name)] = float((h >= t).mean())
    r["ks"] = ks(out, src)
    return r


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    for run in sys.argv[1:]:
        with h5py.File(run + "/field.h5", "r") as f:
            h = {}
            for k, name in (("out", "/field/levels"), ("src", "/source/levels")):
                d = f[name]
                h[k] = heights(d[...], d.attrs["lo"], d.attrs["hi"])
        r = measure(h["out"], h["src"])
        r["run"] = run
        print(json.dumps(r))


if __name__ == "__main__":
    main()
