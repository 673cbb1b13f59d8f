#!/usr/bin/python3
"""Turns a campaign folder (or any folder of geosynth run directories) into a report.

    /usr/bin/python3 analysis/report.py CAMPAIGN_DIR [--bench bench-results/bench_field.json]
                                        [--out DIR]
    -> CAMPAIGN_DIR/report/index.html (+ PNG figures next to it)

Figures: strong scaling (wall seconds and speed-up vs ranks, per config),
per-phase seconds (stacked bars, max over ranks, per run), the matcher
comparison of a field benchmark JSON (--bench: tree vs brute force vs FFT
seconds per query, per query kind), micro target-vs-achieved histograms,
field slices, lattice slices and mesh renders (every face: geosynth's built-in
renderer via `geosynth preview`, $GEOSYNTH or bin/geosynth; matplotlib when it
cannot run), one of each per config (from its smallest rank count). Then a
table of runs: config, ranks, seed, wall, slowest phase, peak memory, digest
and whether the digest agrees with every other run of the same config (the
determinism contract across rank counts). Reads only summary.json,
metrics.jsonl, the HDF5/PLY outputs and the benchmark JSON (analysis/gsio.py).
Exit 0, or 1 when a digest disagrees or there are no runs.
"""
import argparse
import html
import os
import subprocess
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import gsio  # noqa: E402

DPI = 90


def save(fig, out, name):
    path = os.path.join(out, name)
    fig.savefig(path, dpi=DPI, bbox_inches="tight")
    plt.close(fig)
    return name


def safe(s):
    return "".join(c if c.isalnum() or c in "-_" else "_" for c in s)


def groups_by_config(runs):
    """[(label, [runs sorted by ranks])] for comparable groups."""
    res = []
    for members in gsio.comparable_groups(runs):
        members.sort(key=lambda r: r.get("ranks", 0))
        label = members[0]["_config_name"]
        seeds = {m.get("seed") for m in members}
        if len(seeds) == 1:
            label += f" seed {members[0].get('seed')}"
        res.append((label, members))
    res.sort(key=lambda g: g[0])
    return res


def fig_scaling(groups, out):
    multi = [(l, m) for l, m in groups if len({r.get("ranks") for r in m}) > 1]
    if not multi:
        return None
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4))
    maxnp = 1
    for label, members in multi:
        nps = [r.get("ranks", 1) for r in members]
        wall = [r.get("wall_seconds", 0) for r in members]
        maxnp = max(maxnp, max(nps))
        a1.plot(nps, wall, "o-", label=label)
        a2.plot(nps, [wall[0] / w * nps[0] if w else 0 for w in wall], "o-", label=label)
    a2.plot([1, maxnp], [1, maxnp], "k--", lw=0.8, label="ideal")
    for a in (a1, a2):
        a.set_xscale("log", base=2)
        a.set_xlabel("MPI ranks")
        a.grid(alpha=0.3)
    a1.set_yscale("log")
    a1.set_ylabel("wall seconds")
    a1.set_title("strong scaling: time")
    a2.set_ylabel(f"speed-up (x smallest rank count)")
    a2.set_title("strong scaling: speed-up")
    a2.legend(fontsize=7)
    return save(fig, out, "scaling.png")


def fig_phases(runs, out):
    names = []
    for r in runs:
        for p, _ in gsio.phase_seconds(r):
            if p not in names:
                names.append(p)
    if not names:
        return None
    fig, ax = plt.subplots(figsize=(max(6, 0.5 * len(runs) + 2), 4.5))
    x = np.arange(len(runs))
    bottom = np.zeros(len(runs))
    for p in names:
        v = np.array([dict(gsio.phase_seconds(r)).get(p, 0.0) for r in runs])
        ax.bar(x, v, bottom=bottom, label=p)
        bottom += v
    ax.set_xticks(x)
    ax.set_xticklabels([f"{r['_config_name']} np{r.get('ranks')} s{r.get('seed')}" for r in runs],
                       rotation=60, ha="right", fontsize=7)
    ax.set_ylabel("seconds (max over ranks)")
    ax.set_title("time per phase")
    ax.legend(fontsize=8)
    return save(fig, out, "phases.png")


