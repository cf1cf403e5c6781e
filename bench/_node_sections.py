"""Sections of ``docs/performance.md`` about the node beyond the throughput tables.

Used by ``bench/performance_report.py``; each function takes saved results and returns
Markdown lines:

* :func:`sweeps_section`: latency (p99 and maximum) of the node and the fast relay in every one
  of several repeated ``bench/node_throughput.py`` sweeps (issue 13, item 5);
* :func:`mixed_soak_section`: ``bench/soak_mixed.py`` (issue 11, item 6);
* :func:`dynamics_cpu_section`: ``bench/node_dynamics_cpu.py`` (issue 13, item 2).
"""

from __future__ import annotations

from typing import Dict, List, Optional

#: p99 latency target up to 5 kHz (ms), issue 13 item 5.
TARGET_P99_MS = 1.0
TARGET_P99_UP_TO_HZ = 5000.0
#: RSS growth target from minute 1 to 10 of the mixed soak, issue 11 item 6.
TARGET_MIXED_GROWTH_KIB = 1024


def _fmt(value: Optional[float], digits: int = 2) -> str:
    return '–' if value is None else f'{value:.{digits}f}'


def _rows_by_rate(sweep: dict, label: str) -> Dict[float, dict]:
    target = sweep['targets'].get(label)
    return {} if target is None else {row['rate_hz']: row for row in target['rows']}


def sweeps_section(sweeps: List[dict], target: str = 'node',
                   yardstick: str = 'fast_relay') -> List[str]:
    """One table per sweep: p99 / max latency, loss and CPU of ``target`` and ``yardstick``
    per rate, and the verdicts of issue 13 item 5 per sweep."""
    if not sweeps:
        return []
    lines = ['## Latency in repeated sweeps', '',
             f'{len(sweeps)} sweeps of `bench/node_throughput.py` in a row (fresh processes '
             f'per window; {_windows_text(sweeps)}). Per rate: p99 / maximum latency (ms), '
             'lost, CPU (% of a core) of the node with its default parameters and of the '
             'fast relay in the same sweep; the CPU of the bench\'s own publisher and '
             'subscriber in the node\'s row and in the relay\'s (the same messages in both, '
             'though each also answers its peer\'s acknowledgements); and the other load on '
             'the machine (cores). '
             f'Target: node p99 ≤ {TARGET_P99_MS:g} ms at every rate up to '
             f'{TARGET_P99_UP_TO_HZ:.0f} Hz, and above that no worse than the fast relay\'s; '
             'zero loss to 20 kHz; 1 kHz CPU no worse than the fast relay\'s.', '']
    for number, sweep in enumerate(sweeps, 1):
        node, relay = _rows_by_rate(sweep, target), _rows_by_rate(sweep, yardstick)
        lines += [f'**Sweep {number}** (load average at start '
                  f'{sweep["machine"]["load_average_at_start"]})', '',
                  '| rate (Hz) | node p99 / max | node lost | node CPU | relay p99 / max | '
                  'relay lost | relay CPU | bench pub + sub CPU | other load | verdict | '
                  'node / relay p99 per window |',
                  '|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|---|']
        for rate in sorted(node):
            mine, theirs = node[rate], relay.get(rate, {})
            lines.append(
                f'| {rate:.0f} | {_fmt(mine["latency_p99_ms"])} / '
                f'{_fmt(mine["latency_max_ms"], 1)} | {mine["lost"]} | '
                f'{mine["cpu_percent"]:.1f} | {_fmt(theirs.get("latency_p99_ms"))} / '
                f'{_fmt(theirs.get("latency_max_ms"), 1)} | {theirs.get("lost", "–")} | '
                f'{_fmt(theirs.get("cpu_percent"), 1)} | {_bench_cpu(mine)} / '
                f'{_bench_cpu(theirs)} | {mine["other_load_cores"]:.2f} | '
                f'{_latency_verdict(rate, mine, theirs)} | {_window_p99(mine)} / '
                f'{_window_p99(theirs)} |')
        lines.append('')
    return lines + _sweeps_summary(sweeps, target, yardstick)


def _windows_text(sweeps: List[dict]) -> str:
    """How long the windows were and how many a row pools, over all ``sweeps``."""
    kinds = sorted({(sweep['duration_s'], sweep.get('repeats', 1)) for sweep in sweeps})
    return '; '.join(
        f'{duration:g} s windows' if repeats == 1 else
        f'{repeats} interleaved {duration:g} s windows per row, latency percentiles over all '
        f'their poses, the median window\'s CPU' for duration, repeats in kinds)


def _window_p99(row: dict) -> str:
    """Each window's p99 (ms) of a pooled row, or '–' for a single window."""
    windows = row.get('windows')
    if not windows:
        return '–'
    return ' '.join(_fmt(window['latency_p99_ms']) for window in windows)


