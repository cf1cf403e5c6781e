"""The Dask cluster the campaign and fleet replay run on: a scheduler's client, or a local one.

Shared by :mod:`rigid_body_attitude.tools.campaign` (Monte-Carlo chunks) and
:mod:`rigid_body_attitude.tools.replay.fleet` (one bag per task).
"""

from __future__ import annotations

import logging
import os
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from rigid_body_attitude.core.errors import AttitudeError

__all__ = ['ClusterError', 'LOCAL_CLUSTER_CONFIG', 'dask_client', 'default_workers',
           'local_cluster']


class ClusterError(AttitudeError):
    """No Dask scheduler at the address given."""


def default_workers() -> int:
    """Worker processes of the default local cluster: the CPUs this process may use."""
    return max(1, len(os.sched_getaffinity(0)))


@contextmanager
def dask_client(scheduler: str = '', workers: int = 0) -> Iterator[Any]:
    """A ``distributed.Client``: of the scheduler at ``scheduler``, or of a local cluster of
    ``workers`` single-threaded worker processes (default :func:`default_workers`), closed
    on exit."""
    from distributed import Client
    if scheduler:
        try:
            client = Client(scheduler, timeout='5s')
        except (OSError, TimeoutError, ValueError, TypeError) as err:
            raise ClusterError(f'Cannot reach the Dask scheduler at {scheduler!r}: '
                               f'{str(err).splitlines()[0] if str(err) else err!r}') from None
        with client:
            yield client
        return
    import dask
    with local_cluster(workers) as cluster, dask.config.set(LOCAL_CLUSTER_CONFIG), \
            Client(cluster) as client:
        yield client


#: Dask settings of :func:`local_cluster` (and of :func:`dask_client`'s client of it): glibc's
#: adaptive allocation thresholds kept in the workers, and Dask's own sampling (the workers'
#: statistical profiler, event-loop ticks, system and memory monitors, the client's polling of
#: the scheduler) made rare, and no active memory manager (tasks share no data but the
#: scattered spec, which every worker keeps): campaign tasks are few and long, and at Dask's
#: defaults this bookkeeping takes CPU from the chunks in every process of the cluster, the
#: longer the busier the machine.
LOCAL_CLUSTER_CONFIG = {
    'distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_': None,
    'distributed.worker.profile.enabled': False,
    'distributed.admin.tick.interval': '1s',
    'distributed.admin.system-monitor.interval': '10s',
    'distributed.worker.memory.monitor-interval': '1s',
    'distributed.scheduler.active-memory-manager.start': False,
    'distributed.client.scheduler-info-interval': '10s',
}


def local_cluster(workers: int = 0) -> Any:
    """A ``LocalCluster`` of ``workers`` single-threaded worker processes (default
    :func:`default_workers`) with :data:`LOCAL_CLUSTER_CONFIG`.

    Dask starts its workers with ``MALLOC_TRIM_THRESHOLD_`` set, which fixes glibc's
    thresholds: every NumPy temporary of a chunk (a few hundred kB) is then mapped afresh and
    faulted in page by page. These workers start without it (Dask's documented way, a
    ``None`` in ``distributed.nanny.pre-spawn-environ``; the variable is also kept out of
    this process's environment while they start, where an earlier Dask nanny leaves it).
    """
    import dask
    from distributed import LocalCluster
    variable = 'MALLOC_TRIM_THRESHOLD_'
    inherited = os.environ.pop(variable, None)
    try:
        with dask.config.set(LOCAL_CLUSTER_CONFIG):
            return LocalCluster(n_workers=workers or default_workers(), threads_per_worker=1,
                                processes=True, dashboard_address=':0',
                                silence_logs=logging.ERROR)
    finally:
        if inherited is not None:
            os.environ[variable] = inherited
