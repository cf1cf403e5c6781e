"""The ``replay`` command line: options derived from the node's parameter table, ``main``.

Every node parameter the replay takes (:data:`~.options.NODE_PARAMETERS`) is an option of the
same name with dashes (``max_dt`` → ``--max-dt``; booleans ``--use-header-stamps`` /
``--no-use-header-stamps``), its type, bounds and default from the table; ``--no-header-stamps``
is kept as the documented short form. Values are checked by the table's own checks. User
mistakes (bad options, bags, scenes, files) print one ``error: ...`` line and return 1
(argparse usage errors exit with 2); the session's warnings go to stderr as ``[WARN]`` lines.

A glob pattern, or a folder that is not itself a bag but holds bags, replays every bag as a
Dask task (:mod:`rigid_body_attitude.tools.replay.fleet`): one output bag each in the
``--output`` folder, one table of their reports (and errors against ground truth where the
bag has the topic), also written to ``OUTPUT/fleet.csv``.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from rigid_body_attitude.console import closed_pipe_safe
from rigid_body_attitude.bag import STORAGES
from rigid_body_attitude.core.errors import AttitudeError
from rigid_body_attitude.session.parameters import Parameter
from rigid_body_attitude.session.reports import LEVEL_ERROR, LEVEL_WARN
from rigid_body_attitude.tools.replay.options import NODE_PARAMETERS, ReplayOptions
from rigid_body_attitude.tools.replay.report import (
    summary, write_csv, write_error_csv, write_plot)
from rigid_body_attitude.tools.replay.run import ReplayResult, replay_bag

__all__ = ['main', 'parser']

#: Session log lines printed to stderr at most (each reason is already throttled to one per
#: 5 s of bag time; time jumps and refused integrations are not).
MAX_LOG_LINES = 100
_LEVEL_TAGS = {LEVEL_WARN: 'WARN', LEVEL_ERROR: 'ERROR'}


def _option(parameter: Parameter) -> str:
    return '--' + parameter.name.replace('_', '-')


def _help(parameter: Parameter) -> str:
    """The table's description, its unit moved to the end, with default and bounds."""
    text, unit = parameter.description, ''
    head, _, rest = text.partition(': ')
    if parameter.type in (float, tuple) and rest and ' ' not in head:
        text, unit = rest, f' [{head}]'
    default = repr(parameter.default) if parameter.type is str else str(parameter.default)
    if parameter.type is tuple:
        default = f'[{", ".join(map(str, parameter.default))}]'
    bounds = f', in {parameter.range_text()}' if parameter.range_text() else ''
    choices = f', one of {", ".join(parameter.choices)}' if parameter.choices else ''
    return f'{text}{unit} (default {default}{bounds}{choices})'.replace('%', '%%')


def double_array(text: str) -> tuple[float, ...]:
    """A double array option: numbers separated by commas, optionally in brackets
    (``0,0,1.57`` or ``[0, 0, 1.57]``; ``[]`` or an empty string: none)."""
    inner = text.strip()
    if inner.startswith('[') and inner.endswith(']'):
        inner = inner[1:-1]
    if not inner.strip():
        return ()
    try:
        return tuple(float(item) for item in inner.split(','))
    except ValueError:
        raise argparse.ArgumentTypeError(f'expected numbers separated by commas, got {text!r}'
                                         ) from None


def _add_node_parameters(group: Any) -> None:
    for parameter in NODE_PARAMETERS:
        if parameter.type is tuple:
            group.add_argument(_option(parameter), type=double_array, default=None,
                               dest=parameter.name, metavar='X,Y,Z', help=_help(parameter))
        elif parameter.type is bool:
            group.add_argument(_option(parameter), action=argparse.BooleanOptionalAction,
                               default=None, help=_help(parameter))
        else:
            group.add_argument(_option(parameter), type=parameter.type, default=None,
                               dest=parameter.name, metavar=parameter.name.upper(),
                               help=_help(parameter))
    group.add_argument('--no-header-stamps', dest='use_header_stamps', action='store_false',
                       default=None, help='same as --no-use-header-stamps: bag (receive) times '
                                          'instead of header stamps')


