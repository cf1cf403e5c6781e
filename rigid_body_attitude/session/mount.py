"""The sensor's mount from static transforms: the rotation ``body_frame`` -> sensor frame.

What the node (:mod:`rigid_body_attitude.session.mount_gate`, ``/tf_static`` received) and the
replay (:mod:`rigid_body_attitude.tools.replay.mount`, a bag's ``/tf_static``) share: the
table of static transforms (:class:`StaticTransforms`, rotations only: the node reports an
attitude), the composition of a chain between two frames (``base_link`` -> ``torso`` ->
``imu_link``, or up and down a tree), the line saying where the mount came from, and the
dropping of gyro samples while no mount is known (counted ``no_mount``).

Every transform is checked before it enters the table, as tf2's ``BufferCore`` checks what
it is given (ros2/geometry2, ``buffer_core.cpp``, ``setTransformImpl``): refused with
``tf_bad_frames`` (an empty frame, a frame equal to its parent, or a name longer than
:data:`MAX_FRAME_LENGTH`), ``tf_non_finite`` (a NaN or Inf in the rotation or translation) or
``tf_denormalized`` (a rotation whose squared norm differs from 1 by
:data:`NORM_TOLERANCE` or more: zero and near-zero quaternions included). Each child frame has
one parent, as in tf2: a new parent replaces the old. The table holds at most
:data:`MAX_TRANSFORMS`; beyond, the oldest transform not on a chain in use is dropped (counted
``tf_evicted``), so a flood of junk cannot lock a later valid mount out, and the mount in use
is never dropped. The chains from one root frame are resolved when the table changes
(:meth:`StaticTransforms.resolved`), never per gyro sample.
"""

from __future__ import annotations

from collections import Counter, deque
from collections.abc import Iterable
import math

from rigid_body_attitude.core.attitude.quaternion import multiply_floats
from rigid_body_attitude.msgs.tf_message import Transform
from rigid_body_attitude.msgs.untrusted import quoted
from rigid_body_attitude.session.base import LEVEL_INFO
from rigid_body_attitude.session.gyro import GyroSession

__all__ = ['MAX_FRAME_LENGTH', 'MAX_TRANSFORMS', 'NORM_TOLERANCE', 'StaticTransforms',
           'TRANSFORM_REASONS', 'drop_no_mount', 'set_found_mount',
           'transform_problem', 'transform_warning']

Quaternion = tuple[float, float, float, float]

#: Static transforms kept (a hostile publisher or bag cannot grow the table without bound).
MAX_TRANSFORMS = 10_000
#: Longest frame name taken into the table [characters] (REP-105 names are a few dozen).
MAX_FRAME_LENGTH = 256
#: Largest accepted ``|‖q‖² − 1|`` of a transform's rotation (tf2's
#: ``QUATERNION_NORMALIZATION_TOLERANCE``).
NORM_TOLERANCE = 1e-2
#: Why a transform was refused or dropped, by reason (the warning texts).
TRANSFORM_REASONS = {
    'tf_bad_frames': 'an empty frame, a frame equal to its parent, or a frame name longer '
                     f'than {MAX_FRAME_LENGTH} characters',
    'tf_non_finite': 'a NaN or Inf in the rotation or translation',
    'tf_denormalized': f'a rotation whose squared norm is not 1 within {NORM_TOLERANCE:g} '
                       '(zero or near-zero included)',
    'tf_evicted': f'dropped, the oldest beyond {MAX_TRANSFORMS} transforms',
}


def _conjugate(q: Quaternion) -> Quaternion:
    return q[0], -q[1], -q[2], -q[3]


def transform_problem(parent: str, child: str, wxyz: Iterable[float],
                      translation: Iterable[float] = (0.0, 0.0, 0.0)) -> str:
    """The reason (a key of :data:`TRANSFORM_REASONS`) to refuse a transform, or ``''``."""
    if (not parent or not child or parent == child or len(parent) > MAX_FRAME_LENGTH
            or len(child) > MAX_FRAME_LENGTH):
        return 'tf_bad_frames'
    w, x, y, z = wxyz
    if not all(math.isfinite(value) for value in (w, x, y, z, *translation)):
        return 'tf_non_finite'
    if max(abs(w), abs(x), abs(y), abs(z)) > 2.0:  # far from unit; the squares stay finite
        return 'tf_denormalized'
    if not abs(w * w + x * x + y * y + z * z - 1.0) < NORM_TOLERANCE:
        return 'tf_denormalized'
    return ''


