"""Shared builders of the session tests: a sink that records, clocks the test drives."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import pytest

from rigid_body_attitude.session.parameters import defaults
from rigid_body_attitude.session.settings import load_node_scene, open_session

BASE_NS = 1_700_000_000 * 10**9 + 123_456_789
MS = 1_000_000


@dataclass
class RecordingSink:
    """Everything a session hands over, in order."""

    attitudes: list[tuple[int, int, tuple[float, ...]]] = field(default_factory=list)
    ticks: list[tuple[int, int, Any, tuple[float, ...]]] = field(default_factory=list)
    invariant_samples: list[tuple[int, int, float, tuple[float, ...]]] = field(
        default_factory=list)
    reports: list[Any] = field(default_factory=list)
    logs: list[tuple[int, str]] = field(default_factory=list)
    use_header_stamps: bool = True

    imus: list[bytes | None] = field(default_factory=list)
    covariances: list[tuple[float, ...]] = field(default_factory=list)
    mounts: list[tuple[float, ...] | None] = field(default_factory=list)
    simulated: list[tuple[str, bytes]] = field(default_factory=list)
    wheel_states: list[bytes] = field(default_factory=list)
    accelerations: list[tuple[int, int, tuple[float, ...], tuple[float, ...]]] = field(
        default_factory=list)
    odometries: list[tuple[Any, ...]] = field(default_factory=list)

    def acceleration(self, sec, nanosec, estimate):
        self.accelerations.append((sec, nanosec, *estimate()))

    def odometry(self, sec, nanosec, attitude, omega_body, rate_covariance):
        self.odometries.append((sec, nanosec, attitude, omega_body, rate_covariance))

    def sensor_mount(self, q_body_sensor):
        self.mounts.append(q_body_sensor)

    def attitude_covariance(self, covariance):
        self.covariances.append(covariance)

    def attitude(self, sec, nanosec, attitude, imu):
        self.attitudes.append((sec, nanosec, attitude))
        self.imus.append(imu)

    def dynamics(self, sec, nanosec, sample, velocity_body):
        self.ticks.append((sec, nanosec, sample, velocity_body))

    def invariants(self, sec, nanosec, energy, world_momentum):
        self.invariant_samples.append((sec, nanosec, energy, world_momentum))

    def sensor_wanted(self, topic):
        return True

    def simulated_sensor(self, topic, data):
        self.simulated.append((topic, data))

    def wheel_state(self, data):
        self.wheel_states.append(data)

    def diagnostics(self, report):
        self.reports.append(report)

    def log(self, level, text):
        self.logs.append((level, text))


@dataclass
class Clocks:
    """The node clock [ns] and the monotonic clock [s], set by the test."""

    now_ns: int = BASE_NS
    monotonic: float = 0.0


@pytest.fixture
def clocks():
    return Clocks()


@pytest.fixture
def open_scene(clocks):
    """``open_scene(name, **parameters)`` → (session, sink)."""
    def build(name, **parameters):
        values = defaults()
        values.update(parameters)
        sink = RecordingSink()
        scene = load_node_scene(name, values['integrator'], values['step'],
                                values['torque_timeout'])
        session = open_session(scene, values, sink, lambda: clocks.now_ns,
                               lambda: clocks.monotonic)
        return session, sink
    return build
