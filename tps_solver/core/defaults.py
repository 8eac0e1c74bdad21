r"""The one set of defaults of the library, the command line and the demo.

Every front end -- :func:`~tps_solver.solve_kink`, :func:`~tps_solver.solve_oscillon`,
:func:`~tps_solver.solve_lattice`, :func:`~tps_solver.solve_lattice_cycle`, the
``tps-solver kink`` / ``oscillon`` commands and ``tps-solver demo`` -- takes its
default model and grid from here, so a call with no arguments, the command with no
flags and the demo compute the same thing.

Model
-----
``GAMMA = 2.5`` (``GAMMA_STICK = 4.1`` for e = 0, where 2.5 has no f/2 orbit), ``M = 2`` and ``E = 0.45``: the flat layer of launch phase
``t0 = 0.3068`` in the *interior* of its stability window (Floquet multipliers
``-0.192 +/- 0.407i``, modulus 0.45).  The paper's preset ``t0 = 0`` (which fixes
``e = 0.4307`` by (19)) is *not* the default: it sits exactly on the fold of the flat
orbit (a Floquet multiplier equal to 1), where the continuation of the TPS cannot
even start.  It is kept as the named preset :data:`PAPER_PRESET`.  The model is fixed
by one of ``e`` and ``t0``; when neither is given the solvers use ``e = E``.

Grid
----
Single-contact kinks and oscillons exist only on coarse grids: the branch followed
from the decoupled limit ends at a fold when the node spacing falls below about
10.9 viscous lengths in the continuum TPS and 13.6 on the FDA's own lattice
(``validation/REPORT.md``; README, "Results").  A default grid finer than that would
make the first call fail by construction.  The default grid therefore has
``SPACING = 20`` viscous lengths (the README's ``coarse`` lattice, where the TPS, the
exact lattice cycle and the FDA agree to round-off) and ``N_NODES = 8`` nodes:

* oscillon: ``r_j = j h``, ``r_max = SPACING * (N_NODES - 1) = 140``;
* kink: ``x_j = (j + 1/2) h`` on the half-line, ``half_length = SPACING * (N_NODES - 1/2)
  = 150`` (16 nodes on the full line);
* lattice: :data:`COARSE_LATTICE` (8 nodes over a length 140).

A finer grid is a deliberate choice; on it the solvers return ``status = 4`` and a
message naming the spacing that converges.

Examples
--------
>>> from tps_solver.core import defaults
>>> defaults.E, defaults.N_NODES, defaults.R_MAX, defaults.HALF_LENGTH
(0.45, 8, 140.0, 150.0)
>>> defaults.model()
{'e': 0.45, 't0': None}
>>> defaults.model(t0=0.0)
{'e': None, 't0': 0.0}
"""

__all__ = ["GAMMA", "GAMMA_STICK", "M", "E", "PAPER_PRESET", "STABLE_PRESET", "PRESETS", "N_HARMONICS", "SPACING",
           "N_NODES", "R_MAX", "HALF_LENGTH", "R_CORE", "COARSE_LATTICE", "TOL", "MAX_ITER",
           "FOLD_SPACING_TPS", "FOLD_SPACING_LATTICE", "model"]

#: Plate acceleration.
GAMMA = 2.5
#: Plate acceleration of the completely inelastic (e = 0) kinks and oscillons: at GAMMA = 2.5 the
#: e = 0 layer has no f/2 orbit (the sticking one exists for 3.857 <= Gamma <= 6.362).
GAMMA_STICK = 4.1
#: Subharmonic order (period T = 2 pi M).
M = 2
#: Restitution of the default flat layer (stable interior, t0 = 0.3068).
E = 0.45
#: The paper's preset: launch phase t0 = 0 (e = 0.4307 by (19)), at the fold of the flat orbit.
PAPER_PRESET = {"t0": 0.0}
#: The default model as a preset.
STABLE_PRESET = {"e": E}
#: Named presets, for ``solve_*(**PRESETS[name])``.
PRESETS = {"stable": STABLE_PRESET, "paper": PAPER_PRESET}

#: Truncation N of the Fourier series (38)-(39).
N_HARMONICS = 30
#: Node spacing of the default grids, in viscous lengths (above the fold spacing, see the module docstring).
SPACING = 20.0
#: Nodes of the default grids (oscillon: radius; kink: half-line).
N_NODES = 8
#: Oscillon radius: N_NODES nodes r_j = j * SPACING.
R_MAX = SPACING * (N_NODES - 1)
#: Kink half-width: N_NODES staggered nodes x_j = (j + 1/2) * SPACING.
HALF_LENGTH = SPACING * (N_NODES - 0.5)
#: Core radius of the oscillon's initial guess (only the node at r = 0 on the default grid).
R_CORE = 1.0
#: The default lattice of the lattice solvers: ``Lattice.planar(**COARSE_LATTICE)``.
COARSE_LATTICE = {"n_nodes": N_NODES, "length": SPACING * (N_NODES - 1)}
#: Newton tolerance on max|F| of the contact condition (46).
TOL = 1e-10
#: Newton iteration limit.
MAX_ITER = 50

#: Measured node spacing below which the single-contact branch of the continuum TPS ends (a fold).
FOLD_SPACING_TPS = 10.9
#: The same on the FDA's own lattice (exact lattice cycle, no truncation in N).
FOLD_SPACING_LATTICE = 13.6


def model(e=None, t0=None):
    """The ``(e, t0)`` pair a solver uses: the default ``e = E`` when neither is given.

    Parameters
    ----------
    e : float or None
    t0 : float or None

    Returns
    -------
    dict
        ``{"e": e, "t0": t0}`` with ``e = E`` filled in when both were None.

    Examples
    --------
    >>> model()
    {'e': 0.45, 't0': None}
    >>> model(e=0.3)
    {'e': 0.3, 't0': None}
    >>> model(**PAPER_PRESET)
    {'e': None, 't0': 0.0}
    """
    if e is None and t0 is None:
        e = E
    return {"e": e, "t0": t0}