def parser() -> argparse.ArgumentParser:
    """The ``replay`` argument parser."""
    result = argparse.ArgumentParser(
        prog='replay',
        description='Replay a rosbag2 bag (sqlite3 or mcap) through the propagation node\'s '
                    'session and write its outputs (orientation, pose, imu/data, '
                    '/diagnostics; dynamics scenes: twist, energy, angular_momentum) to a '
                    'new bag.')
    result.add_argument('bag', help='input bag (directory with metadata.yaml, or a .db3/.mcap '
                                    'file), or many: a folder of bags or a glob pattern')
    result.add_argument('-o', '--output', help='output bag directory (must not exist; '
                                               'default: BAG_replayed); with many bags, the '
                                               'folder of their output bags and fleet.csv')
    result.add_argument('--storage', choices=sorted(STORAGES), default='sqlite3',
                        help='storage of the output bag (default: %(default)s)')
    _add_node_parameters(result.add_argument_group(
        'node parameters (the node\'s names, defaults and bounds; receive time = bag time)'))
    topics = result.add_argument_group('topics')
    topics.add_argument('--gyro-topic', default='',
                        help='Imu, Vector3Stamped or TwistStamped rates (default: imu, else '
                             'angular_velocity)')
    topics.add_argument('--torque-topic', default=ReplayOptions.torque_topic,
                        help='WrenchStamped commands (default: %(default)s)')
    topics.add_argument('--rotor-torque-topic', default=ReplayOptions.rotor_torque_topic,
                        help='Vector3Stamped rotor torque commands (default: %(default)s)')
    topics.add_argument('--set-pose-topic', default=ReplayOptions.set_pose_topic,
                        help='PoseStamped attitude re-initialisations (default: %(default)s)')
    topics.add_argument('--outputs', default='',
                        help='comma-separated output topics to write (default: all)')
    report = result.add_argument_group('report')
    report.add_argument('--ground-truth', metavar='TOPIC', default='',
                        help='QuaternionStamped or PoseStamped attitude to compare with')
    report.add_argument('--start-from-ground-truth', metavar='STAMP', type=float,
                        help='set the attitude from the ground truth at the first output at '
                             'or after this header stamp [s]')
    report.add_argument('--plot', metavar='PNG',
                        help='error (and dynamics: energy) plot (default with --ground-truth: '
                             'OUTPUT_error.png)')
    report.add_argument('--csv', metavar='FILE',
                        help='outputs as CSV (and FILE_error.csv with --ground-truth)')
    report.add_argument('--progress', action=argparse.BooleanOptionalAction, default=None,
                        help='progress bar (default: on a terminal)')
    _add_fleet_options(result.add_argument_group(
        'many bags (a folder of bags or a glob pattern: one Dask task per bag)'))
    return result


def _add_fleet_options(group: Any) -> None:
    where = group.add_mutually_exclusive_group()
    where.add_argument('--scheduler', default='', metavar='ADDRESS',
                       help='an existing dask.distributed scheduler (tcp://host:8786)')
    where.add_argument('--workers', type=int, default=0, metavar='N',
                       help='worker processes of the local cluster (default: one per bag, '
                            'at most one per CPU)')
    where.add_argument('--serial', action='store_true',
                       help='replay the bags one after the other in this process')


def options_from(args: argparse.Namespace) -> ReplayOptions:
    """The :class:`ReplayOptions` of parsed arguments (node parameters not given: defaults)."""
    given = {p.name: getattr(args, p.name) for p in NODE_PARAMETERS
             if getattr(args, p.name) is not None}
    outputs = tuple(name.strip() for name in args.outputs.split(',') if name.strip())
    return ReplayOptions(
        **given, gyro_topic=args.gyro_topic, torque_topic=args.torque_topic,
        rotor_torque_topic=args.rotor_torque_topic, set_pose_topic=args.set_pose_topic,
        ground_truth_topic=args.ground_truth,
        start_from_ground_truth=args.start_from_ground_truth, outputs=outputs,
        storage=args.storage)


def _default_output(bag: str) -> Path:
    path = Path(bag)
    if path.is_file():
        path = path.parent if path.parent.joinpath('metadata.yaml').is_file() else path
        return path.with_name(path.stem + '_replayed')
    return path.with_name(path.name + '_replayed')


