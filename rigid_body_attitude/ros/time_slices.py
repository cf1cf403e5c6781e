"""Short time slices for Fast DDS's sender threads (Linux 6.12 and later).

Fast DDS 2.14's asynchronous sender (``dds.asyn.*``) retries at once, without sleeping, when
it finds a writer's mutex held by another thread (:mod:`~.sender_threads`). Under
``SCHED_BATCH`` a thread woken on its CPU does not preempt it, so a spin used to last until
the sender's time slice ran out: up to a scheduler tick, the node's multi-millisecond latency
tails (``bench/NOTES.md``, sections 11 and 14).

Since Linux 6.12 the fair scheduler (EEVDF) takes a per-thread slice from
``sched_setattr``'s ``sched_runtime`` (0.1–100 ms). A sender with a 0.1 ms slice that spins
uses it up within 0.1 ms; when the mutex's holder is then woken on that CPU, the scheduler
updates the running sender, finds its slice spent and reschedules, so the holder runs and
the spin ends. A sender that sends and sleeps, its normal work, never spends a slice, so
it keeps ``SCHED_BATCH``'s fewer context switches. Older kernels ignore the field
(:func:`kernel_takes_slices` says which).
"""

from __future__ import annotations

import ctypes
import functools
import os
import platform
import threading

__all__ = ['SENDER_SLICE_NS', 'kernel_takes_slices', 'set_slice', 'shorten_slices',
           'time_slice_ns']

#: Time slice of the sender threads: the kernel's shortest (0.1 ms).
SENDER_SLICE_NS = 100_000

#: (sched_setattr, sched_getattr) system call numbers by machine.
_SYSCALLS = {'x86_64': (314, 315), 'aarch64': (274, 275)}


class _SchedAttr(ctypes.Structure):
    """``struct sched_attr`` of sched_setattr(2)."""

    _fields_ = [('size', ctypes.c_uint32), ('sched_policy', ctypes.c_uint32),
                ('sched_flags', ctypes.c_uint64), ('sched_nice', ctypes.c_int32),
                ('sched_priority', ctypes.c_uint32), ('sched_runtime', ctypes.c_uint64),
                ('sched_deadline', ctypes.c_uint64), ('sched_period', ctypes.c_uint64),
                ('sched_util_min', ctypes.c_uint32), ('sched_util_max', ctypes.c_uint32)]


@functools.cache
def _libc() -> ctypes.CDLL:
    """The C library the process has loaded, with ``errno`` kept per call."""
    return ctypes.CDLL(None, use_errno=True)


def _syscall(index: int, *arguments: object) -> None:
    """Call sched_setattr (``index`` 0) or sched_getattr (1); OSError on failure."""
    numbers = _SYSCALLS.get(platform.machine())
    if numbers is None:
        raise OSError(f'no sched_setattr number for machine {platform.machine()!r}')
    if _libc().syscall(numbers[index], *arguments) != 0:
        error = ctypes.get_errno()
        raise OSError(error, os.strerror(error))


def time_slice_ns(thread_id: int) -> int:
    """The time slice of ``thread_id`` as the kernel reports it: the custom one, else the
    kernel's default (1.4 ms on this project's machine); 0 before Linux 6.12."""
    attr = _SchedAttr()
    _syscall(1, thread_id, ctypes.byref(attr), ctypes.sizeof(attr), 0)
    return int(attr.sched_runtime)


def set_slice(thread_id: int, slice_ns: int) -> None:
    """Give ``thread_id`` (0: the calling thread) a time slice of ``slice_ns``, its policy and
    nice value unchanged (a later ``sched_setscheduler`` keeps the slice)."""
    attr = _SchedAttr(size=ctypes.sizeof(_SchedAttr),
                      sched_policy=os.sched_getscheduler(thread_id),
                      sched_nice=os.getpriority(os.PRIO_PROCESS, thread_id),
                      sched_runtime=slice_ns)
    _syscall(0, thread_id, ctypes.byref(attr), 0)


def kernel_takes_slices() -> bool:
    """Whether this kernel keeps a custom time slice, tried on a short-lived thread of its
    own (so whatever the system refuses, a seccomp policy for one, counts)."""
    took: list[bool] = []

    def probe() -> None:
        try:
            set_slice(0, SENDER_SLICE_NS)
            took.append(time_slice_ns(0) == SENDER_SLICE_NS)
        except OSError:
            took.append(False)

    thread = threading.Thread(target=probe, name='slice-probe')
    thread.start()
    thread.join()
    return took == [True]


def shorten_slices(thread_ids: list[int], slice_ns: int = SENDER_SLICE_NS) -> list[int]:
    """Give each of ``thread_ids`` the slice ``slice_ns``; the ids that took it (a thread
    that ended meanwhile is skipped)."""
    shortened = []
    for thread_id in thread_ids:
        try:
            set_slice(thread_id, slice_ns)
        except OSError:  # ProcessLookupError: ended meanwhile
            continue
        shortened.append(thread_id)
    return shortened
