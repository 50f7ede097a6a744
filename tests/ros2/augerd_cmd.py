"""augerd's commands socket for the DDS tests (ros2_sim.sh sets AUGER and AUGERD_SOCKET):
`status all` as a dict, commands, the event log."""
import glob
import os
import subprocess
import time

ENV = os.environ


def status():
    """augerd's `status all`, as a dict of its key=value fields."""
    out = subprocess.run([ENV["AUGER"], "cmd", "--socket", ENV["AUGERD_SOCKET"], "status all"],
                         capture_output=True, text=True, timeout=5, check=True).stdout
    return dict(f.split("=", 1) for f in out.split() if "=" in f)


def command(*cmds):
    subprocess.run([ENV["AUGER"], "cmd", "--socket", ENV["AUGERD_SOCKET"], *cmds], capture_output=True,
                   text=True, timeout=5, check=True)


def events(expect=None, timeout_s=2.0):
    """augerd's event log (AUGERD_LOG_DIR) as one text. augerd writes it from its log thread, so
    the control loop never waits for the disk: the event of a command just answered may reach the
    file some milliseconds later. With expect, waits up to timeout_s until the text holds it."""
    end = time.time() + timeout_s
    while True:
        text = "".join(open(p).read() for p in glob.glob(os.path.join(ENV["AUGERD_LOG_DIR"], "*-events.log")))
        if expect is None or expect in text or time.time() > end:
            return text
        time.sleep(0.02)


def logged(text, timeout_s=2.0):
    """Whether augerd's event log holds text within timeout_s."""
    return text in events(text, timeout_s)
