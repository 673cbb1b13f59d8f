#!/usr/bin/python3
"""Every key in a config file gets a comment: checks, or adds the missing ones.

    scripts/config-comments.py --check FILE.ini...   list keys without a comment; exit 1 if any
    scripts/config-comments.py --fix FILE.ini...     add the missing comments in place

A key is documented when its line has an inline comment (" ; ..." or " # ...")
or the line right above it is a comment line. --fix inserts, above each
undocumented key, the key's help line from the program itself (the resolved
config of `geosynth ENGINE -c FILE --check`, i.e. `geosynth help ENGINE`),
with the file's comment character and the default. ENGINE is the name of the
file's directory (configs/ENGINE/) unless --engine is given. tests/e2e/configs.sh
runs --check over configs/.
"""
import argparse
import os
import re
import subprocess
import sys

KEY = re.compile(r"^\s*([A-Za-z0-9_.]+)\s*[=:]")
SECTION = re.compile(r"^\s*\[([^\]]+)\]")


def is_comment(line):
    return line.lstrip().startswith((";", "#"))


def has_inline_comment(line):
    return re.search(r"\s[;#]", line.split("=", 1)[-1] if "=" in line else line) is not None


def undocumented(lines):
    """[(line index, section.key)] of keys without a comment."""
    res, section = [], ""
    for i, line in enumerate(lines):
        m = SECTION.match(line)
        if m:
            section = m.group(1).strip()
            continue
        if is_comment(line) or not line.strip():
            continue
        k = KEY.match(line)
        if not k:
            continue
        if has_inline_comment(line) or (i > 0 and is_comment(lines[i - 1])):
            continue
        res.append((i, f"{section}.{k.group(1)}"))
    return res


def help_comments(geosynth, engine, path):
    """{section.key: help text (default X)} from the resolved config."""
    out = subprocess.run([geosynth, engine, "-c", path, "--check"], capture_output=True, text=True)
    if out.returncode != 0:
        raise RuntimeError(f"{path}: geosynth {engine} --check failed:\n{out.stderr}")
    helps, section, last = {}, "", None
    for line in out.stdout.splitlines():
        m = SECTION.match(line)
        if m:
            section = m.group(1)
        elif line.startswith("#"):
            last = line[1:].strip()
        elif KEY.match(line) and last:
            text = last
            d = re.search(r" \((a |an |one |true |text)[^;]*; default:? (.*)\)$", text)
            if d:
                default = d.group(2).strip()
                text = text[:d.start()] + (f" (default {default})" if len(default) <= 24 else "")
            helps[f"{section}.{KEY.match(line).group(1)}"] = text
            last = None
    return helps


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    g = ap.add_mutually_exclusive_group(required=True)
    g.add_argument("--check", action="store_true")
    g.add_argument("--fix", action="store_true")
    ap.add_argument("--engine")
    ap.add_argument("--geosynth", default=os.environ.get("GS_BIN", "bin/geosynth"))
    ap.add_argument("files", nargs="+")
    args = ap.parse_args()
    bad = 0
    for path in args.files:
        with open(path) as f:
            lines = f.read().splitlines()
        missing = undocumented(lines)
        if args.check:
            for i, key in missing:
                print(f"{path}:{i + 1}: {key} has no comment")
            bad += len(missing)
            continue
        if not missing:
            continue
        engine = args.engine or os.path.basename(os.path.dirname(os.path.abspath(path)))
        helps = help_comments(args.geosynth, engine, path)
        ch = next((l.lstrip()[0] for l in lines if is_comment(l)), "#")
        for i, key in reversed(missing):
            text = helps.get(key)
            if not text:
                print(f"{path}:{i + 1}: {key}: no help text found", file=sys.stderr)
                bad += 1
                continue
            indent = lines[i][:len(lines[i]) - len(lines[i].lstrip())]
            lines.insert(i, f"{indent}{ch} {text}")
        with open(path, "w") as f:
            f.write("\n".join(lines) + "\n")
        print(f"{path}: {len(missing)} comments added")
    if args.check and bad:
        print(f"{bad} keys without a comment", file=sys.stderr)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
