"""``uvnav --help | head -3``: a reader that closes standard output early gets no traceback."""

from __future__ import annotations

import subprocess
import sys

from uvnav_tui.cli.main import EXIT_BROKEN_PIPE


def test_help_into_a_closed_pipe_exits_quietly():
    # The read end is closed before the child has even imported the CLI (tens of ms), so its
    # write of the usage fails with EPIPE (Python ignores SIGPIPE): a BrokenPipeError, which
    # used to end in a traceback on stderr.
    proc = subprocess.Popen([sys.executable, "-m", "uvnav_tui.cli.main", "--help"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    assert proc.stdout is not None and proc.stderr is not None
    proc.stdout.close()
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=60) == EXIT_BROKEN_PIPE
    assert "Traceback" not in err and "BrokenPipeError" not in err, err


def test_help_still_printed_whole(capsys):
    from uvnav_tui.cli.main import USAGE, main

    assert main(["--help"]) == 0
    assert capsys.readouterr().out == USAGE + "\n"
