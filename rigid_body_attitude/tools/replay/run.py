"""``replay_bag``: one bag through the node's session into an output bag.

Opens the bag, plans its topics (:mod:`~.plan`), builds the scene's session
(:func:`rigid_body_attitude.session.settings.open_session`) with a :class:`~.sink.BagSink` as
its output and the bag time as its clocks, runs the event loop (:mod:`~.loop`) and gathers a
:class:`ReplayResult`.
"""

from __future__ import annotations

import shutil
import sys
import time
from collections import Counter
from dataclasses import dataclass, fields
from itertools import chain
from pathlib import Path
from typing import Any

from rigid_body_attitude.bag import BagError, BagReader, BagWriter
from rigid_body_attitude.core.dynamics.diagnostics import Diagnostics
from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.core.propagator import build_propagator
from rigid_body_attitude.core.dynamics.scene import Scene
from rigid_body_attitude.session.gyro import GyroSession
from rigid_body_attitude.msgs.sensor_encoders import encode_tf_message
from rigid_body_attitude.session.reports import state_summary
from rigid_body_attitude.session.sensors import mount_transforms
from rigid_body_attitude.session.settings import (
    AnySession, load_node_scene, open_session, timer_period_ns)
from rigid_body_attitude.session.times import seconds_to_ns, split_ns, to_ns
from rigid_body_attitude.tools.replay.loop import EventLoop, Progress
from rigid_body_attitude.tools.replay.mount import read_bag_mount
from rigid_body_attitude.tools.replay.options import ReplayOptions, check_options
from rigid_body_attitude.tools.replay.plan import Plan, make_plan
from rigid_body_attitude.tools.replay.sink import BagSink, LogHandler, OutputSeries
from rigid_body_attitude.tools.replay.truth import (
    ErrorStatistics, GroundTruth, GroundTruthStart, attitude_errors, read_ground_truth)

__all__ = ['ReplayResult', 'replay_bag']

Quaternion = tuple[float, float, float, float]


@dataclass
class ReplayResult:
    """What a replay read, used, rejected and published.

    Attributes:
        input_path, output_path: the bags.
        scene: the scene replayed (with the overrides).
        read: messages read per input topic.
        used: inputs used (gyro samples, commands, poses; not clock ticks).
        ticks: ticks of the output timer within the bag's time span.
        rejected: rejections by reason (the node's diagnostics counters; ``malformed``
            messages per topic in ``malformed``).
        malformed: malformed messages per input topic (the node's topic names).
        written: messages written per output topic.
        logged: the session's log lines by level (``warning``, ``error``, ``info``).
        final_stamp_ns: stamp of the last attitude output [ns] (``None``: no output).
        final_attitude: the last published attitude (w, x, y, z).
        diagnostics: the propagator's final diagnostics (energy, momentum, drift).
        series: the published values (empty unless kept, see :func:`replay_bag`).
        errors: attitude error against the ground truth (``None`` without ground truth);
            from the alignment on when the attitude was set from the ground truth.
        alignment_stamp_ns: where the attitude was set from the ground truth, if it was.
        gyro_messages: gyro messages processed (for the throughput).
        elapsed: seconds spent in the replay loop.
        notes: remarks for the user (ignored topics and the like).
        final_state: the scene's state as the node's INFO line gives it (a dynamics scene:
            energy and momentum; a gyro scene: rotation, gyro bias, alignment).
    """

    input_path: Path
    output_path: Path
    scene: Scene
    read: dict[str, int]
    used: int
    ticks: int
    rejected: Counter[str]
    malformed: Counter[str]
    written: dict[str, int]
    logged: Counter[str]
    final_stamp_ns: int | None
    final_attitude: Quaternion | None
    diagnostics: Diagnostics
    series: OutputSeries
    errors: ErrorStatistics | None
    alignment_stamp_ns: int | None
    gyro_messages: int
    elapsed: float
    notes: list[str]
    final_state: str = ''


class _NoProgress:
    """Stands in for a tqdm bar when progress is off."""

    def update(self, n: int) -> None:
        """Ignore the count."""

    def close(self) -> None:
        """Nothing to close."""


