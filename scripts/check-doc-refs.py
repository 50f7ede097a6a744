#!/usr/bin/env python3
"""Fails if a comment or a doc cites a Markdown file that is not in the repository, or a section
that is not in the file it names.

Usage: check-doc-refs.py SOURCE_DIR
       check-doc-refs.py --self-test   (the check on a made-up tree: good and bad citations)

Every Markdown file name (with or without a path) in the project's sources, scripts, build files and docs must
resolve to a file: from the repository's root, from the citing file's folder, or in docs/.
Web addresses are skipped. Bare names of notes kept outside the repository (the paper's model
notes, the simavr notes) are refused too. A section cited by name after the file,
`docs/<file>.md "Section"` (also `<file>.md, "Section"`, `<file>.md ("Section")`, `<file>.md
section "Section"`, or the quote at the start of the next comment line), must be part of one of
that file's headings (outside code blocks, backticks ignored, case counts): "explain" names the
heading "`auger explain LOG...`", "Calibration" the heading "Calibration of `significant`".
Prints `file:line:col: ...` for each, exit 1 if any.
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
# The section quoted after a cited file, from the end of the file name on; the line is joined to
# the next one without its comment leader, so a quote may start or go on there.
SECTION_AFTER = re.compile(r'`?[,:]? +\(?(?:section )?"([^"]{1,120})"')
LEADER = re.compile(r"\s*(?://+|#+|\*|/\*|--)?\s*")


def cited_files(root):
    for folder, dirs, files in os.walk(root):
        # Build folders (build/, build-asan/, ...) hold generated and third-party files.
        dirs[:] = sorted(d for d in dirs if d not in SKIP_DIRS and not d.startswith("build"))
        for name in sorted(files):
            if name.endswith(SUFFIXES) or name in NAMES:
                yield os.path.join(folder, name)


def resolves(root, citing, ref):
    """The file a citation names, or None."""
    ref = ref.lstrip("./") if ref.startswith("./") else ref
    candidates = [os.path.join(root, ref), os.path.join(os.path.dirname(citing), ref),
                  os.path.join(root, "docs", ref)]
    return next((c for c in candidates if os.path.isfile(c)), None)


def headings(path, cache={}):
    """The headings of a Markdown file (not those in code blocks), without backticks."""
    if path not in cache:
        found = []
        fenced = False
        with open(path, encoding="utf-8") as f:
            for line in f:
                if line.startswith("```"):
                    fenced = not fenced
                elif not fenced and re.match(r"#{1,6} ", line):
                    found.append(line.lstrip("#").strip().replace("`", ""))
        cache[path] = found
    return cache[path]


def cited_section(line, end, next_line):
    """The section quoted after a file cited up to column `end` and the column of its quote (past
    the line's end: on the next line); else None."""
    line = line.rstrip("\n")
    joined = line + " " + (next_line[LEADER.match(next_line).end():] if next_line else "")
    m = SECTION_AFTER.match(joined, end)
    if m:
        return " ".join(m.group(1).split()), m.start(1)
    return None


def self_test():
    import tempfile

    def write(root, name, text):
        with open(os.path.join(root, name), "w") as f:
            f.write(text)

    with tempfile.TemporaryDirectory() as root:
        os.makedirs(os.path.join(root, "docs"))
        os.makedirs(os.path.join(root, "src"))
        model = "model" + ".md"  # not a citation in this file
        write(root, "docs/" + model, "# Model\n## Frames\n## `auger explain LOG`\n```\n# Not a heading\n```\n"
              "See [design](design.md) and https://example.org/README.md.\n")
        # Broken: docs/design.md is missing; the bare note name; "Dynamics", "frames" (case counts),
        # "Not a heading" (a comment line inside a code block), also quoted on the next line, and
        # "auger explain NOW" broken over two lines.
        write(root, "src/a.cpp", f"// eq. (7) (docs/{model}), {model}\n// " + "MODEL-" + "NOTES decision\n"
              f'// docs/{model} "Frames", {model}, "explain" and docs/{model} "Dynamics"\n'
              f'# {model} ("Not a heading") and docs/{model}\n# "Dynamics" again, {model} "frames"\n'
              f'// docs/{model} "auger explain\n// NOW"\n')
        if check(root) != 7:
            print("self-test: expected exactly 7 broken citations")
            return 1
        write(root, "docs/design.md", "# Design\n")
        write(root, "src/a.cpp", f"// eq. (7) (docs/{model}), {model}, ../docs/design.md\n"
              f'// docs/{model} "Frames", {model} section "auger explain" and docs/{model}\n'
              f'// "Frames" again; a string: "docs/{model}", "other"; docs/{model} "auger\n'
              f'// explain LOG" broken over two lines\n')
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
    sections = 0
    for path in cited_files(root):
        rel = os.path.relpath(path, root)
        try:
            with open(path, encoding="utf-8") as f:
                lines = f.readlines()
        except UnicodeDecodeError:
            continue
        for lineno, line in enumerate(lines, 1):
            next_line = lines[lineno] if lineno < len(lines) else None
            for m in MD_REF.finditer(line):
                before = line[:m.start()]
                if re.search(r"[a-z]+://\S*$", before) or m.group(0).startswith("//"):
                    continue  # a web address
                checked += 1
                target = resolves(root, path, m.group(0))
                if not target:
                    print(f"{rel}:{lineno}:{m.start() + 1}: cites {m.group(0)}, "
                          "which is not in the repository")
                    bad += 1
                    continue
                section = cited_section(line, m.end(), next_line)
                if section is None or not target.endswith(".md"):
                    continue
                sections += 1
                name, col = section
                if not any(name.replace("`", "") in h for h in headings(target)):
                    where = f"{lineno}:{col + 1}" if col < len(line.rstrip()) else f"{lineno + 1}:1"
                    print(f"{rel}:{where}: cites section \"{name}\" of {m.group(0)}, which has no "
                          "such heading")
                    bad += 1
            for m in OUTSIDE_NOTE.finditer(line):
                print(f"{rel}:{lineno}:{m.start() + 1}: cites {m.group(0)}, a note kept outside "
                      "the repository (cite docs/model-notes.md, docs/design.md or docs/simulator.md)")
                bad += 1
    if checked == 0:
        print(f"{root}: no citation of a .md file found: wrong folder?")
        return -1
    print(f"{checked} citations of .md files checked ({sections} of a section), {bad} broken")
    return bad


if __name__ == "__main__":
    sys.exit(main())