def _bench_cpu(row: dict) -> str:
    """The bench publisher's and subscriber's CPU in one row (% of a core), or '–'."""
    if 'publisher_cpu_percent' not in row:
        return '–'
    return f'{row["publisher_cpu_percent"] + row["subscriber_cpu_percent"]:.1f}'


#: A row whose maximum latency exceeds this has a stall (the Fast DDS listener's 333 ms one
#: before the package profile bounded it to 10 ms: ``bench/NOTES.md``, section 9).
STALL_MS = 100.0


def _sweeps_summary(sweeps: List[dict], target: str, yardstick: str) -> List[str]:
    """Across all sweeps: rows met, rows with a stall, the largest maxima."""
    pairs = [(rate, mine, _rows_by_rate(sweep, yardstick).get(rate, {}))
             for sweep in sweeps for rate, mine in sorted(_rows_by_rate(sweep, target).items())]
    met = sum(_latency_verdict(rate, mine, theirs).startswith('met')
              for rate, mine, theirs in pairs)

    def stalls(rows: List[dict]) -> str:
        maxima = [row.get('latency_max_ms') for row in rows]
        stalled = [value for value in maxima if value is not None and value > STALL_MS]
        return f'{len(stalled)} of {len(rows)}'

    def largest(rows: List[dict]) -> str:
        maxima = [row['latency_max_ms'] for row in rows if row.get('latency_max_ms') is not None]
        return _fmt(max(maxima), 1) if maxima else '–'

    low = [mine for rate, mine, _ in pairs if rate <= TARGET_P99_UP_TO_HZ]
    high = [mine for rate, mine, _ in pairs if rate > TARGET_P99_UP_TO_HZ]
    relay_rows = [theirs for _, _, theirs in pairs if theirs]
    return [f'**Across the {len(sweeps)} sweeps:** the node met the latency and loss target in '
            f'{met} of {len(pairs)} rows; rows with a maximum latency over {STALL_MS:g} ms: '
            f'node {stalls([mine for _, mine, _ in pairs])}, fast relay {stalls(relay_rows)}. '
            f'Largest node maximum up to {TARGET_P99_UP_TO_HZ:.0f} Hz: {largest(low)} ms; '
            f'above: {largest(high)} ms.{_single_windows(pairs)}', '']


def _single_windows(pairs: List[tuple]) -> str:
    """How the node's single windows of pooled rows fared against the target: up to
    :data:`TARGET_P99_UP_TO_HZ`, p99 over :data:`TARGET_P99_MS`; above, p99 over the fast
    relay's pooled row ('' when no row pools windows)."""
    low = [window['latency_p99_ms'] for rate, mine, _ in pairs if rate <= TARGET_P99_UP_TO_HZ
           for window in mine.get('windows', [])]
    high = [(window['latency_p99_ms'], theirs.get('latency_p99_ms'))
            for rate, mine, theirs in pairs if rate > TARGET_P99_UP_TO_HZ
            for window in mine.get('windows', [])]
    if not low and not high:
        return ''
    over = sum(p99 is None or p99 > TARGET_P99_MS for p99 in low)
    behind = sum(mine is None or (theirs is not None and mine > theirs) for mine, theirs in high)
    return (f' Single windows of the node: p99 over {TARGET_P99_MS:g} ms in {over} of '
            f'{len(low)} up to {TARGET_P99_UP_TO_HZ:.0f} Hz; above, over the fast relay\'s '
            f'pooled p99 in {behind} of {len(high)}.')


def _latency_verdict(rate: float, node: dict, relay: dict) -> str:
    """'met' / 'NOT met' for one rate of one sweep (latency and loss)."""
    p99 = node['latency_p99_ms']
    if node['lost'] or p99 is None:
        return 'NOT met (loss)'
    if rate <= TARGET_P99_UP_TO_HZ:
        return 'met' if p99 <= TARGET_P99_MS else 'NOT met'
    theirs = relay.get('latency_p99_ms')
    if theirs is None:
        return 'met (relay lost all)'
    return 'met' if p99 <= theirs else f'NOT met ({p99 / theirs:.1f}× relay)'


