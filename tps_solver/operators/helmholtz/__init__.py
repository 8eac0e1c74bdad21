"""Per-harmonic Helmholtz solves (45): the continuum Green's-function quadrature and the lattice solve.

* :class:`HelmholtzSolver` (:mod:`.continuum`) -- (48)-(50) by Green's-function quadrature, O(n) sweeps;
* :class:`LatticeHelmholtz` (:mod:`.lattice`) -- the same problem on an FDA lattice, one banded solve.
"""
from tps_solver.operators.helmholtz.continuum import HelmholtzSolver
from tps_solver.operators.helmholtz.lattice import LatticeHelmholtz

__all__ = ["HelmholtzSolver", "LatticeHelmholtz"]
