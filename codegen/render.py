#!/usr/bin/env python3
"""Renders the IR written by pardel-gen (JSON) into DIR/<model>.hpp and DIR/<model>.cpp with the
Jinja2 templates in codegen/templates/. Both files are written atomically; the output depends on
the IR alone, so it is byte-identical across runs.

usage: render.py IR.json --out-dir DIR
"""
import argparse
import json
import os
import re
import sys
import tempfile

import jinja2

IDENT = re.compile(r"[A-Za-z][A-Za-z0-9_]*\Z")
TEMPLATES = os.path.join(os.path.dirname(os.path.abspath(__file__)), "templates")


def c_string(text):
    """A C string literal holding `text` (non-printable bytes escaped as octal). Lone surrogates
    U+DC80..U+DCFF (the IR's bytes of a file name that is not UTF-8) become those bytes again."""
    out = ['"']
    for byte in text.encode("utf-8", "surrogateescape"):
        ch = chr(byte)
        if ch in '"\\':
            out.append("\\" + ch)
        elif 0x20 <= byte < 0x7F and ch != "?":
            out.append(ch)
        else:
            out.append("\\%03o" % byte)
    out.append('"')
    return "".join(out)


def comment_text(text):
    """`text` made safe inside a // comment: printable ASCII only, no trailing backslash."""
    safe = "".join(ch if 0x20 <= ord(ch) < 0x7F else "?" for ch in text)
    return safe.rstrip("\\")


def check_ir(ir):
    model = ir["model"]
    if not IDENT.match(model["name"]):
        raise ValueError("model name %r is not a C identifier" % model["name"])
    for name in model["coords"] + [p["name"] for p in model["params"]]:
        if not re.match(r"[A-Za-z_][A-Za-z0-9_]*\Z", name):
            raise ValueError("name %r is not a C identifier" % name)
    for disc in ir["discretizations"]:
        if not re.match(r"[A-Za-z0-9_]+\Z", disc["ident"]):
            raise ValueError("discretization identifier %r is not valid" % disc["ident"])


def write_atomically(path, text):
    directory = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix=".render-", dir=directory)
    try:
        with os.fdopen(fd, "w", encoding="utf-8", newline="\n") as out:
            out.write(text)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def main(argv):
    parser = argparse.ArgumentParser(description="Render a pardel-gen IR into C++ sources.")
    parser.add_argument("ir", help="the IR written by pardel-gen -o")
    parser.add_argument("--out-dir", required=True, help="folder for <model>.hpp and <model>.cpp")
    args = parser.parse_args(argv)
    try:
        with open(args.ir, encoding="utf-8") as f:
            ir = json.load(f)
        if ir.get("format") != "pardel-ir" or ir.get("format_version") != 1:
            raise ValueError("not a pardel-gen IR of format version 1")
        check_ir(ir)
    except (OSError, ValueError, KeyError, TypeError) as e:
        print("render.py: error: %s: %s" % (args.ir, e), file=sys.stderr)
        return 1
    env = jinja2.Environment(
        loader=jinja2.FileSystemLoader(TEMPLATES),
        undefined=jinja2.StrictUndefined,
        keep_trailing_newline=True,
        trim_blocks=True,
        lstrip_blocks=True,
        autoescape=False,
    )
    env.filters["c_string"] = c_string
    env.filters["comment_text"] = comment_text
    name = ir["model"]["name"]
    os.makedirs(args.out_dir, exist_ok=True)
    for ext in ("hpp", "cpp"):
        text = env.get_template("model.%s.j2" % ext).render(ir=ir, model=ir["model"])
        write_atomically(os.path.join(args.out_dir, "%s.%s" % (name, ext)), text)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
