"""Name → integrator lookup used by scenes and propagators (see :mod:`.integrators`)."""

from rigid_body_attitude.integrators import dynamics_integrator, strapdown_method

__all__ = ['dynamics_integrator', 'strapdown_method']
