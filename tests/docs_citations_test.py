#!/usr/bin/python3
"""Keeps the citations of the physics and design pages true.

Usage: docs_citations_test.py <source dir>

Walks the repository (leaving out .git and build folders) and fails, naming file and line, when
  - a file cites a physics, design or style page by a bare file name instead of its docs/ path
    (docs/physics.md, docs/design.md), or points at a folder outside the repository;
  - a citation `docs/physics.md N` or `docs/physics.md N.M` (also lists such as `2.3, 2.5`,
    `6 and 7.1`, ranges `2.3-2.5`, and `section N`) names a section that docs/physics.md does not
    have (its headings `## N Title` and `### N.M Title`);
  - a citation of docs/design.md by a comma and a section name names no heading of docs/design.md
    (`## Name` or `### Name`).
A citation may continue on the next line of a comment. Run by ctest as docs_citations_test.
"""
import bisect
import os
import re
import sys

NUMBER = r"\d+(?:\.\d+)?"
SEPARATOR = r"(?:, | and | to |-|–)"
# Page names the engine's authors once kept outside the repository; written in pieces so that this
# file does not cite them itself.
BARE_PAGE = re.compile(r"(?<![\w/.-])(?:" + "|".join(["PHYS" + "ICS", "DES" + "IGN", "STY" + "LE"]) + r")\.md\b", re.I)
ANY_PAGE = re.compile(r"[\w./-]*\b(?:physics|design|style)\.md\b", re.I)
OUTSIDE = [re.compile(p) for p in (r"\.\./" + "shared", r"/work/" + "shared", r"(?<![\w/])" + "shared" + "/data", "seed-" + "paper")]
PHYSICS_CITATION = re.compile(r"docs/physics\.md,?(?: sections?)? ?(" + NUMBER + r"(?:" + SEPARATOR + NUMBER + r")*)")
DESIGN_CITATION = re.compile(r"docs/design\.md, ")


def headings(path, level_pattern):
    with open(path, encoding="utf-8") as f:
        return [m.group(1).strip() for m in (re.match(level_pattern, line) for line in f) if m]


def joined(text):
    """The text with each line break and the comment leader after it turned into one space, and for
    each joined line its offset in the result (to map a match back to its line)."""
    parts, starts, at = [], [], 0
    for k, line in enumerate(text.split("\n")):
        if k > 0:
            line = " " + re.sub(r"^\s*(?:/{2,3}!?|#+|\*+|--|;+)?\s*", "", line)
        starts.append(at)
        parts.append(line)
        at += len(line)
    return "".join(parts), starts


def main():
    root = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else ".")
    physics = os.path.join(root, "docs/physics.md")
    design = os.path.join(root, "docs/design.md")
    sections = set(headings(physics, r"#{2,3} (" + NUMBER + r") \S"))
    names = sorted(headings(design, r"#{2,3} (.+)$"), key=len, reverse=True)
    if not sections or not names:
        print("docs_citations_test: no numbered sections in docs/physics.md or no headings in docs/design.md")
        return 1
    failures, files, citations = [], 0, 0
    for folder, dirs, entries in os.walk(root):
        dirs[:] = sorted(d for d in dirs if d != ".git" and not (folder == root and d.startswith("build")))
        for entry in sorted(entries):
            path = os.path.join(folder, entry)
            if entry == ".git" or os.path.islink(path):
                continue
            with open(path, "rb") as f:
                data = f.read()
            if b"\0" in data:
                continue
            try:
                text = data.decode("utf-8")
            except UnicodeDecodeError:
                continue
            files += 1
            rel = os.path.relpath(path, root)
            flat, starts = joined(text)

            def fail(offset, message):
                failures.append(f"{rel}:{bisect.bisect_right(starts, offset)}: {message}")

            for m in BARE_PAGE.finditer(flat):
                fail(m.start(), f"'{m.group(0)}' without its docs/ path: cite docs/physics.md or docs/design.md")
            for m in ANY_PAGE.finditer(flat):
                token = m.group(0)
                if not BARE_PAGE.fullmatch(token) and not re.search(r"(?:^|/)docs/(?:physics|design)\.md$", token):
                    fail(m.start(), f"'{token}' is not docs/physics.md or docs/design.md")
            for pattern in OUTSIDE:
                for m in pattern.finditer(flat):
                    fail(m.start(), f"'{m.group(0)}' points outside the repository")
            for m in PHYSICS_CITATION.finditer(flat):
                citations += 1
                for number in re.findall(NUMBER, m.group(1)):
                    if number not in sections:
                        fail(m.start(), f"'{m.group(0)}': docs/physics.md has no section {number}")
            for m in DESIGN_CITATION.finditer(flat):
                citations += 1
                rest = flat[m.end():]
                if not any(rest.startswith(name) and not rest[len(name):len(name) + 1].isalnum() for name in names):
                    fail(m.start(), f"'{flat[m.start():m.end() + 30]}...': docs/design.md has no such section "
                                    f"(its sections: {', '.join(sorted(names))})")
    for line in failures:
        print(line)
    print(f"docs_citations_test: {citations} citations in {files} files, {len(failures)} problems")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
