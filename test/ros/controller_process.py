"""The installed ``attitude_controller`` beside a lockstep node in a test: started in a
namespace with its parameters, stopped with its stderr checked, and the node's run checked
for ticks advanced without a command."""

from __future__ import annotations

from collections.abc import Mapping
import os
from pathlib import Path
import subprocess

from ament_index_python.packages import get_package_prefix

PACKAGE = 'rigid_body_attitude'
CONTROLLER = Path(get_package_prefix(PACKAGE)) / 'lib' / PACKAGE / 'attitude_controller'


def parameter_arguments(values: Mapping[str, object]) -> list[str]:
    """``-p key:=value`` for each item of ``values`` (a tuple written as a list)."""
    return [item for key, value in values.items()
            for item in ('-p', f'{key}:={list(value) if isinstance(value, tuple) else value}')]


def start_controller(namespace: str, values: Mapping[str, object],
                     *remaps: str) -> subprocess.Popen:
    """The installed controller in ``namespace`` with the parameters ``values`` and the
    remap arguments ``remaps`` (``'-r', 'from:=to'`` pairs)."""
    assert CONTROLLER.is_file() and os.access(CONTROLLER, os.X_OK), CONTROLLER
    return subprocess.Popen(
        [str(CONTROLLER), '--ros-args', '-r', f'__ns:={namespace}', *remaps,
         *parameter_arguments(values)],
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)


def stop_controller(controller: subprocess.Popen | None) -> str:
    """Terminate ``controller`` (None: never started) and return its stderr, which must hold
    no traceback."""
    if controller is None:
        return ''
    controller.terminate()
    _, errors = controller.communicate(timeout=10.0)
    assert 'Traceback' not in errors, errors
    return errors


def assert_every_tick_answered(code: int, stderr: str) -> None:
    """The lockstep node exited 0 without a traceback and advanced no tick without its
    command before it was stopped."""
    assert code == 0 and 'Traceback' not in stderr, stderr
    assert 'lockstep: no command stamped' not in stderr.split('SIGINT')[0], stderr
