"""The environment a body moves in: world axes, the magnetic field (and, for a spacecraft, its
orbit), shared by the effects that act on the body and the sensors that measure it."""
