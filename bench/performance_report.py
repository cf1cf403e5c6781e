"""Write ``docs/performance.md``: the node's throughput and soak, core step costs and batch.

Composes, from saved results in ``--results-dir`` (default ``bench/results/node``):

* ``throughput.json`` and ``soak.json`` of ``bench/node_throughput.py`` (run with
  ``--results-dir bench/results/node``), rendered by its own ``bench/_report.py`` (tables,
  thread breakdown, verdicts, the PNG plot);
* ``core_steps.json`` of ``bench/core_step_costs.py --json`` and ``batch.json`` of
  ``bench/batch_throughput.py --json``;
* ``scenes.json`` of ``bench/dynamics_scenes.py`` and ``effect_costs.json`` of
  ``bench/effect_costs.py`` in ``bench/results/dynamics`` (section "Dynamics scenes and
  effects", issue 13, with the batch with effects from ``batch.json``);
* ``throughput*.json`` of ``bench/campaign_throughput.py --json`` in
  ``bench/results/campaign`` (section "Campaigns on Dask");
* a closing section listing every target of issue 7 with the measured figure and, where one
  is missed, by how much and what limits it (``LIMITS``: from the profiles described there).

Usage (the commands that produced the committed report)::

    NODE='.venv/bin/propagation_node --ros-args -p scene:=strapdown \\
      -p qos_overrides./imu.subscription.reliability:=reliable \\
      -p qos_overrides./imu.subscription.depth:=10000 \\
      -p qos_overrides./pose.publisher.depth:=10000'
    python bench/node_throughput.py --targets node,relay,fast_relay --node-cmd "$NODE" \\
      --results-dir bench/results/node --report /tmp/throughput.md
    python bench/node_throughput.py --soak --targets node --node-cmd "$NODE" \\
      --results-dir bench/results/node --report /tmp/soak.md
    python bench/core_step_costs.py --json bench/results/node/core_steps.json
    python bench/batch_throughput.py --json bench/results/node/batch.json
    python bench/dynamics_scenes.py --before bench/results/dynamics/scenes_before.json \\
      --json bench/results/dynamics/scenes.json
    python bench/effect_costs.py --json bench/results/dynamics/effect_costs.json
    python bench/campaign_throughput.py --repeats 2 --json bench/results/campaign/throughput.json
    python bench/campaign_throughput.py --steps 1000 --repeats 1 \\
      --json bench/results/campaign/throughput_1000steps.json
    python bench/performance_report.py
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
import sys
from typing import Optional

BENCH = Path(__file__).resolve().parent
REPO = BENCH.parent
sys.path.insert(0, str(BENCH))

import _campaign_section  # noqa: E402
import _node_sections  # noqa: E402
import _report  # noqa: E402

#: What limits the 1 kHz CPU figure, from per-thread CPU and context switches
#: (``/proc/<pid>/task/*``), gdb, perf and py-spy at 1 kHz: ``bench/NOTES.md`` sections 3 and 3a.
LIMITS = """\
**What limits the 1 kHz CPU figure.** At 1 kHz every gyro message is its own wake-up (a 1 ms
batch would break the 1 ms latency target), and on this VM each wake-up of a thread costs
tens of µs whatever the thread then does (the node idling with only its 50 Hz timer uses
1 % of a core: ~200 µs per wake-up). The figure is therefore set by how many threads wake
per message, not by the node's arithmetic:

- Fast DDS with its defaults woke its event thread on every reliable sample sent to another
  process (`nackSupressionDuration` 0: the suppression timer restarts per sample; gdb caught
  1 791 of 1 849 event-thread notifications there), and the Linux scheduler let each woken
  thread preempt its waker, so the gyro loop woke, blocked on the reader's mutex still held by
  the receive thread, and woke again: ≈ 10 context switches per message in the node. The node
  now ships a Fast DDS profile (10 ms NACK suppression) and runs its threads under
  `SCHED_BATCH` (`cpu_scheduling`, `bench/NOTES.md` section 3a): ≈ 4 switches per message, and
  in the same runs 11.2–12.5 % of a core against 14.3–15.5 % with Fast DDS's defaults and the
  default policy.
