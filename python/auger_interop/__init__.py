"""auger_interop: measurement data from other tools into the robot log v1 (docs/log-format.md).

`auger import` runs this package (python -m auger_interop import ...) in the project's venv
(scripts/make-venv.sh): ROS 2 bags (rosbag2, sqlite3 or MCAP storage, read with the `rosbags`
library, no ROS needed: bag.py, bagscan.py, bagtypes.py) and CSV files of other programs
(csvsrc.py), mapped column by column (mapping.py), checked where each value enters (limits.py),
cut where the clock steps (timeline.py), put on the log's 100 Hz grid as measured (grid.py) and
written whole or not at all (robotlog.py); pipeline.py runs the passes, cli.py the command.
docs/formats.md is the user's guide.
"""


class InputError(Exception):
    """Bad input: the message names the file and where in it (topic, line, key)."""
