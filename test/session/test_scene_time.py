"""Scene time in the dynamics session: 0 at the scene's first tick, whatever the clock's
origin, so the orbit, the field and the sensors read what the core propagator from t = 0
gives; commands never move it (before the first tick, far from the clock or before the start:
refused and counted); a reset and a backward clock jump start it again."""

from __future__ import annotations

import pytest

from rigid_body_attitude.msgs.decoders import parse_stamped
from rigid_body_attitude.msgs.types import FIXED_LAYOUTS, MAGNETIC_FIELD

from conftest import MS
from magnetic_loop import core_field_samples

SCENE = 'bdot_detumbling_commanded'  # orbit, tilted dipole, 10 Hz magnetometer, dipole input
TICK_NS = 100 * MS
TICKS = 201  # 20 s


def field_samples(sink) -> list[tuple[int, tuple[float, ...]]]:
    """(stamp [ns], measured field [T]) of every magnetometer message, in order."""
    layout = FIXED_LAYOUTS[MAGNETIC_FIELD]
    samples = []
    for topic, data in sink.simulated:
        if topic == 'imu/mag':
            parsed = parse_stamped(data, MAGNETIC_FIELD, layout.count)
            samples.append((parsed.sec * 10**9 + parsed.nanosec, tuple(parsed.body[:3])))
    return samples


def run(session, clocks, first_ns: int, ticks: int = TICKS, before=None) -> None:
    """Ticks every 100 ms of the node clock from ``first_ns``; ``before(k)`` first."""
    for k in range(ticks):
        clocks.now_ns = first_ns + k * TICK_NS
        if before is not None:
            before(k)
        session.tick(clocks.now_ns)


@pytest.mark.parametrize('first_ns', [
    1_700_000_000 * 10**9 + 370 * MS,  # wall time, 0.37 s into a second
    1000 * 10**9 + 370 * MS,           # a sim clock at 1000.37 s
    0,                                 # the node's own sim clock
])
def test_the_field_samples_are_the_core_propagators_from_t0_whatever_the_first_tick(
        open_scene, clocks, first_ns):
    session, sink = open_scene(SCENE, publish_rate=10.0)
    run(session, clocks, first_ns)
    samples = field_samples(sink)
    stamps = [stamp for stamp, _ in samples]
    if first_ns % TICK_NS == 0:  # the start on the sensor's lattice: sampled at the start
        assert stamps == [first_ns + k * TICK_NS for k in range(TICKS)]
    assert 0 <= stamps[0] - first_ns < TICK_NS and len(stamps) >= TICKS - 1
    # the same bits as the core from t = 0 at the same scene times
    assert [body for _, body in samples] == core_field_samples(SCENE, first_ns, TICK_NS, TICKS,
                                                               stamps)


def test_two_clock_origins_with_the_same_phase_give_the_same_samples(open_scene, clocks):
    runs = []
    for first_ns in (1_700_000_000 * 10**9 + 370 * MS, 1000 * 10**9 + 370 * MS):
        session, sink = open_scene(SCENE, publish_rate=10.0)
        run(session, clocks, first_ns)
        runs.append([(stamp - first_ns, body) for stamp, body in field_samples(sink)])
    assert runs[0] == runs[1] and len(runs[0]) == TICKS - 1


def far_commands(session, stamps_ns: list[int]) -> None:
    for stamp_ns in stamps_ns:
        session.dipole(*divmod(stamp_ns, 10**9), (0.2, 0.0, 0.0))


def test_commands_before_the_first_tick_are_counted_and_change_nothing(open_scene, clocks):
    """A command stamped 1.7e9 s (a wall clock) with a sim clock at 1000 s, one stamped in the
    far past and one at the clock, all before the first tick: refused as ``not_started``."""
    first_ns = 1000 * 10**9 + 370 * MS
    twin, twin_sink = open_scene(SCENE, publish_rate=10.0)
    run(twin, clocks, first_ns)
    session, sink = open_scene(SCENE, publish_rate=10.0)
    clocks.now_ns = first_ns - 50 * MS

    def before(k):
        if k == 0:
            far_commands(session, [1_700_000_000 * 10**9, 1 * 10**9, first_ns - 50 * MS])
    run(session, clocks, first_ns, before=before)
    assert session.rejection_counts()['not_started'] == 3
    assert session.commands_accepted == 0
    assert field_samples(sink) == field_samples(twin_sink)
    assert [t[2].attitude for t in sink.ticks] == [t[2].attitude for t in twin_sink.ticks]


def test_commands_far_from_the_clock_or_before_the_start_are_refused_by_reason(
        open_scene, clocks):
    """After the start: far in the future (a wall stamp against a sim clock) ``future_stamp``,
    far in the past or before the scene's start ``stale_stamp``; none blocks the next good
    command, which acts as in a twin that got only that one."""
    first_ns = 1000 * 10**9 + 370 * MS
    good_ns = first_ns + 5 * TICK_NS

    def good(session):
        def before(k):
            if k == 5:
                far_commands(session, [good_ns])
        return before
    twin, twin_sink = open_scene(SCENE, publish_rate=10.0)
    run(twin, clocks, first_ns, 20, before=good(twin))
    session, sink = open_scene(SCENE, publish_rate=10.0)
    send_good = good(session)

    def before(k):
        if k == 3:
            far_commands(session, [1_700_000_000 * 10**9, clocks.now_ns + 1001 * MS])
            far_commands(session, [1 * 10**9, first_ns - 1, clocks.now_ns - 1001 * MS])
        send_good(k)
    run(session, clocks, first_ns, 20, before=before)
    counts = session.rejection_counts()
    assert counts['future_stamp'] == 2 and counts['stale_stamp'] == 3
    assert session.commands_accepted == twin.commands_accepted == 1
    assert [t[2].attitude for t in sink.ticks] == [t[2].attitude for t in twin_sink.ticks]
    assert any(level and 'time_jump_threshold' in text for level, text in sink.logs)


@pytest.mark.parametrize('restart', ['reset', 'time_jump'])
def test_a_reset_or_a_jump_back_starts_the_scene_time_again(open_scene, clocks, restart):
    """After ``~/reset`` or a backward clock jump the next tick is scene time 0 again: the
    samples from there are those of a fresh session whose first tick is that one."""
    first_ns = 1000 * 10**9 + 370 * MS
    again_ns = 500 * 10**9 + 30 * MS  # backward, beyond time_jump_threshold
    session, sink = open_scene(SCENE, publish_rate=10.0)
    run(session, clocks, first_ns, 30)
    if restart == 'reset':
        session.reset()
    count = len(field_samples(sink))
    run(session, clocks, again_ns, 30)
    fresh, fresh_sink = open_scene(SCENE, publish_rate=10.0)
    run(fresh, clocks, again_ns, 30)
    assert field_samples(sink)[count:] == field_samples(fresh_sink)
    assert len(field_samples(fresh_sink)) == 29
    assert [t[2].attitude for t in sink.ticks[-30:]] == [t[2].attitude for t in fresh_sink.ticks]
