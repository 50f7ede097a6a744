"""augerd's commands socket for the DDS tests (ros2_sim.sh sets AUGER and AUGERD_SOCKET):
`status all` as a dict, commands, the event log."""
import glob
import os
import subprocess

ENV = os.environ


def status():
    """augerd's `status all`, as a dict of its key=value fields."""
    out = subprocess.run([ENV["AUGER"], "cmd", "--socket", ENV["AUGERD_SOCKET"], "status all"],
                         capture_output=True, text=True, timeout=5, check=True).stdout
    return dict(f.split("=", 1) for f in out.split() if "=" in f)


def command(*cmds):
    subprocess.run([ENV["AUGER"], "cmd", "--socket", ENV["AUGERD_SOCKET"], *cmds], capture_output=True,
                   text=True, timeout=5, check=True)


def events():
    """augerd's event log (AUGERD_LOG_DIR) as one text."""
    return "".join(open(p).read() for p in glob.glob(os.path.join(ENV["AUGERD_LOG_DIR"], "*-events.log")))
