"""The pandas block of docs/formats.md on a real log (check_pandas_doc.py; augerd's own log is
checked the same way by tests/daemon/e2e_goto.sh)."""

from check_pandas_doc import check, documented_block
from conftest import synthetic_log


def test_documented_pandas_lines_read_a_log(tmp_path):
    synthetic_log(tmp_path / "log.csv", seconds=2)
    text = (tmp_path / "log.csv").read_text().replace("# format: auger-robot-log v1\n",
                                                      "# format: auger-robot-log v1\n# t0_unix_s: 1767225600.5\n")
    (tmp_path / "log.csv").write_text(text)
    assert check(tmp_path / "log.csv") == []


def test_the_check_fails_on_a_wrong_read(tmp_path):
    """The check is not vacuous: the block without comment='#' (a plain read_csv) is caught."""
    synthetic_log(tmp_path / "log.csv", seconds=1)
    plain = documented_block().replace(', comment="#"', "")
    assert 'comment="#"' not in plain
    try:
        problems = check(tmp_path / "log.csv", plain)
    except (KeyError, ValueError, TypeError) as e:  # the misread frame has no column t_s, ...
        problems = [repr(e)]
    assert problems
