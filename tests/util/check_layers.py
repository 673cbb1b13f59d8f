#!/usr/bin/env python3
"""The layers of src/ (docs/ARCHITECTURE.md, "Layers"), checked from the text.

    core (src/core, src/measure) -> par -> io (src/io, src/plugins) -> run -> engines -> cli

A file may include headers of its own layer or of layers below it, never above.
The engine folders (field, points, micro, model) are peers: one engine includes
no other engine's headers. plugins/plugin_api.h is private to src/io and
src/plugins. Outside src/par no code calls MPI (MPI_Xxx(...)); types and
constants (MPI_Comm, MPI_COMM_SELF) are fine. Every public header in
include/geosynth/ must be given a layer in HEADER_LAYER below, so a new header
is classified when it is added.

usage: check_layers.py [ROOT]   prints one line per violation; exit 1 if any.
"""
import os
import re
import sys

LAYERS = ["core", "par", "io", "run", "engines", "cli"]
RANK = {name: i for i, name in enumerate(LAYERS)}

FOLDER_LAYER = {
    "core": "core", "measure": "core",
    "par": "par",
    "io": "io", "plugins": "io",
    "run": "run",
    "field": "engines", "points": "engines", "micro": "engines", "model": "engines",
    "cli": "cli",
}
ENGINES = {"field", "points", "micro", "model"}

# include/geosynth/NAME -> (layer, engine folder that owns it or None)
HEADER_LAYER = {
    "config.h": ("core", None), "data.h": ("core", None), "digest.h": ("core", None),
    "error.h": ("core", None), "file.h": ("core", None), "json.h": ("core", None),
    "log.h": ("core", None), "mem.h": ("core", None), "parse.h": ("core", None),
    "rng.h": ("core", None), "version.h": ("core", None), "measure.h": ("core", None),
    "killpoint.h": ("core", None), "sort.h": ("core", None),
    "par.h": ("par", None), "partition.h": ("par", None), "psearch.h": ("par", None),
    "regions.h": ("par", None), "pmap.h": ("par", None),
    "h5.h": ("io", None), "image.h": ("io", None), "mesh.h": ("io", None),
    "plugin.h": ("io", None), "pointply.h": ("io", None), "preview.h": ("io", None),
    "render.h": ("io", None), "vdb.h": ("io", None), "vox.h": ("io", None),
    "glb.h": ("io", None),
    "run.h": ("run", None), "config_load.h": ("run", None), "engine.h": ("run", None),
    "field.h": ("engines", "field"), "field_examples.h": ("engines", "field"),
    "micro.h": ("engines", "micro"),
    "model.h": ("engines", "model"), "model_io.h": ("engines", "model"),
    "model_tiles.h": ("engines", "model"),
    "points.h": ("engines", "points"),
    "engines.h": ("cli", None),
}
PRIVATE = {"plugins/plugin_api.h": {"io", "plugins"}}

INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"', re.M)
MPI_CALL = re.compile(r"\bMPI_[A-Z][a-z_]*\s*\(")


def strip_comments_and_strings(text):
    """C text with comments and string literals blanked (line numbers kept)."""
    out, i, n = [], 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
        elif text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            out.append(" " * (j - i))
            i = j
        elif c in "\"'":
            j = i + 1
            while j < n and text[j] != c and text[j] != "\n":
                j += 2 if text[j] == "\\" else 1
            out.append(c + " " * (min(j, n) - i - 1) + (c if j < n else ""))
            i = j + 1
        else:
            out.append(c)
            i += 1
    return "".join(out)


def where(path, root):
    """(layer, engine folder or None, folder) of a source or public header."""
    rel = os.path.relpath(path, root)
    parts = rel.split(os.sep)
    if parts[0] == "include":
        layer, engine = HEADER_LAYER.get(parts[-1], (None, None))
        return layer, engine, None
    folder = parts[1]
    return FOLDER_LAYER.get(folder), folder if folder in ENGINES else None, folder


def target(inc, path, root):
    """(layer, engine, name) of an included file, or None for a file outside src/."""
    if inc.startswith("geosynth/"):
        name = inc.split("/", 1)[1]
        layer, engine = HEADER_LAYER.get(name, (None, None))
        return layer, engine, inc
    local = os.path.join(os.path.dirname(path), inc)
    for cand in (local, os.path.join(root, "src", inc)):
        if os.path.exists(cand):
            rel = os.path.relpath(cand, os.path.join(root, "src")).split(os.sep)
            folder = rel[0]
            return FOLDER_LAYER.get(folder), folder if folder in ENGINES else None, \
                "/".join(rel)
    return None


def check(root):
    problems = []
    files = []
    for sub in ("src", os.path.join("include", "geosynth")):
        for d, _, names in os.walk(os.path.join(root, sub)):
            files += [os.path.join(d, f) for f in sorted(names)
                      if f.endswith((".c", ".h", ".cpp"))]
    for path in sorted(files):
        rel = os.path.relpath(path, root)
        layer, engine, folder = where(path, root)
        if layer is None:
            problems.append(f"{rel}: no layer: add it to tests/util/check_layers.py")
            continue
        with open(path, encoding="utf-8", errors="replace") as f:
            text = f.read()
        code = strip_comments_and_strings(text)
        for m in INCLUDE.finditer(text):
            if code[m.start():m.end()].strip() == "":
                continue  # inside a comment
            line = text.count("\n", 0, m.start()) + 1
            t = target(m.group(1), path, root)
            if t is None:
                continue
            tl, te, name = t
            if tl is None:
                problems.append(f"{rel}:{line}: includes {m.group(1)}, which has no layer: "
                                "add it to tests/util/check_layers.py")
                continue
            if RANK[tl] > RANK[layer]:
                problems.append(f"{rel}:{line}: {layer} includes {m.group(1)} of the {tl} "
                                f"layer above it ({' -> '.join(LAYERS)})")
            elif tl == "engines" and layer == "engines" and te and engine and te != engine:
                problems.append(f"{rel}:{line}: engine {engine} includes {m.group(1)} of "
                                f"engine {te} (engines are peers)")
            if name in PRIVATE and folder not in PRIVATE[name]:
                problems.append(f"{rel}:{line}: includes {name}, private to "
                                f"{' and '.join('src/' + p for p in sorted(PRIVATE[name]))}")
        if folder != "par":
            for m in MPI_CALL.finditer(code):
                line = code.count("\n", 0, m.start()) + 1
                call = m.group(0).rstrip("( \t")
                problems.append(f"{rel}:{line}: calls {call} outside src/par "
                                "(use the collectives of include/geosynth/par.h)")
    for name in sorted(os.listdir(os.path.join(root, "include", "geosynth"))):
        if name.endswith(".h") and name not in HEADER_LAYER:
            pass  # reported above as "no layer"
    return problems, len(files)


def main():
    root = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..", "..")
    problems, n = check(os.path.abspath(root))
    for p in problems:
        print(p)
    print(f"check_layers: {n} files, {len(problems)} problems")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
