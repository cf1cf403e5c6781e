"""The interface's endpoints as rclpy entities: subscriptions, publishers and services.

Every topic and service of the nodes is declared once, without rclpy, in
:mod:`rigid_body_attitude.session.interface`; these functions create the rclpy entity of an
:class:`~rigid_body_attitude.session.interface.Endpoint`: its message or service class imported
by type name, its QoS profile by name (:func:`~.qos.qos_profile`), rclpy's ``qos_overrides``
where the endpoint allows them. Subscriptions are raw (the callback gets the CDR bytes).
"""

from __future__ import annotations

from collections.abc import Callable
import importlib
from typing import Any, cast

from rclpy.callback_groups import CallbackGroup
from rclpy.event_handler import PublisherEventCallbacks
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.qos_overriding_options import QoSOverridingOptions
from rclpy.service import Service
from rclpy.subscription import Subscription

from rigid_body_attitude.ros.qos import qos_profile
from rigid_body_attitude.session.interface import Endpoint

__all__ = ['create_publisher', 'create_service', 'create_subscription', 'interface_class']


def interface_class(type_name: str) -> Any:
    """The rclpy class of a message or service type (``sensor_msgs/msg/Imu``)."""
    package, kind, name = type_name.split('/')
    return getattr(importlib.import_module(f'{package}.{kind}'), name)


def _overriding(endpoint: Endpoint) -> dict[str, Any]:
    """rclpy's ``qos_overriding_options`` when the endpoint takes ``qos_overrides``."""
    if not endpoint.qos_overrides:
        return {}
    return {'qos_overriding_options': QoSOverridingOptions.with_default_policies()}


def create_subscription(node: Node, endpoint: Endpoint, callback: Callable[[bytes], object],
                        callback_group: CallbackGroup | None = None) -> Subscription:
    """A raw subscription of the input ``endpoint`` on ``node``."""
    # (rclpy ignores what a callback returns; the raw-take loop reads it: DRAINED)
    return node.create_subscription(
        interface_class(endpoint.type), endpoint.name, cast('Callable[[bytes], None]', callback),
        qos_profile(endpoint.qos),
        callback_group=callback_group, raw=True, **_overriding(endpoint))


def create_publisher(node: Node, endpoint: Endpoint, name: str = '',
                     on_matched: Callable[[], None] | None = None) -> Publisher:
    """The publisher of the output ``endpoint`` on ``node`` (``name``: the name a scene gives
    it, else the endpoint's); ``on_matched`` is called (by the executor serving the node's
    default callback group) when a subscription matches it or leaves it."""
    options: dict[str, Any] = _overriding(endpoint)
    if on_matched is not None:
        options['event_callbacks'] = PublisherEventCallbacks(
            matched=lambda status: on_matched())
    return node.create_publisher(interface_class(endpoint.type), name or endpoint.name,
                                 qos_profile(endpoint.qos), **options)


def create_service(node: Node, endpoint: Endpoint, callback: Callable[[Any, Any], Any]
                   ) -> Service:
    """The service ``endpoint`` on ``node``."""
    return node.create_service(interface_class(endpoint.type), endpoint.name, callback,
                               qos_profile=qos_profile(endpoint.qos))
