"""The event-driven finite-difference approximation (FDA), eqs. (51)-(63), (66)-(67).

* :func:`simulate` -- the one driver loop: method of lines with impacts (54), sticking and
  lift-off, for every method of :data:`METHODS`;
* :class:`Integrator`, :class:`Step` -- the interface every method implements (:mod:`.base`);
* :class:`SimulationResult` (:mod:`.common`);
* :func:`flat_state`, :func:`kink_state`, :func:`oscillon_state` -- initial states;
* :class:`~tps_solver.lattice.Lattice` is re-exported here for convenience.
"""
from ..lattice import Lattice
from .base import Integrator, Step
from .common import SimulationResult
from .driver import METHODS, simulate
from .states import flat_state, kink_state, oscillon_state

__all__ = ["Lattice", "simulate", "METHODS", "Integrator", "Step", "SimulationResult", "flat_state",
           "kink_state", "oscillon_state"]