- What is left per message: the receive thread's wake-up (≈ 2–3 % of a core), the gyro loop's
  wake-up, take and publish (≈ 8–9 %; publishing wakes the subscriber process, whose receive
  thread then preempts the loop 1.6 times per message, `perf sched`: that process's threads
  are not ours to set),
  and the event thread (≈ 0.3 %). A stripped relay with the same settings and no physics
  measured 8.8–11.5 % on this machine in this session, so the floor under this middleware is
  at about the target; the node sits 1–2 points above it (the Python of the gyro path,
  ≈ 7 µs warm, 20–30 µs with cold caches once per millisecond).
- Already removed: the executor (≈ 100 µs of Python per message), message objects (raw CDR
  in and out), outputs nobody subscribes to, NumPy arrays per sample (the gyro state is plain
  floats), rclpy's per-call publisher wrapper, garbage-collector pauses. Tried without gain:
  handling messages in the receive thread itself (`rcl_subscription_set_on_new_message_callback`),
  pinning the process to one core, a 100 µs scheduler slice for the node's threads,
  UDP instead of shared memory; `RMW_FASTRTPS_PUBLICATION_MODE=ASYNCHRONOUS` saves no CPU at
  1 kHz (one more thread hand-over per message) but the node now uses it for its latency at
  10–20 kHz (`bench/NOTES.md`, section 10).

