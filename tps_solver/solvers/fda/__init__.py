"""The event-driven finite-difference approximation (FDA), eqs. (51)-(63), (66)-(67).

* :func:`simulate` -- the one driver loop: method of lines with impacts (54), sticking and
  lift-off, for every method of :data:`METHODS`;
* :class:`Integrator`, :class:`Step` -- the interface every method implements (:mod:`.base`);
* :class:`SimulationResult` (:mod:`.common`);
* :func:`flat_state`, :func:`kink_state`, :func:`oscillon_state` -- initial states;
* :class:`~tps_solver.operators.lattice.Lattice` is re-exported here for convenience.
"""
from tps_solver.operators.lattice import Lattice
from tps_solver.solvers.fda.base import Integrator, Step
from tps_solver.solvers.fda.common import SimulationResult
from tps_solver.solvers.fda.driver import METHODS, simulate
from tps_solver.solvers.fda.states import flat_state, kink_state, oscillon_state

__all__ = ["Lattice", "simulate", "METHODS", "Integrator", "Step", "SimulationResult", "flat_state",
           "kink_state", "oscillon_state"]