def fig_matcher(bench, out):
    cases = gsio.read_bench_field(bench)
    if not cases:
        return None
    fig, axes = plt.subplots(1, len(cases), figsize=(5.5 * len(cases), 4), squeeze=False)
    for ax, (label, queries) in zip(axes[0], cases):
        kinds = list(queries)
        x = np.arange(len(kinds))
        for i, (key, name) in enumerate([("tree_s", "search tree"), ("brute_s", "brute force"),
                                          ("fft_s", "FFT")]):
            v = [queries[k].get(key, 0) or np.nan for k in kinds]
            ax.bar(x + (i - 1) * 0.27, v, 0.27, label=name)
        ax.set_xticks(x)
        ax.set_xticklabels(kinds, rotation=40, ha="right", fontsize=8)
        ax.set_yscale("log")
        ax.set_ylabel("seconds per query")
        ax.set_title(f"matchers: {label}")
        ax.legend(fontsize=7)
    return save(fig, out, "matchers.png")


def fig_micro(run, out):
    hists = gsio.micro_histograms(run)[:3]
    if not hists:
        return None
    fig, axes = plt.subplots(1, len(hists), figsize=(5 * len(hists), 3.5), squeeze=False)
    for ax, (inst, target, achieved, nneg, realized) in zip(axes[0], hists):
        x = np.arange(len(target)) - nneg
        n = max(1, np.sum(target))
        if realized is not None:
            ax.bar(x - 0.2, target, 0.4, label="target")
            ax.bar(x + 0.2, realized, 0.4, label="realized (true distance)")
            ax.step(x, achieved, where="mid", color="k", lw=0.7, label="labels assigned")
            err = np.abs(np.asarray(target) - np.asarray(realized)).sum() / n
            title = f"{inst}: realized L1/n = {err:.3f}"
        else:
            ax.bar(x - 0.2, target, 0.4, label="target")
            ax.bar(x + 0.2, achieved, 0.4, label="achieved")
            err = np.abs(np.asarray(target) - np.asarray(achieved)).sum() / n
            title = f"{inst}: sum |target - achieved| / target = {err:.3f}"
        ax.axvline(-0.5, color="k", lw=0.6)
        ax.set_xlabel("signed distance bin (< 0: negative region)")
        ax.set_ylabel("triangles")
        ax.set_title(title, fontsize=9)
        ax.legend(fontsize=7)
    fig.suptitle(f"{run['_config_name']}: contact histograms", fontsize=10)
    return save(fig, out, f"micro_{safe(run['_dir'])}.png")