Under 10 % at 1 kHz on this machine would need fewer wake-ups per message than rclpy over
rmw_fastrtps allows (another rmw, or the gyro path in a C++ component)."""


#: How the node was configured for the throughput runs, and why.
QOS_NOTE = """\
**Configuration.** The node runs as a user would start it, with its default parameters and QoS
(`rigid_body_attitude/ros/qos.py`): inputs RELIABLE, KEEP_LAST 5000; outputs RELIABLE, KEEP_LAST
5000, the package's Fast DDS profile, and asynchronous publication (the node sets
`RMW_FASTRTPS_PUBLICATION_MODE=ASYNCHRONOUS` for itself: a Fast DDS thread sends while the gyro
loop handles the next message; `bench/NOTES.md`, section 10). The publisher, the subscriber and
the relays use RELIABLE, KEEP_LAST 10000; the publisher and the subscriber load the package's
Fast DDS profile as the README asks of processes that talk to the node (`--endpoint-profile`),
the relays run on Fast DDS's defaults. At 20 kHz the publisher, the node and the subscriber
together need about the two cores (a publisher that falls short of the rate is marked
"(short)"), so that row also measures the machine, not the node alone."""


#: What caused the ~300 ms latency stalls, and what removed them (issue 13, item 5).
STALLS_NOTE = """\
**The ~300 ms stalls: found in Fast DDS, bounded by the package profile.** Before this
session about one run in three had one stall: the subscriber received no pose for 225–335 ms,
then all of them within 1 ms (17 of 40 node rows in session 3's five sweeps). Measured this
session (`bench/NOTES.md`, section 9): the node handles and publishes every gyro message on
time through a stall (a 1 ms in-process sampler); uprobes on Fast DDS show the node's writer
pushing every sample of the stall (334 of 334 successful) into the subscriber's shared-memory
port while the subscriber's listener thread sleeps in `wait_pop` until its own timeout,
333 ms (Fast DDS 2.14's default `healthy_check_timeout_ms` 1000 / 3), right after that
process handled a peer's participant re-announcement: a lost wake-up in the *receiving*
process. The package's `config/fastdds.xml` now sets `healthy_check_timeout_ms` 30 (the
listener wakes every 10 ms, so such a stall lasts at most 10 ms). It protects the node's own
inputs, and the README tells users to give the same file to the processes that subscribe to
the node; the bench's publisher and subscriber load it (`--endpoint-profile`), the relays keep
Fast DDS's defaults. In interleaved 1 kHz runs: bench endpoints with the default check 2 of 8
runs stalled (263 and 334 ms); with 30 ms 0 of 24 (maximum 9.4 ms); the profile on the node
alone, 4 of 8. The sweeps above are with the profile on both ends."""


#: What caused the node's multi-millisecond latency tails at 10-20 kHz (issue 13, item 5).
TAILS_NOTE = """\
**The millisecond tails at 5–20 kHz: Fast DDS's sender spinning under `SCHED_BATCH`.** After
the stalls were gone the node still lost to the fast relay at 15 kHz in 4 of 10 sweeps (session
5): episodes of 100–300 ms at 2–5 ms latency. `perf sched` caught the cause (`bench/NOTES.md`,
section 11): the asynchronous sender thread `dds.asyn.0.1` ran up to 3.9 ms without a break,
going round `FlowControllerImpl::run` because another thread held the writer's mutex; that
thread (the node's event thread, which the sender had woken) sat runnable on the same CPU, and
under `SCHED_BATCH` a woken thread never preempts the running one, so only the 4 ms scheduler
tick ended the spin. With the sender threads on `SCHED_IDLE` any thread woken on their CPU
preempts them: in 8 interleaved 15 kHz runs that node's p99 was 0.65–1.74 ms against the fast
relay's 1.46–4.55 ms (ahead in 8 of 8; the all-`SCHED_BATCH` node 0.81–4.14 ms, ahead in 6 of
8). An idle-policy thread starves when other threads keep the CPUs busy (two CPU-bound
processes: p99 64–909 ms at 1–5 kHz) and is the last to run when other processes fill both CPUs
for a moment (both busy 30 ms out of every 330 ms: p99 12.3–21.4 ms at 2 kHz against 7.4–8.9 ms
with the senders on `SCHED_BATCH`, section 12), while the spin it cures only cost the lead at
15–20 kHz. So the senders run under `SCHED_IDLE` only while gyro input comes at
`idle_senders_above_hz` (12 kHz) or more, and go back to `SCHED_BATCH` below two thirds of it;
while they are idle the node reads their run-queue waits every 0.1 s and puts them on
`SCHED_BATCH` for good when one starves (`rigid_body_attitude/ros/sender_threads.py`). A
process that could not undo `SCHED_IDLE` (no `CAP_SYS_NICE`, `RLIMIT_NICE` below 20) keeps them
on `SCHED_BATCH`. The sweeps of session 8 were with that rule: idle senders at 15 and 20 kHz
(from 0.34–0.49 s after the first sample, before the 0.5 s warm-up ended), `SCHED_BATCH` below.
Beside one process busy 100 ms in every second (`bench/NOTES.md`, section 13) no pose of the
node arrived for up to 31 ms at a time; over eight rounds at 15–20 kHz the node's p99 was
2.3–55.3 ms, `all_batch`'s 2.2–34.6 ms and the fast relay's 2.3–12.1 ms. A rule that moved idle
senders to `SCHED_BATCH` while other load contends for the CPUs was built, measured (medians
within 1 ms of the node's, maxima over 30 s up to 65 ms against 24 ms) and reverted. Session 9
found the spin at 5 kHz too (one window with p99 4.61 ms) and ended it another way
(`bench/NOTES.md`, section 14): since Linux 6.12 a thread can have its own time slice, and the
senders now get the shortest, 0.1 ms, and stay on `SCHED_BATCH` at every rate. A spinning
sender spends that slice within 0.1 ms, so the mutex's holder runs as soon as it is woken onto
that CPU. In two rounds of three interleaved windows that node had pooled p99 0.27–0.45 ms up
to 15 kHz and 0.57 / 1.13 ms at 20 kHz, against the fast relay's 0.23–1.02 and 1.62 / 1.66 ms;
beside one process busy 100 ms in every second its p99 at 15 / 20 kHz was 3.27 / 3.08 ms, the
relay's 4.80 / 3.72 ms. `idle_senders_above_hz` (default 0, never) brings the idle rule back,
for kernels without custom slices. Session 11's sweeps, with the slices (`bench/NOTES.md`,
section 16; `bench/results/node/sweeps_steal`), met item 5 in all five, and the same code 7 of
the fifteen before them (`slices/sweeps`, `sweeps_sampled`, `sweeps_reader`), so 12 of twenty:
in the remaining slow spells the gyro loop thread waited for a CPU, the CPUs did work no
sampled thread was charged for (no steal time: 30–40 ms per sweep of 240 s, none in a node
spell), or, in the largest, the sender spun on one CPU while the loop waited for that CPU and
the other was partly idle. Session 12 keeps them apart (`bench/NOTES.md`, section 17): while
gyro input is at `separate_cpus_above_hz` (12 kHz) or more, the loop thread runs on one CPU and
the sender threads on the others (`rigid_body_attitude/ros/cpu_split.py`). Over 16 interleaved
windows a rate against the node without it, the median window p99 at 20 kHz was 0.82 against
1.11 ms (windows over 1 ms: 6 against 10), for 80.7 against 72.4 % of a core; at 15 kHz even
(0.58 / 0.57 ms), at 10 kHz no better (0.50 / 0.47 ms), hence 12 kHz. The sweeps above are of
that node, with every thread of the three processes and every CPU's idle and steal time
sampled every 5 ms (`--sample-threads 5`). They met item 5 in all five: zero loss, the node's
pooled p99 at most 0.56 ms up to 5 kHz and below the fast relay's at 10–20 kHz in every row
(0.68–1.17 ms at 20 kHz), its 1 kHz CPU below the relay's in every sweep. The sender's spin is
gone from the spells at 15–20 kHz (1 of the node's 159 spells of 20 slow poses or more there);
the largest left are the pinned loop waiting for its CPU. Letting the loop thread preempt
(`SCHED_OTHER`, with or without a 0.1 ms slice) gained nothing (session 10). Nor is it the
bench's measuring end: measured up to the subscriber's Fast DDS reader, before its own thread
wakes, the node's pooled p99s were 0.03–0.15 ms lower and no verdict changed."""


#: What limits the dynamics scenes' node CPU (issue 13, item 2).
DYNAMICS_NOTE = """\
**What the dynamics figures depend on.** With the fast core (plain-float effects, the generated
RK4 kernel, `casimir8` for `heavy_top`: "Dynamics scenes and effects" above) the propagator
alone is 0.1–0.7 % of a core per scene in this run; the rest is the node's own share. Session 5
made the outputs cheap: `orientation`, `pose`, `twist`, `energy` and `angular_momentum` are
written as CDR bytes with the header packed once and published only to matched subscriptions,
like the gyro outputs (before, five message objects were filled and converted by rclpy every
tick, subscribed or not), the body-frame velocity is rotated with plain floats instead of two
`numpy.cross` calls, and the node clock is read through its handle without a `Time` object
(session 4 measured 2.8–4.8 % unsubscribed and 3.2–5.8 % subscribed for these scenes, with the
main thread at 2.2–4.0 %). Per thread in this run (`bench/results/node/node_dynamics_cpu.json`,
run times in ns from `/proc/<pid>/task/*/schedstat` since session 10; earlier runs counted
10 ms ticks): the main thread 0.8–1.4 % unsubscribed and 0.8–1.5 % subscribed, each of the
two shared-memory listeners of the package's Fast DDS profile (they wake every 10 ms, "Latency
in repeated sweeps") 0.2–0.3 %, and with subscribers the asynchronous sender thread
(`dds.asyn.0.1`, "Configuration" above) 0.2 % and the event thread 0.1–0.2 %. The sender
threads of a dynamics scene are on `SCHED_BATCH` with 0.1 ms time slices like those of a gyro
scene (session 9) and no sender guard runs: session 6, with idle senders and the guard's 10 Hz
timer, measured 2.2–2.9 % unsubscribed and 3.4–4.2 % subscribed. The other load is every other
process's run time over the window; it was at most 0.02 cores in this run. Subscribed windows
are noisier than unsubscribed ones: the subscriber process shares the two cores."""


def _load(path: Path) -> Optional[dict]:
    return json.loads(path.read_text()) if path.exists() else None


def _verdict(ok: bool) -> str:
    return 'met' if ok else 'NOT met'


def core_section(core: dict) -> list[str]:
    """The core step tables and their targets."""
    lines = ['## Core step costs', '',
             f'`python bench/core_step_costs.py` (timeit-style loops, gc off, '
             f'{core["repeats"]} repetitions; minimum and median per step). The baselines do the '
             'same update over the same samples and end in the same state (last column: '
             'round-off only). CPU: ' + core['machine']['cpu_model'] + f'; NumPy '
             f'{core["machine"]["numpy"]}, SciPy {core["machine"]["scipy"]}, AHRS '
             f'{core["machine"]["AHRS"]} (imports and runs with NumPy 2).', '']
    for key, title, target in (('strapdown', 'Exp-map strapdown step, one gyro sample',
                                core['target_strapdown_us']),
                               ('rk4', 'RK4 dynamics step, torque-free body',
                                core['target_rk4_us'])):
        rows = core[key]
        lines += [f'**{title}** (target ≤ {target:g} µs and ≥ {core["target_speedup"]:g}× '
                  'faster than every baseline)', '',
                  '| contender | µs/step (min) | µs/step (median) | cost ÷ first row | '
                  'final state vs first row |', '|---|---:|---:|---:|---:|']
        ours = rows[0]['min_us']
        for row in rows:
            lines.append(f'| {row["label"]} | {row["min_us"]:.2f} | {row["median_us"]:.2f} | '
                         f'{row["min_us"] / ours:.1f}× | {row["difference"]:.1e} |')
        lines.append('')
    return lines


def _core_verdicts(core: dict) -> list[str]:
    lines = []
    for key, name, target in (('strapdown', 'exp-map strapdown step', core['target_strapdown_us']),
                              ('rk4', 'RK4 dynamics step', core['target_rk4_us'])):
        rows = core[key]
        ours = [row for row in rows if '(ours)' in row['label']]
        baselines = [row for row in rows if '(ours)' not in row['label']]
        slowest_ours = max(row['min_us'] for row in ours)
        lines.append(f'- {name} ≤ {target:g} µs: {ours[0]["min_us"]:.2f} µs '
                     f'({ours[0]["label"]}; {slowest_ours:.2f} µs for the slowest of ours) — '
                     f'{_verdict(slowest_ours <= target)}')
        for row in baselines:
            factor = row['min_us'] / slowest_ours
            lines.append(f'- {name} ≥ {core["target_speedup"]:g}× faster than the '
                         f'{row["label"]}: {factor:.1f}× (slowest of ours) — '
                         f'{_verdict(factor >= core["target_speedup"])}')
    return lines


def batch_section(batch: dict) -> list[str]:
    """The batch throughput table."""
    lines = ['## Batch: N torque-free bodies (`TorqueFreeBatch`, RK4)', '',
             f'`python bench/batch_throughput.py`: a Monte-Carlo dispersion (per-body inertia '
             f'with random principal axes, random attitudes and rates up to 3 rad/s), '
             f'{batch["step_s"] * 1e3:g} ms steps; best and median of the repetitions. Checked '
             'bodies are integrated again one by one with the single-body `rk4` integrator '
             '(`test/core/test_batch.py` asserts the same to 1e-12).', '',
             '| N bodies | steps per call | body-steps/s (best) | body-steps/s (median) | '
             'max abs. difference vs single-body rk4 | checked bodies × steps |',
             '|---:|---:|---:|---:|---:|---:|']
    for row in batch['rows']:
        lines.append(f'| {row["bodies"]} | {row["steps_per_call"]} | '
                     f'{row["body_steps_per_s"]:.3g} | {row["median_body_steps_per_s"]:.3g} | '
                     f'{row["max_difference"]:.1e} | {row["checked_bodies"]} × '
                     f'{row["checked_steps"]} |')
    return lines + ['']


def _batch_verdicts(batch: dict) -> list[str]:
    row = next((r for r in batch['rows'] if r['bodies'] == batch['target_bodies']), None)
    if row is None:
        return [f'- batch at N = {batch["target_bodies"]}: not measured']
    return [f'- batch ≥ {batch["target_body_steps_per_s"]:.0e} body-steps/s at N = '
            f'{row["bodies"]}: {row["body_steps_per_s"]:.3g} — '
            f'{_verdict(row["body_steps_per_s"] >= batch["target_body_steps_per_s"])}',
            f'- batch matches the single-body RK4 per body to 1e-12: '
            f'{row["max_difference"]:.1e} — {_verdict(row["max_difference"] <= 1e-12)}']


def dynamics_section(scenes: Optional[dict], costs: Optional[dict],
                     batch: Optional[dict]) -> list[str]:
    """Issue 13: the dynamics scenes (CPU and accuracy, old and new settings), the effect and
    integrator prices, and the batch with effects."""
    lines = ['## Dynamics scenes and effects', '']
    if scenes is not None:
        lines += _scene_lines(scenes)
    if costs is not None:
        lines += _cost_lines(costs)
    if batch is not None and batch.get('scene_rows'):
        lines += _scene_batch_lines(batch)
    return lines


def _scene_lines(scenes: dict) -> list[str]:
    before = scenes['before_ms_per_s']
    lines = [f'`python bench/dynamics_scenes.py --before bench/results/dynamics/'
             f'scenes_before.json`: CPU time of `DynamicsPropagator.advance_to` per simulated '
             f'second, the node\'s way (ticks every {scenes["tick_s"] * 1e3:g} ms, commanded '
             f'inputs every {scenes["command_period_s"] * 1e3:g} ms), best of three 2 s runs. '
             '"Before" is the code before issue 13 with the old settings (same script, '
             '`--cpu-only`, `scenes_before.json`); "old settings" is the new code with the old '
             'integrator and step. Accuracy over 10 s against RK4 at 1/16 of the old step: the '
             'largest attitude error at the ticks, the energy-balance residual '
             '|T − T₀ − W| / max(T₀, T) at the end (for the heavy top, whose gravity has a '
             'potential, that is the drift of T + V), the world-momentum drift for torque-free '
             'scenes and the largest position error for the free flyer. Target: ≤ '
             f'{scenes["target_ms_per_s"]:g} ms per simulated second (≥ 100× real time) with '
             'accuracy at least as good as the old settings.', '',
             '| scene | before: method, step → CPU [ms/s] | new: method, step | CPU new '
             '[ms/s] | real-time factor | attitude error old / new [rad] | energy residual old '
             '/ new | other old / new |', '|---|---|---|---:|---:|---:|---:|---:|']
    for row in scenes['rows']:
        old, new = row['old'], row['new']
        other = '—'
        for key, unit in (('momentum_drift', ''), ('position_error_m', ' m')):
            if key in new:
                other = f'{old[key]:.1e} / {new[key]:.1e}{unit}'
        lines.append(
            f'| {row["scene"]} | {old["integrator"]}, {old["step"] * 1e3:g} ms → '
            f'{before.get(row["scene"], float("nan")):.0f} | {new["integrator"]}, '
            f'{new["step"] * 1e3:g} ms | {new["cpu_ms_per_s"]:.2f} | '
            f'{1e3 / new["cpu_ms_per_s"]:.0f}× | {old["attitude_error_rad"]:.1e} / '
            f'{new["attitude_error_rad"]:.1e} | {old["energy_balance_residual"]:.1e} / '
            f'{new["energy_balance_residual"]:.1e} | {other} |')
    verdict = 'every scene met' if not scenes['failures'] else (
        'NOT met for ' + ', '.join(scenes['failures']))
    return lines + ['', f'Target (≤ {scenes["target_ms_per_s"]:g} ms/s, accuracy ≥ old): '
                    f'{verdict}.', '']


def _cost_lines(costs: dict) -> list[str]:
    lines = [f'**What each effect costs per evaluation** (`python bench/effect_costs.py`, '
             f'best of {costs["repeats"]} `timeit` runs): the plain-float method the '
             'integrators call against the same effect through its array API (a NumPy round '
             'trip per call, what every evaluation cost before).', '',
             '| effect | kind | plain-float call [µs] | array API [µs] |', '|---|---|---:|---:|']
    lines += [f'| {r["effect"]} | {r["kind"]} | {r["plain_float_us"]:.2f} | '
              f'{r["array_us"]:.2f} |' for r in costs['effects']]
    labels = list(costs['effect_sets'])
    lines += ['', f'**What each integrator costs per step** (same run; CPU µs per '
              f'`advance_to` step of {costs["step_s"] * 1e3:g} ms over {costs["step_count"]} '
              'steps, '
              f'best of {costs["repeats"]}, 1/2/3 kg m² body at about 1 rad/s: integrator, '
              'effects and energy-balance work together). The exact-flow '
              'RKN methods (rkn4, rkn6) solve the free flow with elliptic functions for this '
              'non-axisymmetric body; on an axisymmetric one they and casimir6/8 run the fused '
              'loop of `integrators/axisymmetric.py`.', '',
              '| integrator | ' + ' | '.join(f'effects: {label}' for label in labels) + ' |',
              '|---|' + '---:|' * len(labels)]
    lines += [f'| {r["integrator"]} | ' + ' | '.join(f'{r[label]:.1f}' for label in labels)
              + ' |' for r in costs['steps']]
    lines += ['', '**The RK4 step written out per body model** (`integrators/rk4_kernel.py`, '
              'same run) against the generic plain-float step:', '',
              '| effects | written-out [µs] | generic [µs] |', '|---|---:|---:|']
    lines += [f'| {r["effects"]} | {r["kernel_us"]:.2f} | {r["generic_us"]:.2f} |'
              for r in costs['kernel']]
    return lines + ['', APPROACH_NOTE, '']


def _scene_batch_lines(batch: dict) -> list[str]:
    scene = batch['effects_scene']
    lines = ['**Batch with effects** (`SceneBatch`, `python bench/batch_throughput.py`, same '
             'run as the torque-free batch above): the scene '
             f'`{scene["name"]}` (gravity gradient on a 7000 km orbit and viscous damping, '
             f'{batch["step_s"] * 1e3:g} ms RK4 steps), each body with its own attitude, rate '
             'and damping coefficients, and either the scene\'s diagonal inertia or a '
             'dispersed full tensor. Checked bodies are run again one by one through '
             '`DynamicsPropagator` (`test/core/test_batch.py` asserts 1e-12 for four scenes '
             'with every effect kind). Load average of the 2-core machine (other users) '
             f'at the end of the run: {batch.get("load_average_1min", float("nan")):.1f}.', '',
             '| N bodies | inertia | body-steps/s (best) | body-steps/s (median) | max abs. '
             'difference vs single body |', '|---:|---|---:|---:|---:|']
    for row in batch['scene_rows']:
        lines.append(f'| {row["bodies"]} | {row["inertia"]} | {row["body_steps_per_s"]:.3g} | '
                     f'{row["median_body_steps_per_s"]:.3g} | {row["max_difference"]:.1e} |')
    target = batch['target_effects_body_steps_per_s']
    rows = [r for r in batch['scene_rows'] if r['bodies'] == batch['target_bodies']]
    lines += [''] + [f'- ≥ {target:.0e} body-steps/s at N = {r["bodies"]} ({r["inertia"]} '
                     f'inertia): {r["body_steps_per_s"]:.3g} — '
                     f'{_verdict(r["body_steps_per_s"] >= target)}' for r in rows]
    return lines + ['', BATCH_NOTE, '']


#: How the single-body speed was reached, and why no compiler was added (issue 13, item 3).
APPROACH_NOTE = """\
**Approach.** The profile before was NumPy's per-call overhead on 3-vectors (issue 13's
profile: about 29 `numpy.cross` calls and several `quaternion.rotate` calls per step) and a
Simpson quadrature of the energy-balance work that evaluated every torque five more times per
step. Now every effect evaluates on plain-float tuples (the array API stays for scripts), the
propagator runs each `advance_to` on floats from start to end (arrays built once per call),
RK4 integrates the work as an eighth component with its own stage weights (no extra torque
evaluation; a torque with a potential, `ConservativeTorque`, gives the work exactly as
V(q₀) − V(q₁)), held commands are looked up once per step, and the RK4 step is written out per
body model (all four stages inlined, diagonal inertia and absent torques or rotors left out).
Where the accuracy study's methods reach the same accuracy for less work, the scene now ships
them: the heavy top runs `casimir8` at 20 ms (the fused axisymmetric loop the study measures).
These met every single-body target without a compiled dependency, so none was added or
measured here (a compiler such as numba remains the way to take the batch further: see
below)."""

#: What limits the batch with effects.
BATCH_NOTE = """\
**What limits the batch with effects.** NumPy's passes over the rows of a chunk (8 192 bodies,
`SCENE_CHUNK`), not Python: each RK4 stage with gravity gradient and damping takes one
`einsum` for ω = J⁻¹ h (the chunk's state holds the body-frame momentum h = J ω, so Euler's
equations ḣ = M − ω × h need no product J ω), one for J r̂ of the gravity gradient, one 3 × 3
matrix product for the rotation's τ = 2 r̂_w × q_v, and about 70 passes over single rows, most
of them the four cross products (ω × h, τ × q_v, r̂ × J r̂, q_v × ω), then the stage
combinations over the state's 7 rows, all into work arrays allocated once per chunk. With the
scene's diagonal inertia the two `einsum`s are three row products with plain floats each; a
dispersed tensor per body reads nine entries per body instead, which is what differs between
the two rows above. Fewer operations would need the bodies' principal frames (as
`TorqueFreeBatch` does) with every effect's parameters turned into them, or a compiled loop
that keeps each body's state in registers."""


def _node_verdicts(throughput: Optional[dict], soak: Optional[dict]) -> list[str]:
    lines = []
    if throughput is not None:
        lines += _report._node_verdict(throughput['targets'])
    if soak is not None:
        first, last = soak['samples'][0], soak['samples'][-1]
        growth = soak['growth_kib']
        lines.append(f'- RSS after {last["minute"]} min within 5 MiB of RSS after '
                     f'{first["minute"]} min at {soak["rate_hz"]:.0f} Hz: {growth / 1024:+.2f} '
                     f'MiB — {_verdict(abs(growth) <= _report.TARGET_SOAK_GROWTH_KIB)}')
    return lines


def render(results_dir: Path, png_name: str) -> str:
    """The whole report from the results in ``results_dir``."""
    throughput = _load(results_dir / 'throughput.json')
    soak = _load(results_dir / 'soak.json')
    core = _load(results_dir / 'core_steps.json')
    batch = _load(results_dir / 'batch.json')
    scenes = _load(results_dir.parent / 'dynamics' / 'scenes.json')
    costs = _load(results_dir.parent / 'dynamics' / 'effect_costs.json')
    text = _report.render(throughput, soak, png_name)
    text = text.replace('Generated by `bench/node_throughput.py` (do not edit by hand; rerun it).',
                        'Generated by `bench/performance_report.py` from the results of '
                        '`bench/node_throughput.py`, `bench/core_step_costs.py`, '
                        '`bench/batch_throughput.py`, `bench/dynamics_scenes.py` and '
                        '`bench/effect_costs.py` (do not edit by hand; rerun them).', 1)
    lines = [text.rstrip('\n'), '']
    if core is not None:
        lines += core_section(core)
    if batch is not None:
        lines += batch_section(batch)
    if scenes is not None or costs is not None:
        lines += dynamics_section(scenes, costs, batch)
    lines += ['## Issue 7 targets', '']
    lines += _node_verdicts(throughput, soak)
    if core is not None:
        lines += _core_verdicts(core)
    if batch is not None:
        lines += _batch_verdicts(batch)
    lines += ['', QOS_NOTE, '']
    lines += [LIMITS, '']
    lines += _node_sections.sweeps_section(_sweeps(results_dir))
    lines += STALLS_NOTE.splitlines() + ['']
    lines += TAILS_NOTE.splitlines() + ['']
    lines += _node_sections.mixed_soak_section(_load(results_dir / 'soak_mixed.json'))
    lines += _node_sections.dynamics_cpu_section(_load(results_dir / 'node_dynamics_cpu.json'))
    lines += DYNAMICS_NOTE.splitlines() + ['']
    lines += _campaign_section.campaign_section(
        [json.loads(path.read_text()) for path in sorted(
            (results_dir.parent / 'campaign').glob('throughput*.json'),
            key=lambda path: json.loads(path.read_text())['steps'])])
    return '\n'.join(lines)


def _sweeps(results_dir: Path) -> list[dict]:
    """The repeated sweeps, ``sweeps/sweep_<n>/throughput.json``, in order."""
    found = sorted((results_dir / 'sweeps').glob('sweep_*/throughput.json'),
                   key=lambda path: int(path.parent.name.split('_')[1]))
    return [json.loads(path.read_text()) for path in found]


def main(argv: Optional[list[str]] = None) -> int:
    """Regenerate the report (and the throughput plot beside it)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--results-dir', type=Path, default=BENCH / 'results' / 'node')
    parser.add_argument('--report', type=Path, default=REPO / 'docs' / 'performance.md')
    args = parser.parse_args(argv)
    png_path = args.report.with_suffix('.png')
    throughput = _load(args.results_dir / 'throughput.json')
    if throughput is not None:
        _report.plot(throughput, png_path)
    args.report.parent.mkdir(parents=True, exist_ok=True)
    args.report.write_text(render(args.results_dir, png_path.name))
    print(f'wrote {args.report}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
