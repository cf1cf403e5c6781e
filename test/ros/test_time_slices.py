"""Custom time slices (:mod:`rigid_body_attitude.ros.time_slices`) on this kernel."""

from __future__ import annotations

import os
import platform
import re
import threading

from rigid_body_attitude.ros.time_slices import (
    kernel_takes_slices, SENDER_SLICE_NS, shorten_slices, time_slice_ns)


def _kernel_has_custom_slices() -> bool:
    """Linux 6.12 brought per-thread slices for the fair class (``sched_runtime``)."""
    major, minor = map(int, re.match(r'(\d+)\.(\d+)', platform.release()).groups())
    return (major, minor) >= (6, 12)


def test_the_probe_answers_what_the_kernel_version_says_and_changes_no_thread():
    before = time_slice_ns(0)
    assert kernel_takes_slices() == _kernel_has_custom_slices()
    assert time_slice_ns(0) == before != SENDER_SLICE_NS  # the probe ran on its own thread


def test_a_thread_takes_the_slice_and_keeps_its_policy_and_nice():
    """A fresh thread on SCHED_BATCH, nice 5: the slice is what the kernel reads back (no
    change on a kernel without custom slices); policy and nice value are unchanged; a thread
    that does not exist is skipped; a later policy change keeps the slice."""
    ready, done = threading.Event(), threading.Event()
    thread_ids: list[int] = []

    def body() -> None:
        os.sched_setscheduler(0, os.SCHED_BATCH, os.sched_param(0))
        os.setpriority(os.PRIO_PROCESS, 0, 5)
        thread_ids.append(threading.get_native_id())
        ready.set()
        done.wait(10.0)
    thread = threading.Thread(target=body)
    thread.start()
    try:
        assert ready.wait(10.0)
        thread_id = thread_ids[0]
        default = time_slice_ns(thread_id)
        assert default != SENDER_SLICE_NS
        assert shorten_slices([thread_id, 2**22 + 1]) == [thread_id]  # no such thread
        expected = SENDER_SLICE_NS if _kernel_has_custom_slices() else default
        assert time_slice_ns(thread_id) == expected
        assert os.sched_getscheduler(thread_id) == os.SCHED_BATCH
        assert os.getpriority(os.PRIO_PROCESS, thread_id) == 5
        # A policy change through sched_setscheduler keeps it.
        os.sched_setscheduler(thread_id, os.SCHED_OTHER, os.sched_param(0))
        assert time_slice_ns(thread_id) == expected
    finally:
        done.set()
        thread.join()
