"""Rigid-body dynamics: inertia, Euler's equations, effects, dynamics integrators, scenes.

:mod:`.euler` holds Euler's equations ``J ω̇ + ω × (J ω + h) = M − ḣ`` and the body model the
integrators see; :mod:`.effects` the torques, forces and rate corrections a scene may name;
:mod:`.integrators` the dynamics integrators (the exact torque-free solution included);
:mod:`.diagnostics` energy and momentum; :mod:`.batch` many bodies at once; :mod:`.scene` the
validated scene file.
"""
