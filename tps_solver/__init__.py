"""tps_solver: kinks and oscillons of vibrated granular layers.

Implements the antiplane continuum model of Goddard & Didwania, *A fluid-like
model of vibrated granular layers: linear stability, kinks, and oscillons*.

Public API (see ``README.md`` for a tour):

* :class:`FlatLayer` -- the periodically bouncing flat layer, eqs. (17)-(19);
* :class:`ViscoelasticRestitution`, :class:`PowerLawRestitution`, :class:`ConstantRestitution`,
  :class:`CallableRestitution` -- restitution laws e(v), accepted wherever ``e`` is (point impacts);
* :func:`secular_roots`, :func:`growth_rates` -- linear stability, eq. (35);
* :func:`solve_kink`, :func:`solve_oscillon`, :func:`solve_lattice`,
  :class:`PeriodicSolution`, :func:`load` -- the spectral time-periodic solver
  (TPS), eqs. (38)-(50), on the continuum or on an FDA lattice;
* :func:`solve_lattice_cycle` -- exact single-contact periodic orbits of a
  lattice (the TPS summed to all orders), the reference for TPS and FDA;
* :class:`Lattice` -- the FDA's grids and Laplacians, shared by the TPS and the FDA;
* :func:`simulate`, :data:`METHODS` -- the event-driven FDA, eqs. (51)-(63);
* :class:`SoftFlatOrbit` -- the flat layer of the soft-contact model;
* :class:`PeriodicOrbit`, :data:`STATUS`, :class:`ContactPattern` -- the vocabulary of every periodic
  result; :class:`ShootingOrbit` and :class:`StickSolution`, the results of shooting and of the
  impact-and-stick TPS; :class:`Problem`, the problem protocol of the one Newton and of
  :func:`continue_branch`;
* :func:`check_stability` -- hands a limit cycle to the FDA;
* :func:`find_periodic_orbit` -- periodic orbits of any contact pattern by shooting;
* :func:`lattice_kink`, :func:`lattice_oscillon`, :func:`front_width` -- kinks and oscillons of
  any contact pattern on lattices (settle, then shoot);
* :func:`front_fate`, :func:`invasion_speed` -- what a time-stepped front does (settles, drifts,
  collapses, invades, ...) and how fast it invades, from its per-period records;
* :func:`continue_branch`, :class:`Branch` -- continuation with folds and period doublings;
* :func:`flat_basins` -- basins of attraction of the bouncing ball (one node);
* :func:`solve_stick_flat`, :func:`solve_stick_lattice` -- the TPS for impact-and-stick contacts
  (e -> 0), flat and on Neumann lattices;
* :func:`sweep` -- parameter sweeps on any ``concurrent.futures.Executor`` (Dask too), resumable.

See ``ARCHITECTURE.md`` for the layers and what each module owns.

Submodules are imported lazily (PEP 562), so ``import tps_solver`` is cheap.
"""
from importlib import import_module

__version__ = "0.1.0"

# public name -> submodule that defines it
_LAZY = {
    "FlatLayer": "model.flat",
    "SoftFlatOrbit": "model.soft_flat",
    "ConstantRestitution": "model.restitution",
    "ViscoelasticRestitution": "model.restitution",
    "PowerLawRestitution": "model.restitution",
    "CallableRestitution": "model.restitution",
    "secular_roots": "model.linear_stability",
    "growth_rates": "model.linear_stability",
    "solve_kink": "solvers.tps",
    "solve_oscillon": "solvers.tps",
    "solve_lattice": "solvers.tps",
    "solve_lattice_cycle": "solvers.tps",
    "LatticeCycle": "solvers.tps",
    "PeriodicSolution": "solvers.tps",
    "PeriodicOrbit": "core.orbit",
    "STATUS": "core.orbit",
    "ContactPattern": "core.pattern",
    "load": "analyses.files",
    "Lattice": "operators.lattice",
    "simulate": "solvers.fda",
    "METHODS": "solvers.fda",
    "SimulationResult": "solvers.fda",
    "check_stability": "analyses.stability",
    "StabilityResult": "analyses.stability",
    "find_periodic_orbit": "solvers.shooting.periodic",
    "continue_branch": "analyses.continuation",
    "Branch": "analyses.continuation",
    "load_branch": "analyses.continuation",
    "sweep": "analyses.sweep",
    "flat_basins": "analyses.basins",
    "lattice_kink": "analyses.localized",
    "lattice_oscillon": "analyses.localized",
    "front_width": "analyses.localized",
    "front_fate": "analyses.fronts",
    "invasion_speed": "analyses.fronts",
    "solve_stick_flat": "solvers.tps.stick",
    "solve_stick_lattice": "solvers.tps.stick",
    "StickSolution": "solvers.tps.stick",
    "ShootingOrbit": "solvers.shooting.periodic",
    "Problem": "core.problem",
}

__all__ = sorted(_LAZY) + ["__version__"]


def __getattr__(name):
    try:
        module = _LAZY[name]
    except KeyError:
        raise AttributeError(f"module 'tps_solver' has no attribute {name!r}") from None
    value = getattr(import_module(f"{__name__}.{module}"), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(__all__))
