#!/usr/bin/env python3
"""Fails if a comment or a doc cites a Markdown file that is not in the repository.

Usage: check-doc-refs.py SOURCE_DIR
       check-doc-refs.py --self-test   (the check on a made-up tree: one good, two bad citations)

Every Markdown file name (with or without a path) in the project's sources, scripts, build files and docs must
resolve to a file: from the repository's root, from the citing file's folder, or in docs/.
Web addresses are skipped. Bare names of notes kept outside the repository (the paper's model
notes, the simavr notes) are refused too. Prints `file:line:col: ...` for each, exit 1 if any.
"""
import os
import re
import sys

SUFFIXES = (".c", ".h", ".cpp", ".hpp", ".S", ".py", ".sh", ".cmake", ".md", ".toml", ".txt",
            ".yml", ".yaml", ".in", ".service", ".msg")
NAMES = ("CMakeLists.txt", "Makefile")
SKIP_DIRS = {".git", "venv", "__pycache__", "node_modules"}
MD_REF = re.compile(r"[A-Za-z0-9_./-]*[A-Za-z0-9_-]\.md\b")
OUTSIDE_NOTE = re.compile(r"\b(?:MODEL|SIMAVR)-NOTES\b")


def cited_files(root):
    for folder, dirs, files in os.walk(root):
        # Build folders (build/, build-asan/, ...) hold generated and third-party files.
        dirs[:] = sorted(d for d in dirs if d not in SKIP_DIRS and not d.startswith("build"))
        for name in sorted(files):
            if name.endswith(SUFFIXES) or name in NAMES:
                yield os.path.join(folder, name)


def resolves(root, citing, ref):
    ref = ref.lstrip("./") if ref.startswith("./") else ref
    candidates = [os.path.join(root, ref), os.path.join(os.path.dirname(citing), ref),
                  os.path.join(root, "docs", ref)]
    return any(os.path.isfile(c) for c in candidates)


def self_test():
    import tempfile
    with tempfile.TemporaryDirectory() as root:
        os.makedirs(os.path.join(root, "docs"))
        os.makedirs(os.path.join(root, "src"))
        with open(os.path.join(root, "docs", "model.md"), "w") as f:
            f.write("See [design](design.md) and https://example.org/README.md.\n")
        with open(os.path.join(root, "src", "a.cpp"), "w") as f:
            f.write("// eq. (7) (docs/model.md), model.md\n// " + "MODEL-" + "NOTES decision\n")
        if check(root) != 2:  # docs/design.md is missing; the bare note name is refused
            print("self-test: expected exactly 2 broken citations")
            return 1
        with open(os.path.join(root, "docs", "design.md"), "w") as f:
            f.write("# Design\n")
        with open(os.path.join(root, "src", "a.cpp"), "w") as f:
            f.write("// eq. (7) (docs/model.md), model.md, ../docs/design.md\n")
        if check(root) != 0:
            print("self-test: expected no broken citation")
            return 1
    print("self-test passed")
    return 0


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    if sys.argv[1] == "--self-test":
        return self_test()
    bad = check(os.path.abspath(sys.argv[1]))
    return 1 if bad else 0


def check(root):
    """Prints each broken citation under root; returns their count (-1: nothing cited at all)."""
    bad = 0
    checked = 0
    for path in cited_files(root):
        rel = os.path.relpath(path, root)
        try:
            with open(path, encoding="utf-8") as f:
                lines = f.readlines()
        except UnicodeDecodeError:
            continue
        for lineno, line in enumerate(lines, 1):
            for m in MD_REF.finditer(line):
                before = line[:m.start()]
                if re.search(r"[a-z]+://\S*$", before) or m.group(0).startswith("//"):
                    continue  # a web address
                checked += 1
                if not resolves(root, path, m.group(0)):
                    print(f"{rel}:{lineno}:{m.start() + 1}: cites {m.group(0)}, "
                          "which is not in the repository")
                    bad += 1
            for m in OUTSIDE_NOTE.finditer(line):
                print(f"{rel}:{lineno}:{m.start() + 1}: cites {m.group(0)}, a note kept outside "
                      "the repository (cite docs/model-notes.md, docs/design.md or docs/simulator.md)")
                bad += 1
    if checked == 0:
        print(f"{root}: no citation of a .md file found: wrong folder?")
        return -1
    print(f"{checked} citations of .md files checked, {bad} broken")
    return bad


if __name__ == "__main__":
    sys.exit(main())