class StaticTransforms:
    """The rotations of the static transforms received, as an undirected tree of frames.

    Attributes:
        edges: frame -> neighbour frame -> rotation mapping the neighbour's vectors into
            frame.
        parents: child frame -> its parent frame, oldest transform first.
        protected: child frames whose transform is on a chain in use (never dropped).
    """

    def __init__(self) -> None:
        """No transforms yet."""
        self.edges: dict[str, dict[str, Quaternion]] = {}
        self.parents: dict[str, str] = {}
        self.protected: set[str] = set()
        #: reason -> (parent, child) of a transform refused for it by :meth:`add_all`.
        self.examples: dict[str, tuple[str, str]] = {}
        self._resolved: dict[str, dict[str, tuple[Quaternion, str]]] = {}

    @property
    def count(self) -> int:
        """Transforms held."""
        return len(self.parents)

    def add(self, parent: str, child: str, wxyz: Iterable[float],
            translation: Iterable[float] = (0.0, 0.0, 0.0)) -> str:
        """Add ``parent`` -> ``child`` with the rotation ``wxyz`` (mapping ``child``-frame
        vectors into ``parent``'s); the reason it was refused (:data:`TRANSFORM_REASONS`), or
        ``''`` (``'tf_evicted'`` when an older transform had to make room)."""
        problem = transform_problem(parent, child, wxyz, translation)
        if problem:
            return problem
        w, x, y, z = wxyz
        norm = math.sqrt(w * w + x * x + y * y + z * z)
        q = (w / norm, x / norm, y / norm, z / norm)
        evicted = ''
        if child in self.parents:
            self._remove(child)
        elif len(self.parents) >= MAX_TRANSFORMS:
            evicted = self._evict()
        self.parents[child] = parent
        self.edges.setdefault(parent, {})[child] = q
        self.edges.setdefault(child, {})[parent] = _conjugate(q)
        self._resolved.clear()
        return evicted

    def add_all(self, transforms: Iterable[Transform]) -> Counter[str]:
        """Add each transform; how many were refused or dropped, by reason (the first
        frames of each reason in :attr:`examples`)."""
        counts: Counter[str] = Counter()
        for t in transforms:
            reason = self.add(t.parent_frame, t.child_frame, t.rotation, t.translation)
            if reason:
                if not counts[reason]:
                    self.examples[reason] = (t.parent_frame, t.child_frame)
                counts[reason] += 1
        return counts

    def _remove(self, child: str) -> None:
        parent = self.parents.pop(child)
        for frame, neighbour in ((parent, child), (child, parent)):
            neighbours = self.edges[frame]
            del neighbours[neighbour]
            if not neighbours:
                del self.edges[frame]

    def _evict(self) -> str:
        """Drop the oldest transform not on a chain in use."""
        for child in self.parents:
            if child not in self.protected:
                self._remove(child)
                return 'tf_evicted'
        return ''

    def resolved(self, root: str) -> dict[str, tuple[Quaternion, str]]:
        """Every frame connected to ``root``: the rotation mapping its vectors into
        ``root``'s (the chain composed) and the frame before it on the chain. Computed once
        per change of the table."""
        found = self._resolved.get(root)
        if found is not None:
            return found
        found = {root: ((1.0, 0.0, 0.0, 0.0), '')}
        frontier = deque([root])
        while frontier:
            frame = frontier.popleft()
            q_frame = found[frame][0]
            for neighbour, q in self.edges.get(frame, {}).items():
                if neighbour not in found:
                    found[neighbour] = (multiply_floats(q_frame, q), frame)
                    frontier.append(neighbour)
        self._resolved = {root: found}
        return found

    def rotation(self, parent: str, child: str) -> Quaternion | None:
        """The rotation mapping ``child``-frame vectors into ``parent``'s (the chain between
        them composed), or None when they are not connected."""
        found = self.resolved(parent).get(child)
        return None if found is None else found[0]

    def protect(self, root: str, frame: str) -> None:
        """Never drop the transforms of the chain ``root`` -> ``frame`` (the mount in use)."""
        tree = self.resolved(root)
        while frame in tree and frame != root:
            before = tree[frame][1]
            self.protected.add(frame if self.parents.get(frame) == before else before)
            frame = before


def transform_warning(reason: str, count: int, example: tuple[str, str], source: str) -> str:
    """The warning about ``count`` transforms of ``source`` refused for ``reason`` (the
    frames of one of them: ``example``)."""
    parent, child = example
    return (f'{source}: {count} transforms refused or dropped ({reason}: '
            f'{TRANSFORM_REASONS[reason]}), e.g. {quoted(parent)} -> {quoted(child)}')


def set_found_mount(session: GyroSession, sensor_frame: str, q_body_sensor: Quaternion,
                    source: str) -> None:
    """Give ``session`` the mount found in ``source`` (``/tf_static``, the bag's) and say so."""
    session.set_mount(q_body_sensor)
    rounded = tuple(round(value, 6) for value in q_body_sensor)
    session.sink.log(LEVEL_INFO, f'mount {quoted(session.body_frame)} -> '
                                 f'{quoted(sensor_frame)} from {source}: (w, x, y, z) '
                                 f'{rounded}')


def drop_no_mount(session: GyroSession, count: int, sensor_frame: str, where: str,
                  remedy: str) -> None:
    """``count`` gyro samples dropped for want of the transform ``body_frame`` ->
    ``sensor_frame`` (counted ``no_mount``; a throttled warning naming ``where`` it was looked
    for and the ``remedy``)."""
    session.rejections['no_mount'] += count
    session.warn('no_mount', f'no static transform {quoted(session.body_frame)} -> '
                             f'{quoted(sensor_frame)} {where}: gyro samples dropped ({remedy})')
