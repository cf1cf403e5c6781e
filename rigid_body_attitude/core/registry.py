"""The one registry mechanism: classes by their ``name``, filled by a class decorator.

Effects (:data:`rigid_body_attitude.core.dynamics.effects.EFFECTS`) and dynamics integrators
(:data:`rigid_body_attitude.core.dynamics.integrators.DYNAMICS_INTEGRATORS`) are each a
:class:`Registry`:
a read-mostly mapping name → class that a module joins with ``@REGISTRY.register``, so adding
one means adding a module, never editing a list elsewhere.
"""

from __future__ import annotations

from typing import ClassVar, Generic, Protocol, TypeVar

__all__ = ['Named', 'Registry']


class Named(Protocol):
    """A registrable class: it has a ``name``."""

    name: ClassVar[str]


NamedType = TypeVar('NamedType', bound='type[Named]')


class Registry(dict[str, NamedType], Generic[NamedType]):
    """Classes by name; :meth:`register` adds one, :meth:`lookup` explains a wrong name."""

    def __init__(self, kind: str, error: type[Exception]) -> None:
        """An empty registry of ``kind`` (used in messages); unknown names raise ``error``."""
        super().__init__()
        self.kind = kind
        self.error = error

    def register(self, cls: NamedType) -> NamedType:
        """Class decorator: add ``cls`` under ``cls.name`` (a name may be registered once)."""
        name = cls.name
        if not name or name in self:
            raise self.error(f'{self.kind} name {name!r} is empty or registered twice')
        self[name] = cls
        return cls

    def lookup(self, name: str) -> NamedType:
        """The class registered as ``name``; ``error`` lists the valid names otherwise."""
        if name not in self:
            raise self.error(f'Unknown {self.kind} {name!r}; expected one of '
                             f'{", ".join(sorted(self))}')
        return self[name]
