#!/usr/bin/env python3
"""Every document a file in the tree cites exists, and so does every section it cites.

docs/style.md §19: a comment that sends a reader to a document names a file in the clone. This
scans the project's own files (sources, CMake, scripts, presets, scenarios, docs) for
  - a path under docs/ (a .md file or any other): it must exist;
  - a .md path under docs/ followed by a section sign and a number (4, 4.5, …): that document
    must have a heading with that number;
  - the brief's names (DESIGN or STYLE before a section sign): documents a clone does not have.
Usage: check_citations.py ROOT   (exit 1 and one line per broken citation, file:line first)
"""
import os
import re
import sys

SCANNED_DIRS = ("sim", "rt", "drivers", "tests", "cmake", "config", "scenarios", "docs", ".ci",
                "examples")
SCANNED_TOP = ("CMakeLists.txt", "CMakePresets.json", "Makefile", "README.md")
TEXT_EXT = {".cpp", ".h", ".hpp", ".c", ".cmake", ".txt", ".py", ".sh", ".md", ".toml", ".json",
            ".dbc", ".csv", ""}
# A path under docs/ as code and prose write it; trailing punctuation is not part of it.
DOC_PATH = re.compile(r"(?<![\w/.-])docs/[\w./-]*[\w/]")
SECTION = re.compile(r"(?<![\w/.-])(docs/[\w./-]+\.md)\s*§\s*([0-9]+(?:\.[0-9]+)*)")
OLD_FORM = re.compile(r"\b(DESIGN|STYLE)\s*§")
HEADING = re.compile(r"^#+\s+([0-9]+(?:\.[0-9]+)*)[.\s]")


def files_under(root):
    for top in SCANNED_TOP:
        p = os.path.join(root, top)
        if os.path.isfile(p):
            yield top
    for d in SCANNED_DIRS:
        base = os.path.join(root, d)
        for dirpath, dirnames, filenames in os.walk(base):
            dirnames[:] = [n for n in dirnames if n not in ("build", ".git", "__pycache__")]
            rel = os.path.relpath(dirpath, root)
            # Measured data and fixtures are not prose: tables copied from sources, corpora, and
            # this check's own folder (its fixtures cite what does not exist on purpose).
            if rel.startswith(("tests/data", "tests/fuzz/corpus", "tests/arch")):
                continue
            for n in filenames:
                if os.path.splitext(n)[1] in TEXT_EXT:
                    yield os.path.join(rel, n)


def sections_of(root, doc, cache):
    if doc not in cache:
        numbers = set()
        with open(os.path.join(root, doc), encoding="utf-8", errors="replace") as f:
            for line in f:
                m = HEADING.match(line)
                if m:
                    numbers.add(m.group(1))
        cache[doc] = numbers
    return cache[doc]


def main():
    root = sys.argv[1] if len(sys.argv) > 1 else "."
    errors, cited, cache = [], 0, {}
    for rel in sorted(set(files_under(root))):
        try:
            with open(os.path.join(root, rel), encoding="utf-8") as f:
                lines = f.readlines()
        except (UnicodeDecodeError, OSError):
            continue
        for i, line in enumerate(lines, 1):
            where = f"{rel}:{i}"
            if OLD_FORM.search(line):
                errors.append(f"{where}: cites a document outside the repository: {line.strip()}")
            for m in DOC_PATH.finditer(line):
                path = m.group(0).rstrip("./")
                if line[m.end():m.end() + 1] in ("*", "{", "<"):
                    continue  # a pattern (docs/plots/atmosphere_*.png), not one file
                cited += 1
                if not os.path.exists(os.path.join(root, path)):
                    errors.append(f"{where}: {path} does not exist")
            for m in SECTION.finditer(line):
                doc, number = m.group(1), m.group(2)
                if os.path.isfile(os.path.join(root, doc)) and number not in sections_of(
                        root, doc, cache):
                    errors.append(f"{where}: {doc} has no section {number}")
    for e in errors:
        print(e)
    print(f"{cited} citations of docs/ checked, {len(errors)} broken")
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())
