#!/usr/bin/python3
"""A small JSON Schema (draft 2020-12) validator for the keywords geosynth's
schemas use: type, enum, const, required, properties, additionalProperties,
propertyNames, items, minItems, maxItems, minimum, minLength, pattern, not,
allOf, if/then, $ref (#/$defs/...). Any other keyword is refused, so a schema
cannot silently ask for a check this validator does not make.

usage: json_schema.py SCHEMA.json FILE.json...   (exit 1 naming every violation)
"""
import json
import re
import sys

KNOWN = {"$schema", "$id", "title", "description", "$defs", "type", "enum", "const",
         "required", "properties", "additionalProperties", "propertyNames", "items",
         "minItems", "maxItems", "minimum", "minLength", "pattern", "not", "allOf",
         "if", "then", "$ref"}

TYPES = {
    "object": lambda v: isinstance(v, dict),
    "array": lambda v: isinstance(v, list),
    "string": lambda v: isinstance(v, str),
    "boolean": lambda v: isinstance(v, bool),
    "integer": lambda v: isinstance(v, int) and not isinstance(v, bool),
    "number": lambda v: isinstance(v, (int, float)) and not isinstance(v, bool),
    "null": lambda v: v is None,
}


def validate(v, s, root, where="$"):
    """[error text] of value v against schema s."""
    errs = []
    unknown = set(s) - KNOWN
    if unknown:
        raise ValueError("schema at %s uses unsupported keywords %s" % (where, sorted(unknown)))
    if "$ref" in s:
        ref = s["$ref"]
        if not ref.startswith("#/$defs/"):
            raise ValueError("unsupported $ref %s" % ref)
        errs += validate(v, root["$defs"][ref[len("#/$defs/"):]], root, where)
    if "type" in s:
        types = s["type"] if isinstance(s["type"], list) else [s["type"]]
        if not any(TYPES[t](v) for t in types):
            return errs + ["%s: %r is not of type %s" % (where, v, "/".join(types))]
    if "enum" in s and v not in s["enum"]:
        errs.append("%s: %r is not one of %s" % (where, v, s["enum"]))
    if "const" in s and v != s["const"]:
        errs.append("%s: %r is not %r" % (where, v, s["const"]))
    if isinstance(v, str):
        if "pattern" in s and not re.search(s["pattern"], v):
            errs.append("%s: %r does not match %s" % (where, v, s["pattern"]))
        if len(v) < s.get("minLength", 0):
            errs.append("%s: %r is shorter than %d" % (where, v, s["minLength"]))
    if TYPES["number"](v) and "minimum" in s and v < s["minimum"]:
        errs.append("%s: %r is below %r" % (where, v, s["minimum"]))
    if isinstance(v, dict):
        for k in s.get("required", []):
            if k not in v:
                errs.append("%s: required key '%s' missing" % (where, k))
        props = s.get("properties", {})
        for k, x in v.items():
            if "propertyNames" in s:
                errs += validate(k, s["propertyNames"], root, "%s[key %r]" % (where, k))
            if k in props:
                errs += validate(x, props[k], root, "%s.%s" % (where, k))
            elif s.get("additionalProperties") is False:
                errs.append("%s: key '%s' is not allowed" % (where, k))
            elif isinstance(s.get("additionalProperties"), dict):
                errs += validate(x, s["additionalProperties"], root, "%s.%s" % (where, k))
    if isinstance(v, list):
        if len(v) < s.get("minItems", 0):
            errs.append("%s: %d items, at least %d expected" % (where, len(v), s["minItems"]))
        if "maxItems" in s and len(v) > s["maxItems"]:
            errs.append("%s: %d items, at most %d expected" % (where, len(v), s["maxItems"]))
        if "items" in s:
            for i, x in enumerate(v):
                errs += validate(x, s["items"], root, "%s[%d]" % (where, i))
    if "not" in s and not validate(v, s["not"], root, where):
        errs.append("%s: %r matches a schema it must not match (%s)" % (where, v, json.dumps(s["not"])))
    for sub in s.get("allOf", []):
        errs += validate(v, sub, root, where)
    if "if" in s and not validate(v, s["if"], root, where) and "then" in s:
        errs += validate(v, s["then"], root, where)
    return errs


def main(argv):
    if len(argv) < 3:
        print(__doc__.strip().splitlines()[-1], file=sys.stderr)
        return 2
    schema = json.load(open(argv[1]))
    bad = 0
    for path in argv[2:]:
        try:
            doc = json.load(open(path))
        except (OSError, ValueError) as e:
            print("%s: not readable JSON: %s" % (path, e))
            bad += 1
            continue
        errs = validate(doc, schema, schema)
        for e in errs:
            print("%s: %s" % (path, e))
        bad += bool(errs)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
