"""The message-type table of rigid_body_attitude.msgs against ROS 2 Jazzy's definitions.

The table is written out in the package (the node must not load a bag library to read an Imu);
here it is compared field for field with the definitions in ``rosbags``' Jazzy type store, so a
difference fails loudly.
"""

import pytest
from rosbags.interfaces import Nodetype

from rigid_body_attitude import bag, msgs
from rigid_body_attitude.msgs.types import Layout

HEADER = 'std_msgs/msg/Header'


def flattened(msgtype):
    """``(stamped, float64 field names)`` of a Jazzy type, nested names joined by dots;
    None if any field other than a leading header is not float64."""
    _, fields = bag.typestore().fielddefs[msgtype]
    stamped = bool(fields) and fields[0] == ('header', (Nodetype.NAME, HEADER))
    names = []
    for name, (kind, details) in fields[1:] if stamped else fields:
        if kind == Nodetype.BASE and details[0] == 'float64':
            names.append(name)
        elif kind == Nodetype.ARRAY and details[0] == (Nodetype.BASE, ('float64', 0)):
            names += [f'{name}[{index}]' for index in range(details[1])]
        elif kind == Nodetype.NAME:
            nested = flattened(details)
            if nested is None or nested[0]:
                return None
            names += [f'{name}.{field}' for field in nested[1]]
        else:
            return None
    return stamped, tuple(names)


@pytest.mark.parametrize('msgtype', sorted(msgs.FIXED_LAYOUTS))
def test_fixed_layouts_are_the_jazzy_definitions(msgtype):
    layout = msgs.FIXED_LAYOUTS[msgtype]
    assert flattened(msgtype) == (layout.stamped, layout.fields)


def test_every_type_is_a_jazzy_type_and_diagnostics_are_not_fixed():
    known = bag.typestore().fielddefs
    assert all(msgtype in known for msgtype in msgs.MESSAGE_TYPES)
    assert flattened(msgs.DIAGNOSTIC_ARRAY) is None
    assert set(msgs.MESSAGE_TYPES) == {
        *msgs.FIXED_LAYOUTS, msgs.ODOMETRY, msgs.DIAGNOSTIC_ARRAY}


def test_the_comparison_sees_a_difference():
    imu = msgs.FIXED_LAYOUTS[msgs.IMU]
    swapped = Layout(True, imu.fields[:13] + imu.fields[14:15] + imu.fields[13:14]
                     + imu.fields[15:])
    assert flattened(msgs.IMU) == (True, imu.fields) != (True, swapped.fields)
    assert imu.count == 37 and imu.at('angular_velocity.x') == 13
    assert imu.at('linear_acceleration.x') == 25


def test_odometry_body_is_the_jazzy_definition_after_its_two_strings():
    _, fields = bag.typestore().fielddefs[msgs.ODOMETRY]
    assert [name for name, _ in fields[:2]] == ['header', 'child_frame_id']
    names = []
    for name, (_, details) in fields[2:]:
        nested = flattened(details)
        assert nested is not None and not nested[0]
        names += [f'{name}.{field}' for field in nested[1]]
    assert tuple(names) == msgs.ODOMETRY_BODY.fields and msgs.ODOMETRY_BODY.count == 85
