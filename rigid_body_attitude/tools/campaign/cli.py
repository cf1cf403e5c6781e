"""The ``campaign`` command line.

``campaign SPEC --out DIR [--scheduler ADDRESS | --workers N | --serial]`` runs (or resumes)
a Monte-Carlo campaign; ``campaign replay BAGS... --out DIR [replay options]`` replays a fleet
of bags (folders or glob patterns), every option after the bags as for ``replay``. Mistakes
(bad options, specs, bags, an unreachable scheduler) print one ``error: ...`` line and exit
with 2; an interrupted campaign exits with 130 and resumes when run again.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from typing import NoReturn

import numpy as np

from rigid_body_attitude.console import closed_pipe_safe
from rigid_body_attitude.core.errors import AttitudeError
from rigid_body_attitude.tools.campaign.engine import CampaignResult, run_campaign
from rigid_body_attitude.tools.replay.fleet import find_bags, format_table, replay_fleet
from rigid_body_attitude.tools.campaign.spec import load_spec
from rigid_body_attitude.tools.campaign.statistics import METRICS, UNITS

__all__ = ['main']

USAGE_ERROR = 2


class _Parser(argparse.ArgumentParser):
    """argparse with its mistakes as one ``error:`` line (exit 2)."""

    def error(self, message: str) -> NoReturn:
        """Print ``error: message`` and exit with 2."""
        print(f'error: {message}', file=sys.stderr)
        sys.exit(USAGE_ERROR)


def _engine_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('--out', required=True, metavar='DIR', help='results folder')
    where = parser.add_mutually_exclusive_group()
    where.add_argument('--scheduler', default='', metavar='ADDRESS',
                       help='an existing dask.distributed scheduler (tcp://host:8786)')
    where.add_argument('--workers', type=int, default=0, metavar='N',
                       help='worker processes of the local cluster (default: one per CPU)')
    where.add_argument('--serial', action='store_true',
                       help='run in this process, without Dask')
    parser.add_argument('--progress', action=argparse.BooleanOptionalAction, default=None,
                        help='progress bar (default: on a terminal)')


def campaign_parser() -> argparse.ArgumentParser:
    """The ``campaign SPEC`` parser."""
    parser = _Parser(prog='campaign', allow_abbrev=False,
                     description='Run a Monte-Carlo campaign of a scene with dispersed '
                                 'parameters on Dask; `campaign replay BAGS...` replays a '
                                 'fleet of bags.')
    parser.add_argument('spec', help='campaign spec (YAML; examples in config/campaigns/)')
    _engine_options(parser)
    return parser


def fleet_parser() -> argparse.ArgumentParser:
    """The ``campaign replay BAGS...`` parser (replay's own options are passed on)."""
    parser = _Parser(prog='campaign replay', allow_abbrev=False,
                     description='Replay many bags as Dask tasks; one table of their '
                                 'reports (and errors against ground truth where present). '
                                 'Other options are replay\'s (see replay --help).')
    parser.add_argument('bags', nargs='+', help='bag folders, bag files, folders of bags or '
                                                'glob patterns')
    _engine_options(parser)
    return parser


def _summary(result: CampaignResult) -> str:
    lines = [f'{result.runs} runs, {result.failed} failed'
             + ''.join(f'; {reason}: {count}' for reason, count in result.failures.items()
                       if count),
             f'chunks: {result.chunks_run} run, {result.chunks_resumed} already finished; '
             f'{result.total_seconds:.1f} s']
    last = result.times[-1]
    for name in METRICS:
        column = result.statistics[name][:, -1]
        text = ', '.join(f'{value:.4g}' for value in column)
        if np.all(np.isnan(column)):
            text = 'none: every run turns slower than statistics.nutation_min_rate' if (
                name == 'nutation_deg') else 'none'
        lines.append(f'{name} at {last:g} s (percentiles) [{UNITS[name]}]: {text}')
    if result.closed_loop:
        loop = result.closed_loop
        lines.append(f'closed loop: {loop["settled"]} of {result.runs - result.failed} runs '
                     f'settled within {loop["settling_deg"]:g} deg')
        for name, values in loop['percentiles'].items():
            shown = ', '.join(f'{value:.4g}' for value in values)
            lines.append(f'{name} (percentiles) [{UNITS[name]}]: {shown}')
    for name, values in result.actuators.items():
        shown = ', '.join(f'{value:.4g}' for value in values)
        lines.append(f'{name} (percentiles) [{UNITS[name]}]: {shown}')
    lines.append(f'wrote {result.folder}/statistics.csv, summary.json, summary.png, chunks/')
    return '\n'.join(lines)


def _run(argv: list[str]) -> int:
    if argv[:1] == ['replay']:
        return _fleet(argv[1:])
    args = campaign_parser().parse_args(argv)
    if args.workers < 0:
        campaign_parser().error('--workers must be at least 1')
    spec = load_spec(args.spec)
    result = run_campaign(spec, args.out, scheduler=args.scheduler, workers=args.workers,
                          serial=args.serial, progress=args.progress)
    print(_summary(result))
    return 0


def _fleet(argv: list[str]) -> int:
    from rigid_body_attitude.tools.replay.cli import options_from, parser as replay_parser
    args, rest = fleet_parser().parse_known_args(argv)
    replay = replay_parser()
    replay.error = fleet_parser().error  # type: ignore[method-assign]
    options = options_from(replay.parse_args(['-', *rest]))
    bags = [bag for pattern in args.bags for bag in find_bags(pattern)]
    rows = replay_fleet(bags, args.out, options, scheduler=args.scheduler,
                        workers=args.workers, serial=args.serial, progress=args.progress)
    print(format_table(rows))
    failed = sum(row['status'] != 'ok' for row in rows)
    print(f'{len(rows)} bags, {failed} not replayed; wrote {args.out}/fleet.csv')
    return 0


@closed_pipe_safe
def main(argv: Sequence[str] | None = None) -> int:
    """Command-line entry point: 0 on success, 2 with ``error: ...`` for unusable input."""
    try:
        return _run(list(sys.argv[1:] if argv is None else argv))
    except SystemExit as done:  # argparse: --help (0) or a usage error (2, printed)
        return done.code if isinstance(done.code, int) else USAGE_ERROR
    except (AttitudeError, OSError, UnicodeError) as err:
        print(f'error: {str(err).splitlines()[0] if str(err) else type(err).__name__}',
              file=sys.stderr)
        return USAGE_ERROR
    except KeyboardInterrupt:
        print('error: interrupted; finished chunks are kept: run again to resume',
              file=sys.stderr)
        return 130