class _StderrLog:
    """Prints the session's warnings and errors to stderr, at most :data:`MAX_LOG_LINES`, and
    its calibration line (the node's INFO line at start)."""

    def __init__(self) -> None:
        self.printed = 0

    def __call__(self, bag_time_ns: int, level: int, text: str) -> None:
        tag = _LEVEL_TAGS.get(level)
        if tag is None:
            if text.startswith('calibration: '):  # the node's start-up line, printed as is
                print(text, file=sys.stderr)
            return
        self.printed += 1
        if self.printed <= MAX_LOG_LINES:
            print(f'[{tag}] bag time {bag_time_ns * 1e-9:.3f} s: {text}', file=sys.stderr)
        elif self.printed == MAX_LOG_LINES + 1:
            print(f'[{tag}] more log lines not printed (counted in the summary)',
                  file=sys.stderr)


def _report_files(args: argparse.Namespace, output: Path, result: ReplayResult) -> None:
    if args.csv:
        write_csv(result, Path(args.csv))
        print(f'wrote {args.csv}')
        if result.errors is not None:
            error_csv = Path(args.csv).with_name(Path(args.csv).stem + '_error.csv')
            write_error_csv(result.errors, error_csv)
            print(f'wrote {error_csv}')
    plot = args.plot or (str(output) + '_error.png' if result.errors is not None else '')
    if plot:
        write_plot(result, Path(plot))
        print(f'wrote {plot}')


_GLOB_CHARACTERS = frozenset('*?[')


def is_many_bags(bag: str) -> bool:
    """Whether ``bag`` names many bags: a glob pattern, or a folder without ``metadata.yaml``
    (a folder of bags; one bag is a folder with ``metadata.yaml`` or a file)."""
    path = Path(bag).expanduser()
    if path.exists():
        return path.is_dir() and not path.joinpath('metadata.yaml').is_file()
    return bool(_GLOB_CHARACTERS & set(bag))


def _fleet_output(args: argparse.Namespace) -> Path:
    if args.output:
        return Path(args.output)
    if _GLOB_CHARACTERS & set(args.bag) and not Path(args.bag).exists():
        raise _UsageError('-o/--output is required with a glob pattern (the folder of the '
                          'output bags)')
    return _default_output(args.bag)


class _UsageError(Exception):
    """An option that does not fit many bags (one ``error:`` line)."""


def _replay_many(args: argparse.Namespace) -> int:
    from rigid_body_attitude.tools.replay.fleet import find_bags, format_table, replay_fleet
    if args.csv or args.plot:
        raise _UsageError('--csv and --plot are for one bag; many bags write OUTPUT/fleet.csv')
    if args.workers < 0:
        raise _UsageError('--workers must be at least 1')
    output = _fleet_output(args)
    bags = find_bags(args.bag)
    rows = replay_fleet(bags, output, options_from(args), scheduler=args.scheduler,
                        workers=args.workers, serial=args.serial, progress=args.progress)
    print(format_table(rows))
    failed = sum(row['status'] != 'ok' for row in rows)
    print(f'{len(rows)} bags, {failed} not replayed; wrote {output / "fleet.csv"}')
    return 0


@closed_pipe_safe
def main(argv: Sequence[str] | None = None) -> int:
    """Command-line entry point: 0 on success, 1 with ``error: ...`` for unusable input."""
    args = parser().parse_args(argv)
    try:
        if is_many_bags(args.bag):
            return _replay_many(args)
        output = Path(args.output) if args.output else _default_output(args.bag)
        result = replay_bag(args.bag, output, options_from(args), progress=args.progress,
                            keep_series=bool(args.csv or args.plot),
                            scene_given=args.scene is not None, log=_StderrLog())
        print(summary(result))
        _report_files(args, output, result)
    except (AttitudeError, OSError, UnicodeError, _UsageError) as err:
        # Bad options, scenes and bags (AttitudeError: InputError, SceneError, BagError, ...),
        # unreadable or unwritable files: the user's to fix, no traceback.
        print(f'error: {str(err).splitlines()[0] if str(err) else type(err).__name__}',
              file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print('error: interrupted; no output bag written', file=sys.stderr)
        return 130
    return 0
