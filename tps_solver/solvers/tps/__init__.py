"""The spectral time-periodic solver (TPS), eqs. (38)-(50), and the exact lattice cycle.

* :mod:`.engine` -- Newton--GMRES, continuation in the coupling, fixed-point schemes,
  and the problem protocol they use;
* :mod:`.problems` -- the continuum problem (45)-(46) and its FDA-lattice twin;
* :mod:`.cycle` -- exact single-contact lattice cycles (the TPS to all orders);
* :mod:`.solvers` -- the front ends :func:`solve_kink`, :func:`solve_oscillon`, :func:`solve_lattice`;
* :mod:`.result` -- :class:`PeriodicSolution` and its file format;
* :mod:`.checks` -- the physical checks of the single-contact assumption.
"""
from tps_solver.solvers.tps.cycle import LatticeCycle, solve_lattice_cycle
from tps_solver.solvers.tps.result import PeriodicSolution, load
from tps_solver.solvers.tps.solvers import solve_kink, solve_lattice, solve_oscillon

__all__ = ["solve_kink", "solve_oscillon", "solve_lattice", "solve_lattice_cycle", "PeriodicSolution",
           "LatticeCycle", "load"]
