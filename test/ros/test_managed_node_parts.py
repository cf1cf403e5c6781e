"""The managed node in-process: what ``configure`` builds is one object (``parts``), and
``cleanup`` drops it whole: no entity, no attribute and no object of it survives."""

from __future__ import annotations

import gc
import weakref

import pytest
from rclpy.lifecycle import TransitionCallbackReturn
from rclpy.parameter import Parameter
from ros_helpers import unique_namespace

from rigid_body_attitude.ros.managed_node import ManagedPropagatorNode


def entities(node):
    """Every rclpy entity the node holds."""
    return {*node.publishers, *node.subscriptions, *node.timers, *node.services,
            *node.clients, *node.guards}


@pytest.mark.parametrize('parameters', [
    {'scene': 'strapdown', 'publish_tf': True},
    {'scene': 'commanded_torque', 'publish_tf': True},
])
def test_cleanup_drops_everything_configure_built(ros, request, parameters):
    node = ManagedPropagatorNode(
        context=ros.context, namespace=unique_namespace(request),
        parameter_overrides=[Parameter(name, value=value) for name, value in parameters.items()])
    try:
        attributes, before = set(vars(node)), entities(node)
        assert node.parts is None and not node.configured
        for _ in range(2):  # configure, clean up, and again
            assert node.trigger_configure() == TransitionCallbackReturn.SUCCESS
            parts = node.parts
            assert parts is not None and node.configured
            built = entities(node) - before
            assert parts.diagnostics_timer in built and parts.reset_service in built
            assert set(parts.subscriptions_by_topic.values()) <= built
            assert len(built) > len(parts.subscriptions_by_topic) + 2  # the publishers too
            gone = [weakref.ref(parts), weakref.ref(parts.session), weakref.ref(parts.outputs)]
            del parts, built  # the test's own references (callbacks hold the session)
            assert node.trigger_cleanup() == TransitionCallbackReturn.SUCCESS
            assert node.parts is None and not node.configured
            assert entities(node) == before
            assert set(vars(node)) == attributes  # nothing configure set survives
            gc.collect()
            assert [ref() for ref in gone] == [None, None, None]
    finally:
        node.destroy_node()
