#!/usr/bin/python3
"""Points stacked over one another in a height-field run, from points.ply
alone: the share of points with another point within half a spacing in x y
that lies more than 4 spacings above or below it. A height field sampled
by dart throwing has almost none (points copied from the ridged example of
e2e/points_quality: 0.4%); walls and fins the blend or the strip
resampling leave standing over the sheet raise it.

  analysis/point_layers.py RUN_DIR [SPACING]   -> one JSON line

SPACING defaults to summary.json's input_spacing.
"""
import json
import sys

import numpy as np
from scipy.spatial import cKDTree

from point_seams import read_points


def stacked_share(v, spacing):
    pairs = cKDTree(v[:, :2]).query_pairs(0.5 * spacing, output_type="ndarray")
    if len(pairs) == 0:
        return 0.0
    far = pairs[np.abs(v[pairs[:, 0], 2] - v[pairs[:, 1], 2]) > 4 * spacing]
    hit = np.zeros(len(v), bool)
    hit[far.ravel()] = True
    return float(hit.mean())


def main():
    run = sys.argv[1]
    if len(sys.argv) > 2:
        spacing = float(sys.argv[2])
    else:
        spacing = json.load(open(run + "/summary.json"))["metrics"]["input_spacing"]
    v, _ = read_points(run + "/points.ply")
    print(json.dumps({"points": len(v), "spacing": spacing,
                      "stacked_share": stacked_share(v, spacing)}))


if __name__ == "__main__":
    main()