def _progress_bar(enabled: bool | None, total: int) -> Progress:
    if enabled is False:
        return _NoProgress()
    from tqdm import tqdm
    bar: Progress = tqdm(total=total, unit='msg', unit_scale=True, mininterval=0.5,
                         file=sys.stderr, disable=None if enabled is None else False,
                         leave=False)
    return bar


def _output_custom_data(reader: BagReader, scene: Scene, options: ReplayOptions,
                        input_path: Path) -> dict[str, str]:
    custom = dict(reader.custom_data)
    custom.update({
        'replay_source_bag': str(input_path),
        'replay_scene': scene.name,
        'replay_integrator': scene.integrator,
        'replay_settings': ', '.join(f'{item.name}={getattr(options, item.name)!r}'
                                     for item in fields(options)),
    })
    return custom


@dataclass
class _Run:
    """What the replay loop leaves for the result."""

    session: AnySession
    sink: BagSink
    loop: EventLoop | None
    gyro_messages: int
    elapsed: float
    publish_rate: float
    notes: list[str]


def replay_bag(input_path: str | Path, output_path: str | Path,
               options: ReplayOptions = ReplayOptions(), *, progress: bool | None = False,
               keep_series: bool = True, scene_given: bool = True,
               log: LogHandler | None = None) -> ReplayResult:
    """Replay the bag at ``input_path`` into a new bag at ``output_path`` (must not exist).

    Raises :class:`~rigid_body_attitude.bag.BagError` for a missing or unreadable bag, a
    topic not in it (the message lists the bag's topics) or one of an unusable type;
    :class:`InputError` or :class:`~rigid_body_attitude.core.errors.SceneError` for bad options
    or scene. Bad messages do not raise: the session rejects and counts them, as the node
    does. On any error no output bag is left behind. ``progress``: ``None`` shows a bar on a
    terminal only. ``keep_series``: keep the published values in memory (``series``; always
    with a ground-truth topic, whose error statistics need them). ``scene_given=False`` adds
    a note when the default dynamics scene meets a gyro bag. ``log`` gets the session's log
    lines (bag time [ns], level, text; throttled by the session on bag time).
    """
    values = check_options(options)
    input_path, output_path = Path(input_path), Path(output_path)
    scene = load_node_scene(options.scene, options.integrator, options.step,
                            options.torque_timeout)
    if output_path.exists():
        raise BagError(f'Output bag {str(output_path)!r} already exists; choose another '
                       f'with -o/--output or remove it')
    with BagReader(input_path) as reader:
        plan = make_plan(reader, scene, build_propagator(scene).input_names, options,
                         scene_given)
        truth = (read_ground_truth(reader, plan.ground_truth_topic)
                 if plan.ground_truth_topic else None)
        topics = plan.read_topics(reader.topics)
        total = sum(reader.message_counts.get(topic, 0) for topic in topics)
        custom = _output_custom_data(reader, scene, options, input_path)
        try:
            with BagWriter(output_path, storage=options.storage, custom_data=custom) as bag:
                sink = BagSink(bag, plan.outputs, keep_series or truth is not None,
                               scene.name, log)
                run = _replay(reader, sink, scene, values, plan, truth, options,
                              _progress_bar(progress, total))
            if sink.start is not None and sink.start.aligned_at_ns is None:
                raise InputError(f'Expected an output at or after stamp '
                                 f'{sink.start.stamp_ns * 1e-9:.9f} s to start from the '
                                 f'ground truth; the last is at {_last_text(run)}')
        except BaseException:
            if output_path.exists():
                shutil.rmtree(output_path)
            raise
    return _result(input_path, output_path, scene, plan, truth, run)


