"""Every executable ends quietly when its reader closes the pipe (``--help | head``)."""

from pathlib import Path
import subprocess
import sys

import pytest

from rigid_body_attitude.console import CLOSED_PIPE_STATUS

LIBEXEC_DIR = Path(sys.prefix).resolve() / 'lib' / 'rigid_body_attitude'
EXECUTABLES = sorted(path.name for path in LIBEXEC_DIR.iterdir())


def test_the_installed_executables_are_found():
    assert {'propagation_node', 'replay', 'campaign', 'imu_noise'} <= set(EXECUTABLES)


@pytest.mark.parametrize('name', EXECUTABLES)
def test_help_into_a_closed_pipe_gives_no_traceback(name):
    process = subprocess.Popen([str(LIBEXEC_DIR / name), '--help'], stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True)
    process.stdout.close()  # the reader is gone before the first line is written
    stderr = process.stderr.read()
    code = process.wait(timeout=60)
    process.stderr.close()
    assert 'Traceback' not in stderr and 'Exception' not in stderr, stderr
    # argparse's help drops a failed write itself (status 0); the others stop as if by SIGPIPE
    assert code in (0, CLOSED_PIPE_STATUS), stderr
