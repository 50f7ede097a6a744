#!/usr/bin/env python3
"""Loads a local HTML page in headless Chromium and reports what a reader's browser would see.

Drives Chromium over the DevTools protocol on a pipe (--remote-debugging-pipe: NUL-separated
JSON on file descriptors 3 and 4, so no websocket library is needed). Collects every console
error or warning, every uncaught exception, every browser log error, and every request the page
makes to anything but itself (file: and data: URLs); evaluates an optional JavaScript
expression in the page (its value, JSON-encoded by the expression, is printed as "eval");
optionally saves a screenshot of the whole page.

Prints one JSON object: {"errors": [...], "requests": [...], "eval": ..., "screenshot": path,
"seconds": ...}. Exit 0 when there are no errors and no outside requests, 1 otherwise, 2 when
Chromium cannot be run.

usage: browser_check.py PAGE.html [--eval JS] [--screenshot OUT.png] [--width PX]
                        [--chromium PATH] [--timeout S]
"""
import argparse
import base64
import json
import os
import pathlib
import shutil
import subprocess
import sys
import tempfile
import time


class Browser:
    def __init__(self, exe, timeout_s):
        self.timeout_s = timeout_s
        self.profile = tempfile.mkdtemp(prefix="auger-browser-")
        to_child_r, self.to_child_w = os.pipe()
        self.from_child_r, from_child_w = os.pipe()

        def wire():  # in the child: the pipe ends Chromium expects on 3 (commands) and 4 (replies)
            high_r, high_w = os.dup(to_child_r), os.dup(from_child_w)  # out of the way of 3 and 4 first
            os.dup2(high_r, 3)
            os.dup2(high_w, 4)

        args = [exe, "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
                "--no-default-browser-check", "--disable-extensions", "--disable-background-networking",
                "--remote-debugging-pipe", "--user-data-dir=" + self.profile, "about:blank"]
        self.proc = subprocess.Popen(args, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                     stderr=subprocess.DEVNULL, preexec_fn=wire, close_fds=False)
        os.close(to_child_r)
        os.close(from_child_w)
        self.buf = b""
        self.next_id = 0
        self.events = []

    def close(self):
        try:
            self.send("Browser.close")
        except Exception:
            pass
        try:
            self.proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        os.close(self.to_child_w)
        os.close(self.from_child_r)
        shutil.rmtree(self.profile, ignore_errors=True)

    def _read_message(self, deadline):
        while b"\0" not in self.buf:
            if time.monotonic() > deadline:
                raise TimeoutError("no answer from Chromium")
            chunk = os.read(self.from_child_r, 1 << 20)
            if not chunk:
                raise RuntimeError("Chromium closed the DevTools pipe")
            self.buf += chunk
        msg, _, self.buf = self.buf.partition(b"\0")
        return json.loads(msg)

    def send(self, method, params=None, session=None):
        self.next_id += 1
        msg = {"id": self.next_id, "method": method, "params": params or {}}
        if session:
            msg["sessionId"] = session
        os.write(self.to_child_w, json.dumps(msg).encode() + b"\0")
        deadline = time.monotonic() + self.timeout_s
        while True:
            m = self._read_message(deadline)
            if m.get("id") == self.next_id:
                if "error" in m:
                    raise RuntimeError(f"{method}: {m['error']}")
                return m.get("result", {})
            self.events.append(m)

    def wait_event(self, method, seconds):
        deadline = time.monotonic() + seconds
        while True:
            for i, e in enumerate(self.events):
                if e.get("method") == method:
                    return self.events.pop(i)
            self.events.append(self._read_message(deadline))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("page")
    ap.add_argument("--eval", default="")
    ap.add_argument("--screenshot", default="")
    ap.add_argument("--width", type=int, default=1200)
    ap.add_argument("--chromium", default=os.environ.get("AUGER_CHROMIUM", "chromium"))
    ap.add_argument("--timeout", type=float, default=60)
    a = ap.parse_args()
    exe = shutil.which(a.chromium)
    if not exe:
        print(f"browser_check: '{a.chromium}' not found (Debian package chromium)", file=sys.stderr)
        return 2
    url = pathlib.Path(a.page).resolve().as_uri()
    t0 = time.monotonic()
    b = Browser(exe, a.timeout)
    out = {"errors": [], "requests": [], "eval": None, "screenshot": None}
    try:
        target = b.send("Target.createTarget", {"url": "about:blank"})["targetId"]
        s = b.send("Target.attachToTarget", {"targetId": target, "flatten": True})["sessionId"]
        for domain in ("Runtime", "Log", "Network", "Page"):
            b.send(domain + ".enable", session=s)
        b.send("Emulation.setDeviceMetricsOverride",
               {"width": a.width, "height": 900, "deviceScaleFactor": 1, "mobile": False}, session=s)
        b.send("Page.navigate", {"url": url}, session=s)
        b.wait_event("Page.loadEventFired", a.timeout)
        # Let timers and the first animation frames run (dygraphs draws on construction).
        b.send("Runtime.evaluate", {"expression": "new Promise(r => setTimeout(r, 300))", "awaitPromise": True},
               session=s)
        if a.eval:
            r = b.send("Runtime.evaluate", {"expression": a.eval, "returnByValue": True, "awaitPromise": True},
                       session=s)
            if "exceptionDetails" in r:
                out["errors"].append("--eval threw: " + json.dumps(r["exceptionDetails"])[:500])
            else:
                value = r.get("result", {}).get("value")
                out["eval"] = json.loads(value) if isinstance(value, str) else value
        if a.screenshot:
            size = b.send("Page.getLayoutMetrics", session=s)["cssContentSize"]
            height = int(min(size["height"], 16000))
            b.send("Emulation.setDeviceMetricsOverride",
                   {"width": a.width, "height": height, "deviceScaleFactor": 1, "mobile": False}, session=s)
            shot = b.send("Page.captureScreenshot", {"format": "png"}, session=s)
            pathlib.Path(a.screenshot).write_bytes(base64.b64decode(shot["data"]))
            out["screenshot"] = {"path": a.screenshot, "width": a.width, "height": height}
        for e in b.events:
            m, p = e.get("method"), e.get("params", {})
            if m == "Runtime.exceptionThrown":
                d = p.get("exceptionDetails", {})
                out["errors"].append("exception: " + d.get("exception", {}).get("description", d.get("text", "")))
            elif m == "Runtime.consoleAPICalled" and p.get("type") in ("error", "warning", "assert"):
                text = " ".join(str(x.get("value", x.get("description", ""))) for x in p.get("args", []))
                out["errors"].append(f"console.{p['type']}: {text}")
            elif m == "Log.entryAdded" and p.get("entry", {}).get("level") in ("error", "warning"):
                out["errors"].append("log: " + p["entry"].get("text", ""))
            elif m == "Network.requestWillBeSent":
                u = p.get("request", {}).get("url", "")
                if not (u.startswith("file:") or u.startswith("data:") or u == "about:blank"):
                    out["requests"].append(u)
    finally:
        b.close()
    out["seconds"] = round(time.monotonic() - t0, 2)
    print(json.dumps(out))
    return 0 if not out["errors"] and not out["requests"] else 1


if __name__ == "__main__":
    sys.exit(main())