def fig_field(run, out):
    vol = gsio.field_volume(run)
    if vol is None:
        return None
    nz, ny, nx = vol.shape
    lim = float(np.percentile(np.abs(vol), 95)) or 1.0
    fig, axes = plt.subplots(1, 3, figsize=(13, 4))
    for ax, (img, t) in zip(axes, [(vol[nz // 2], f"z = {nz // 2}"), (vol[:, ny // 2], f"y = {ny // 2}"),
                                   (vol[:, :, nx // 2], f"x = {nx // 2}")]):
        im = ax.imshow(img, origin="lower", cmap="RdBu", vmin=-lim, vmax=lim)
        ax.contour(img, [0.0], colors="k", linewidths=0.8)
        ax.set_title(t)
    fig.colorbar(im, ax=axes, shrink=0.8, label="distance (samples)")
    fig.suptitle(f"{run['_config_name']}: field slices ({nx}x{ny}x{nz})", fontsize=10)
    return save(fig, out, f"field_{safe(run['_dir'])}.png")


def fig_lattice(run, out):
    lat = gsio.model_lattice(run)
    if lat is None:
        return None
    nz = lat.shape[0]
    zs = sorted({0, nz // 3, (2 * nz) // 3, nz - 1})
    fig, axes = plt.subplots(1, len(zs), figsize=(3.6 * len(zs), 3.8), squeeze=False)
    vmax = max(1, int(lat.max()))
    for ax, z in zip(axes[0], zs):
        ax.imshow(lat[z], origin="lower", cmap="tab20", vmin=0, vmax=vmax, interpolation="nearest")
        ax.set_title(f"z = {z}")
    fig.suptitle(f"{run['_config_name']}: lattice slices {lat.shape[2]}x{lat.shape[1]}x{nz} "
                 f"({len(np.unique(lat))} labels)", fontsize=10)
    return save(fig, out, f"lattice_{safe(run['_dir'])}.png")


def fig_mesh(run, out):
    """The run's first mesh, every face drawn: rendered by geosynth's built-in
    renderer (`geosynth preview`, $GEOSYNTH or bin/geosynth), else by
    matplotlib. Returns (figure file, faces in the file, faces drawn) or None."""
    meshes = gsio.mesh_outputs(run)
    if not meshes:
        return None
    path = meshes[0]
    v, f = gsio.read_mesh(path)
    if v is None or f is None or len(f) == 0:
        return None
    nfaces = gsio.mesh_face_count(path)  # polygons of a model mesh count once (f has them fanned)
    name = f"mesh_{safe(run['_dir'])}.png"
    exe = os.environ.get("GEOSYNTH") or os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "bin", "geosynth")
    try:
        r = subprocess.run([exe, "-q", "preview", "--out", os.path.join(out, name), "--size", "512", path],
                           capture_output=True, text=True, timeout=600)
        if r.returncode == 0 and os.path.getsize(os.path.join(out, name)) > 0:
            return name, nfaces, nfaces
        gsio.warn(f"{path}: geosynth preview failed ({r.stderr.strip()[:200]}); drawing with matplotlib")
    except OSError as e:
        gsio.warn(f"{path}: no geosynth to render with ({e}); drawing with matplotlib")
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection
    tri = v[f[:, :3]]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True) + 1e-12
    light = np.array([0.4, -0.5, 0.77])
    shade = 0.25 + 0.75 * np.abs(n @ light)
    fig = plt.figure(figsize=(6, 5.5))
    ax = fig.add_subplot(projection="3d")
    pc = Poly3DCollection(v[f], facecolors=plt.cm.bone(0.35 + 0.6 * shade), edgecolors="none")
    ax.add_collection3d(pc)
    lo, hi = v.min(axis=0), v.max(axis=0)
    c, r = (lo + hi) / 2, (hi - lo).max() / 2
    ax.set_xlim(c[0] - r, c[0] + r)
    ax.set_ylim(c[1] - r, c[1] + r)
    ax.set_zlim(c[2] - r, c[2] + r)
    ax.view_init(elev=30, azim=-60)
    ax.set_axis_off()
    ax.set_title(f"{run['_config_name']}: {os.path.basename(path)}\n{nfaces} faces", fontsize=9)
    return save(fig, out, name), nfaces, nfaces


PAGE = """<!DOCTYPE html>
<html><head><meta charset="utf-8"><title>geosynth campaign report: {title}</title>
<style>
body {{ font-family: sans-serif; margin: 1.5em; }}
table {{ border-collapse: collapse; font-size: 0.85em; }}
td, th {{ border: 1px solid #bbb; padding: 2px 6px; text-align: right; }}
td.l, th.l {{ text-align: left; }}
.bad {{ background: #f8c0c0; }} .good {{ background: #d0f0d0; }}
figure {{ display: inline-block; margin: 0.5em; vertical-align: top; }}
img {{ max-width: 100%; border: 1px solid #ddd; }}
</style>
<script>
// Marks each figure loaded or not (for people and for tests/e2e/report.sh,
// which reads these attributes from headless Chromium's DOM).
function gsMarkImages() {{
  var imgs = document.images, n = 0;
  for (var i = 0; i < imgs.length; i++) {{
    var ok = imgs[i].complete && imgs[i].naturalWidth > 0;
    imgs[i].setAttribute("data-loaded", ok ? "yes" : "no");
    if (ok) n++;
  }}
  document.body.setAttribute("data-images", n + "/" + imgs.length);
}}
window.addEventListener("load", gsMarkImages);
</script>
</head><body>
<h1>geosynth campaign report: {title}</h1>
<p>{summary}</p>
<h2>Runs</h2>
<table id="runs">
<tr><th class="l">run</th><th class="l">config</th><th class="l">engine</th><th>np</th><th>seed</th>
<th>wall s</th><th class="l">slowest phase</th><th>peak MiB</th><th class="l">digest</th>
<th class="l">digest agrees</th></tr>
{rows}
</table>
{micro}
<h2>Figures</h2>
{figures}
</body></html>
"""


def table_rows(runs, agree):
    rows = []
    for r in runs:
        ph = gsio.phase_seconds(r)
        slow = max(ph, key=lambda p: p[1]) if ph else ("", 0)
        a = agree.get(id(r))
        cls, txt = ("", "alone") if a is None else (("good", "yes") if a else ("bad", "NO"))
        rows.append(
            f'<tr class="run"><td class="l">{html.escape(r["_dir"])}</td>'
            f'<td class="l">{html.escape(r["_config_name"])}</td><td class="l">{html.escape(str(r.get("engine")))}</td>'
            f'<td>{r.get("ranks", "")}</td><td>{r.get("seed", "")}</td>'
            f'<td>{r.get("wall_seconds", 0):.2f}</td><td class="l">{html.escape(slow[0])} {slow[1]:.2f} s</td>'
            f'<td>{r.get("mem_peak_bytes", 0) / 2**20:.1f}</td><td class="l"><code>{html.escape(str(r.get("digest")))}</code></td>'
            f'<td class="l {cls}">{txt}</td></tr>')
    return "\n".join(rows)


def micro_coast(run):
    """Outline of the first instance's islands, from its mesh.ply alone
    (analysis/micro_outline.py): 'measured / ideal (islands)', the
    area-weighted perimeter / 2 pi r of the positive regions other than the
    surrounding one against ideal discs of their areas drawn on the same
    mesh; '-' without such regions or a readable mesh.ply."""
    plys = [p for p in gsio.outputs(run, "mesh", "instance") if p.endswith(".ply")]
    if not plys:
        return "-"
    import micro_outline
    try:
        v, f, _, vl = micro_outline.load(os.path.dirname(plys[0]))
    except (OSError, KeyError, ValueError) as e:
        gsio.warn(f"{plys[0]}: no outline ({e})")
        return "-"
    regions, specks = micro_outline.discs(v, f, vl)
    sm = micro_outline.summary(regions, specks)["positive"]
    if not sm["count"]:
        return "-"
    return f'{sm["perimeter_ratio"]:.3f} / {sm["ideal_ratio"]:.3f} ({sm["count"]})'


def micro_table(runs):
    """Realized contact distribution of the micro runs (summary.json metrics:
    true geodesic distance of each triangle to the region interface against
    the target; src/measure/geodesic.c) and their islands' outline
    (micro_coast)."""
    rows = []
    for r in runs:
        m = r.get("metrics", {})
        if r.get("engine") != "micro" or "realized_l1" not in m:
            continue
        rows.append(f'<tr><td class="l">{html.escape(r["_dir"])}</td><td class="l">{html.escape(r["_config_name"])}</td>'
                    f'<td>{m.get("triangles", 0)}</td><td>{m["realized_l1"]:.4f}</td>'
                    f'<td>{m.get("realized_l1_max", 0):.4f}</td><td>{100 * m.get("unassigned_share", m.get("unassigned_share_max", 0)):.3f}%</td>'
                    f'<td>{html.escape(micro_coast(r))}</td></tr>')
    if not rows:
        return ""
    return ("<h2>Contact distributions (micro)</h2>\n<p>realized L1/n: sum over the signed bins of |realized - target| "
            "divided by the triangle count, where realized is each triangle's true geodesic distance to the "
            "interface between the regions (the side of its label), histogrammed like the target. Islands: "
            "the first instance's positive regions of at least 100 units^2 other than the surrounding one, "
            "from its mesh.ply's vertex labels: area-weighted perimeter / 2 pi r (r: the radius of a disc of "
            "the same area) / the same for ideal discs of those areas drawn on the same mesh (above 1 from "
            "the staircase of its edges) (count); round coasts come close to the ideal.</p>\n"
            '<table id="micro"><tr><th class="l">run</th><th class="l">config</th><th>triangles</th>'
            "<th>realized L1/n</th><th>worst instance</th><th>unassigned</th><th>islands: perimeter / 2 pi r, "
            "measured / ideal (count)</th></tr>\n" + "\n".join(rows) + "\n</table>")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("campaign")
    ap.add_argument("--bench", help="field benchmark JSON (tests/bench: bench-results/bench_field.json)")
    ap.add_argument("--out", help="report directory (default CAMPAIGN/report)")
    args = ap.parse_args()
    runs = gsio.load_runs(args.campaign)
    if not runs:
        print(f"report: no summary.json under {args.campaign}", file=sys.stderr)
        return 1
    out = args.out or os.path.join(args.campaign, "report")
    os.makedirs(out, exist_ok=True)
    agree = gsio.digest_agreement(runs)
    groups = groups_by_config(runs)
    figs = []  # (file, caption)

    def add(name, caption):
        if name:
            figs.append((name, caption))

    add(fig_scaling(groups, out), "Strong scaling: wall seconds and speed-up against ranks, per config.")
    add(fig_phases(runs, out), "Seconds per phase (max over ranks) of every run.")
    if args.bench:
        add(fig_matcher(args.bench, out), f"Matcher comparison from {os.path.basename(args.bench)}.")
    for label, members in groups:
        r = members[0]
        engine = r.get("engine")
        try:
            if engine == "micro":
                add(fig_micro(r, out), f"{label}: target vs realized contact histograms (realized: each "
                    "triangle's true geodesic distance to the region interface; the line: the labels "
                    "the reconstruction assigned).")
            if engine == "field":
                add(fig_field(r, out), f"{label}: orthogonal slices of the synthesized distance field.")
            if engine == "model":
                add(fig_lattice(r, out), f"{label}: slices of the label lattice.")
            m = fig_mesh(r, out)
            if m:
                add(m[0], f"{label}: output mesh ({r['_dir']}), {m[2]} of {m[1]} faces drawn.")
        except (OSError, ValueError, KeyError) as e:
            gsio.warn(f"{r['_dir']}: {e}")
    nbad = sum(1 for v in agree.values() if v is False)
    summary = (f"{len(runs)} runs, {len(groups)} configs, {len(figs)} figures; "
               + (f"<b>{nbad} runs disagree on the digest</b>" if nbad
                  else "digests agree across rank counts wherever a config ran more than once"))
    figures = "\n".join(f'<figure><img src="{html.escape(n)}" alt="{html.escape(c)}">'
                        f"<figcaption>{html.escape(c)}</figcaption></figure>" for n, c in figs)
    page = PAGE.format(title=html.escape(os.path.basename(os.path.abspath(args.campaign))),
                       summary=summary, rows=table_rows(runs, agree), figures=figures, micro=micro_table(runs))
    index = os.path.join(out, "index.html")
    with open(index, "w") as f:
        f.write(page)
    print(f"report: {index} ({len(runs)} runs, {len(figs)} figures)")
    return 1 if nbad else 0


if __name__ == "__main__":
    sys.exit(main())
