#!/usr/bin/env python3
"""Runs the pandas block of docs/formats.md, as written, on a robot log and checks its result.

Usage: check_pandas_doc.py LOG   (exit 0 when the documented lines read LOG correctly)
Used by test_pandas_doc.py (a simulated log) and tests/daemon/e2e_goto.sh (augerd's own log).
"""

import math
import re
import sys
from pathlib import Path

DOC = Path(__file__).resolve().parents[2] / "docs" / "formats.md"


def documented_block():
    text = DOC.read_text()
    section = text[text.index("## pandas and the csv module"):]
    m = re.search(r"```python\n(.*?)```", section, re.S)
    return m.group(1)


def check(log_path, code=None):
    """Problems found (empty: the block read the log right). code: the block (default: the doc's)."""
    code = documented_block() if code is None else code
    lit = re.search(r'^path = "([^"]+)"$', code, re.M)
    assert lit, "the block no longer sets `path = \"...\"`"
    code = code.replace(lit.group(0), "path = %r" % str(log_path))
    scope = {}
    exec(compile(code, "docs/formats.md (pandas block)", "exec"), scope)
    log, meta, rows, pose = scope["log"], scope["meta"], scope["rows"], scope["pose"]

    lines = Path(log_path).read_text().splitlines()
    n_meta = sum(1 for l in lines if l.startswith("#"))
    header = next(l for l in lines if not l.startswith("#")).split(",")
    data = [l.split(",") for l in lines[n_meta + 1:] if l and not l.startswith("#")]
    problems = []
    if list(log.columns[:len(header)]) != header:
        problems.append("pandas columns %s, the header %s" % (list(log.columns)[:5], header[:5]))
    if len(log) != len(data) or len(rows) != len(data):
        problems.append("%d pandas rows, %d csv rows, %d in the file" % (len(log), len(rows), len(data)))
    if meta.get("format") != "auger-robot-log v1":
        problems.append("metadata format %r" % meta.get("format"))
    for col in ["t_s"] + ["omega_rpm_%d" % i for i in range(4)] + ["x_m"]:
        j = header.index(col)
        for k in (0, len(data) // 2, len(data) - 1):
            want = float(data[k][j]) if data[k][j] else math.nan
            got = float(log[col].iloc[k])
            if not (got == want or (math.isnan(got) and math.isnan(want))):
                problems.append("%s row %d: pandas %r, file %r" % (col, k, got, data[k][j]))
            if rows[k][col] != data[k][j]:
                problems.append("%s row %d: csv module %r, file %r" % (col, k, rows[k][col], data[k][j]))
    if not (log["t_s"].diff().dropna() > 0).all():
        problems.append("t_s is not increasing in pandas")
    if len(pose) != sum(1 for r in data if r[header.index("x_m")]):
        problems.append("pose rows %d" % len(pose))
    if "t0_unix_s" in meta:
        t0 = float(meta["t0_unix_s"])
        if abs(log["time"].iloc[-1].timestamp() - (t0 + float(data[-1][0]))) > 1e-3:
            problems.append("time column %s, t0 %s" % (log["time"].iloc[-1], t0))
    return problems


if __name__ == "__main__":
    problems = check(sys.argv[1])
    for p in problems:
        print("check_pandas_doc: %s: %s" % (sys.argv[1], p), file=sys.stderr)
    print("check_pandas_doc: %s: %s" % (sys.argv[1], "FAILED" if problems else "the documented pandas lines read it"))
    sys.exit(1 if problems else 0)