def _replay(reader: BagReader, sink: BagSink, scene: Scene, values: dict[str, Any], plan: Plan,
            truth: GroundTruth | None, options: ReplayOptions, bar: Progress) -> _Run:
    """Build the session on the bag's clock, mount its sensor and run the event loop over the
    bag's messages."""
    mount = read_bag_mount(reader, plan.gyro_topic, values['body_frame'],
                           bool(values['mount_rpy']))
    messages = reader.messages(plan.read_topics(reader.topics))
    first = next(messages, None)
    if first is not None:
        sink.now_ns = first[1]  # the session's period starts at the first message

    def clock_ns() -> int:
        return sink.now_ns

    def monotonic() -> float:
        return sink.now_ns / 1e9  # correctly rounded: whole seconds stay exact

    session = open_session(scene, values, sink, clock_ns, monotonic)
    problem = session.check(values)
    if problem:
        raise InputError(problem)
    sink.set_frames(values['world_frame'], values['body_frame'])
    if first is not None:
        _write_mounts(sink, scene, values['body_frame'])
    if truth is not None and options.start_from_ground_truth is not None:
        sink.start_from(GroundTruthStart(truth, seconds_to_ns(options.start_from_ground_truth)),
                        session)
    if isinstance(session, GyroSession):
        mount.apply(session)
    loop, count = None, 0
    begin = time.perf_counter()
    try:
        if first is not None:
            loop = EventLoop(session, sink, plan, timer_period_ns(values['publish_rate']),
                             first[1], values['lockstep'])
            if isinstance(session, GyroSession) and loop.gyro_handler is not None:
                loop.gyro_handler = mount.gate(session, loop.gyro_handler)
            count = loop.run(chain([first], messages), bar)
        sink.flush()
    finally:
        bar.close()
    return _Run(session, sink, loop, count, time.perf_counter() - begin,
                values['publish_rate'], mount.notes)


def _write_mounts(sink: BagSink, scene: Scene, body_frame: str) -> None:
    """The simulated sensors' mounts on ``/tf_static`` at the first message's time, as the
    node publishes them when it starts (when the outputs hold ``/tf_static``)."""
    transforms = mount_transforms(scene, body_frame)
    if transforms:
        sink.static_transforms(encode_tf_message(*split_ns(sink.now_ns), transforms))


def _final_stamp_ns(run: _Run) -> int | None:
    session = run.session
    if isinstance(session, GyroSession):
        return to_ns(*session.output_stamp) if run.sink.attitude_outputs else None
    return run.sink.last_stamp_ns


def _last_text(run: _Run) -> str:
    last = _final_stamp_ns(run)
    return 'none' if last is None else f'{last * 1e-9:.9f} s'


def _result(input_path: Path, output_path: Path, scene: Scene, plan: Plan,
            truth: GroundTruth | None, run: _Run) -> ReplayResult:
    session, sink, loop = run.session, run.sink, run.loop
    series = sink.series if sink.series is not None else OutputSeries()
    stamps, attitudes, _ = series.attitude_array()
    aligned_at = sink.start.aligned_at_ns if sink.start is not None else None
    errors = None
    notes = list(plan.notes) + run.notes
    if truth is not None:
        errors = attitude_errors(stamps, attitudes, truth.stamps_ns, truth.attitudes)
        if truth.malformed:
            notes.append(f'{truth.malformed} malformed ground-truth messages skipped')
    if errors is not None and aligned_at is not None:
        errors = errors.within(aligned_at, int(stamps[-1]))
    ticks = loop.ticks if loop is not None else 0
    if not isinstance(session, GyroSession) and not ticks:
        notes.append(f'no clock tick within the bag\'s time span at publish_rate '
                     f'{run.publish_rate:g} Hz (ticks at multiples of '
                     f'{timer_period_ns(run.publish_rate) * 1e-9:g} s): nothing propagated')
    return ReplayResult(
        input_path=input_path, output_path=output_path, scene=scene,
        read=dict(loop.read) if loop is not None else {}, used=session.accepted_count(),
        ticks=ticks, rejected=session.rejection_counts(),
        malformed=Counter(session.malformed_by_topic), written=sink.written(),
        logged=Counter(sink.logged), final_stamp_ns=_final_stamp_ns(run),
        final_attitude=sink.last_attitude, diagnostics=session.propagator.diagnostics(),
        series=series, errors=errors, alignment_stamp_ns=aligned_at,
        gyro_messages=run.gyro_messages, elapsed=run.elapsed, notes=notes,
        final_state=state_summary(session.propagator, session.strapdown_state()))
