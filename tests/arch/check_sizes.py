#!/usr/bin/env python3
"""No file over 800 lines under sim/, no function over 80 lines in the folders that hold the
frame's path (docs/style.md §17), but for the exceptions named in an exceptions file
(`path:function reason`, one a line).

Function lengths come from cxx_functions.py (why it is not pmccabe or clang-tidy: its opening
comment): from the line of a function's name to its closing brace, both counted.
Usage: check_sizes.py ROOT [EXCEPTIONS]   (exit 1 and one line per excess, file:line first)
"""
import os
import sys

import cxx_functions

MAX_FILE_LINES = 800
MAX_FUNCTION_LINES = 80
FILE_DIRS = ("sim",)
FUNCTION_DIRS = ("sim/sensor", "sim/render", "rt/loop", "rt/compose")
SOURCE_EXT = (".cpp", ".h")


def sources(root, dirs):
    for d in dirs:
        for dirpath, _, filenames in os.walk(os.path.join(root, d)):
            for n in sorted(filenames):
                if n.endswith(SOURCE_EXT):
                    yield os.path.relpath(os.path.join(dirpath, n), root)


def functions(root, rel):
    with open(os.path.join(root, rel), encoding="utf-8") as f:
        return cxx_functions.functions(f.read())


def load_exceptions(path):
    allowed = {}
    if path and os.path.isfile(path):
        with open(path, encoding="utf-8") as f:
            for line in f:
                line = line.split("#", 1)[0].strip()
                if line:
                    key, _, why = line.partition(" ")
                    allowed[key] = why.strip()
    return allowed


def main():
    root = sys.argv[1] if len(sys.argv) > 1 else "."
    allowed = load_exceptions(sys.argv[2] if len(sys.argv) > 2 else None)
    errors, counted = [], 0
    for rel in sources(root, FILE_DIRS):
        with open(os.path.join(root, rel), encoding="utf-8") as f:
            n = sum(1 for _ in f)
        if n > MAX_FILE_LINES and rel not in allowed:
            errors.append(f"{rel}:1: {n} lines (at most {MAX_FILE_LINES})")
    for rel in sources(root, FUNCTION_DIRS):
        rows = functions(root, rel)
        for first, lines, name in rows:
            counted += 1
            if lines > MAX_FUNCTION_LINES and f"{rel}:{name}" not in allowed:
                errors.append(f"{rel}:{first}: {name} has {lines} lines (at most "
                              f"{MAX_FUNCTION_LINES})")
    for e in errors:
        print(e)
    print(f"{counted} functions measured, {len(errors)} over the limits")
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())
