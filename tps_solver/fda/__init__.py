"""The event-driven finite-difference approximation (FDA), eqs. (51)-(63), (66)-(67).

* :class:`Lattice` -- planar (63) and axisymmetric (66) grids with a conservative Laplacian;
* :func:`simulate` -- method of lines with impacts (54), sticking and lift-off,
  integrated exactly between events (55)-(56) or by a scipy ODE solver;
* :class:`SimulationResult`;
* :func:`flat_state`, :func:`kink_state` -- initial states.
"""
from .driver import SimulationResult, simulate
from .lattice import Lattice
from .states import flat_state, kink_state

__all__ = ["Lattice", "simulate", "SimulationResult", "flat_state", "kink_state"]