def mixed_soak_section(soak: Optional[dict]) -> List[str]:
    """The mixed-traffic soak: RSS growth, loss, replies."""
    if soak is None:
        return []
    mixed = soak['mixed']
    growth = soak['growth_kib']
    samples = ', '.join(f'{s["rss_kib"] / 1024:.2f}' for s in soak['samples']
                        if abs(s['minute'] - round(s['minute'])) < 0.09)
    return [
        '## Mixed-traffic soak', '',
        f'`python bench/soak_mixed.py` ({soak["minutes"]:g} minutes): `{soak["command"]}` '
        f'with `imu` at {soak["gyro_rate_hz"]:.0f} Hz and, at {soak["mixed_rate_hz"]:.0f} Hz '
        'each, a `set_pose`, a `set_parameters` request (`max_dt`, `body_frame`) and a '
        '`~/reset` call.', '',
        f'- RSS from minute 1 to {soak["minutes"]:g}: {soak["rss_minute_1_kib"] / 1024:.2f} → '
        f'{soak["rss_end_kib"] / 1024:.2f} MiB ({growth:+d} KiB; least-squares slope '
        f'{soak["growth_kib_per_minute"]:+.1f} KiB/min). Target ≤ '
        f'{TARGET_MIXED_GROWTH_KIB // 1024} MiB: '
        f'{"met" if growth <= TARGET_MIXED_GROWTH_KIB else "NOT met"}. '
        f'RSS each minute (MiB): {samples}.',
        f'- gyro samples: sent {soak["sent"]}, poses received {soak["received"]}, lost '
        f'{soak["lost"]}; latency p50 {_fmt(soak["latency_p50_ms"])} ms, p99 '
        f'{_fmt(soak["latency_p99_ms"])} ms, max {_fmt(soak["latency_max_ms"], 1)} ms'
        + _worst_when(soak) + '.',
        f'- mixed ticks {mixed["ticks"]}: parameter replies {mixed["parameter_replies"]} '
        f'(refused {mixed["parameters_refused"]}), reset replies {mixed["reset_replies"]} '
        f'(failed {mixed["resets_failed"]}); the last few requests were in flight at the end.',
        f'- node CPU {soak["cpu_percent"]:.1f} % of a core; ' + _soak_load(soak), '']


def _soak_load(soak: dict) -> str:
    """The machine's other load during the soak: other processes' run times (results since
    session 10), or /proc/stat's busy cores (older results; it does not add up on this VM)."""
    if 'other_load_cores' in soak:
        return (f'the other processes (not the node and its peers) used '
                f'{soak["other_load_cores"]:.2f} cores.')
    return (f'the whole machine was {soak["machine_busy_cores"]:.2f} cores busy by /proc/stat '
            '(all processes, other engineers\' included).')


def _worst_when(soak: dict) -> str:
    """When the soak's worst latency happened, and the mixed process's Fast DDS profile
    (results written before these were recorded have neither)."""
    if soak.get('latency_max_at_s') is None:
        return ''
    profile = soak.get('mixed_profile', '')
    return (f' ({soak["latency_max_at_s"]:.1f} s into the soak; the mixed-traffic process on '
            f'{"Fast DDS defaults" if profile == "none" else "the package profile"})')


def dynamics_cpu_section(result: Optional[dict]) -> List[str]:
    """Node CPU per dynamics scene, unsubscribed and subscribed, beside the propagator."""
    if result is None:
        return []
    targets = result['targets_percent']
    lines = [
        '## Dynamics scenes: the node\'s CPU', '',
        f'`python bench/node_dynamics_cpu.py`: the installed node per shipped dynamics scene '
        f'at default parameters (50 Hz ticks), {result["duration_s"]:g} s windows after '
        f'{result["warmup_s"]:g} s of warm-up; CPU of the whole process (% of one core) with '
        'nobody subscribed and with every output subscribed; "propagator alone" is the '
        'scene\'s `DynamicsPropagator.advance_to` at the same tick times in one process, '
        'warm, without ROS: the difference is what the node adds (wake-ups, outputs, '
        'diagnostics, and the propagator running with cold caches between ticks). Targets: '
        f'≤ {targets["unsubscribed"]:g} % unsubscribed, ≤ {targets["subscribed"]:g} % '
        'subscribed.', '',
        '| scene | unsubscribed | subscribed | propagator alone | node − propagator '
        '(unsubscribed) | pose received (/s) | other load (cores) | verdict |',
        '|---|---:|---:|---:|---:|---:|---:|---|']
    for row in result['rows']:
        alone, subscribed = row['unsubscribed'], row['subscribed']
        ok = (alone['node_cpu_percent'] <= targets['unsubscribed']
              and subscribed['node_cpu_percent'] <= targets['subscribed'])
        lines.append(
            f'| {row["scene"]} | {alone["node_cpu_percent"]:.1f} | '
            f'{subscribed["node_cpu_percent"]:.1f} | {row["propagator_cpu_percent"]:.1f} | '
            f'{alone["node_cpu_percent"] - row["propagator_cpu_percent"]:+.1f} | '
            f'{row["received_per_s"].get("pose", 0.0):.1f} | '
            f'{alone["other_load_cores"]:.2f} / {subscribed["other_load_cores"]:.2f} | '
            f'{"met" if ok else "NOT met"} |')
    if result.get('note'):
        lines += ['', result['note'] + '.']
    return lines + ['']
