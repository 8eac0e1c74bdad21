"""Result files: :func:`load` reads every result type of the package (``tps_solver.load``).

The archive (:mod:`tps_solver.core.archive`) knows no result type; each type registers its
codec in its own module.  This module imports every result module, so that every codec is
registered before a file is read.  The result types are ``PeriodicSolution``,
``LatticeCycle``, ``ShootingOrbit``, ``StickSolution``, ``Branch``, ``BasinResult``,
``StabilityResult``, ``SimulationResult`` and ``SecularRoots``; each has a ``save`` method.
"""
from tps_solver.core import archive
from tps_solver.model import linear_stability  # noqa: F401  (registers SecularRoots)
from tps_solver.solvers.fda import common  # noqa: F401  (SimulationResult)
from tps_solver.solvers.shooting import periodic  # noqa: F401  (ShootingOrbit)
from tps_solver.solvers.tps import cycle, result, stick  # noqa: F401  (LatticeCycle, PeriodicSolution, StickSolution)
from tps_solver.analyses import basins, continuation, stability  # noqa: F401  (BasinResult, Branch, StabilityResult)

__all__ = ["load"]


def load(path, kind=None):
    """Read any result file written by a result's ``save`` (with or without its ``.npz`` ending).

    Parameters
    ----------
    path : str or os.PathLike
    kind : str, optional
        The result type expected (e.g. ``"PeriodicSolution"``); a file of another type is an error.

    Returns
    -------
    object
        The result, every stored field bit for bit as saved.

    Raises
    ------
    ValueError
        Every failure, naming the file and saying what is wrong: the file does not exist
        (:class:`tps_solver.core.archive.MissingFileError`, also a ``FileNotFoundError``),
        ``path`` is not a file name or is a directory, or the file is truncated, damaged
        (its SHA-256 seal does not match), foreign, of a newer format version, of another
        kind than ``kind``, or holds a missing, mistyped, inconsistent or unphysical field.

    Examples
    --------
    >>> import os, tempfile
    >>> from tps_solver import FlatLayer, check_stability
    >>> chk = check_stability(FlatLayer(2.5, 2, e=0.45), periods=3, n_nodes=4)
    >>> with tempfile.TemporaryDirectory() as d:
    ...     back = load(chk.save(os.path.join(d, "check")))
    >>> type(back).__name__, back.stable == chk.stable, back.lattice.spacing == chk.lattice.spacing
    ('StabilityResult', True, True)
    >>> load(None)
    Traceback (most recent call last):
    ...
    ValueError: path must be a file name (str or os.PathLike), got None
    """
    return archive.load(path, kind)
