"""Helpers shared by the FDA driver and its integrators: the result type, time windows, samples."""
import numpy as np

from tps_solver.core import archive as io
from tps_solver.core.checks import check_array, check_real
from tps_solver.core.bunch import Bunch
from tps_solver.core.orbit import STATUS

__all__ = ["SimulationResult", "check_time_window", "stack_samples", "SIMULATION_STATUS"]

#: The codes of the one table :data:`tps_solver.STATUS` that a simulation returns.
SIMULATION_STATUS = {k: STATUS[k] for k in (0, 3, 5, 6)}


class SimulationResult(Bunch):
    """Result of :func:`simulate`.

    Attributes
    ----------
    t : float
        Final time (``t_end``, or the time the run stopped).
    w, zeta : ndarray of float, shape (n_nodes,)
        Final state.
    stuck : ndarray of bool, shape (n_nodes,)
        Nodes stuck to the plate at ``t``.
    events : numpy.recarray
        Time-ordered records with fields ``t``, ``node``, ``kind``
        (``"impact"``, ``"stick"``, ``"liftoff"``) and ``w_before``.
    n_events : int
    success : bool
    status : int
        A code of :data:`tps_solver.STATUS` (:data:`SIMULATION_STATUS` lists those used):
        0 reached ``t_end``; 6 event bound exceeded (chattering); 3 contact search stalled; 5 interrupted (the state so far).
    message : str
    t_eval : ndarray of float, shape (k,)
    w_eval, zeta_eval : ndarray of float, shape (k, n_nodes)
        States at the requested output times (pre-event values at event instants).
    cutoff : dict
        The regularisation length in force (docs/design.md, hazard 8): ``{"kind", "length"}``.
    method : str
    n_steps : int
        Search steps (exact) or solver steps (ode).

    Examples
    --------
    A uniform flat layer on three nodes lands every period ``T = 4 pi`` (M = 2):

    >>> import numpy as np
    >>> from tps_solver import FlatLayer, Lattice, simulate
    >>> from tps_solver.solvers.fda import flat_state
    >>> fl = FlatLayer(2.5, 2, e=0.45)
    >>> lat = Lattice.planar(n_nodes=3, length=2.0)
    >>> res = simulate(lat, 2.5, 0.45, *flat_state(lat, fl, fl.t0), t_start=fl.t0, t_end=fl.t0 + 2 * fl.period + 1.0)
    >>> res.status, res.n_events, sorted(set(res.events.kind.tolist()))
    (0, 6, ['impact'])
    >>> bool(np.allclose(res.events.t - fl.t0, [4 * np.pi] * 3 + [8 * np.pi] * 3))
    True
    >>> bool(np.allclose(res.zeta, fl.height(res.t), atol=1e-12))
    True
    """

    def save(self, path):
        """Write the result to ``path`` (``.npz`` appended if missing; see :mod:`tps_solver.core.archive`); returns the path."""
        return io.save(self, path)


def check_time_window(t_start, t_end, t_eval):
    """Validate the integration interval and the output times; returns them as floats/array.

    Returns
    -------
    t_start, t_end : float
    t_eval : ndarray of float, shape (k,)
        Sorted; empty when ``t_eval`` is None.

    Examples
    --------
    >>> check_time_window(0, 2.0, [1.5, 0.5])
    (0.0, 2.0, array([0.5, 1.5]))
    >>> check_time_window(1.0, 0.5, None)
    Traceback (most recent call last):
    ...
    ValueError: t_end must be > t_start = 1.0, got 0.5
    """
    t_start = check_real(t_start, "t_start")
    if t_end is None:
        raise ValueError("t_end must be given (a finite number > t_start)")
    t_end = check_real(t_end, "t_end")
    if t_end <= t_start:
        raise ValueError(f"t_end must be > t_start = {t_start}, got {t_end}")
    if t_eval is None:
        return t_start, t_end, np.empty(0)
    t_eval = np.sort(check_array(t_eval, "t_eval", ndim=1))
    if t_eval.size and (t_eval[0] < t_start or t_eval[-1] > t_end):
        raise ValueError(f"t_eval must lie in [t_start, t_end] = [{t_start}, {t_end}]")
    return t_start, t_end, t_eval


def stack_samples(samples, n):
    """Stack ``(t, w, zeta)`` output samples into arrays of shapes (k,), (k, n), (k, n).

    Examples
    --------
    >>> t, w, z = stack_samples([(0.0, np.zeros(2), np.ones(2)), (1.0, np.ones(2), np.zeros(2))], 2)
    >>> t.tolist(), w.shape, z[:, 0].tolist()
    ([0.0, 1.0], (2, 2), [1.0, 0.0])
    >>> [a.shape for a in stack_samples([], 3)]
    [(0,), (0, 3), (0, 3)]
    """
    if not samples:
        return np.empty(0), np.empty((0, n)), np.empty((0, n))
    return (np.array([s[0] for s in samples]), np.array([s[1] for s in samples]),
            np.array([s[2] for s in samples]))


# ------------------------------------------------------------------ file codec (tps_solver.core.archive)
def _validate_simulation(f):
    from tps_solver.operators.lattice import Lattice

    n = f.instance("lattice", Lattice).n_nodes
    f.float("t")
    f.array("w", "f", shape=(n,), finite=True)
    f.array("zeta", "f", shape=(n,), finite=True)
    f.array("stuck", "b", shape=(n,))
    k = f.array("t_eval", "f", ndim=1, finite=True).size
    f.array("w_eval", "f", shape=(k, n), finite=True)
    f.array("zeta_eval", "f", shape=(k, n), finite=True)
    status = f.int("status")
    if status not in SIMULATION_STATUS:
        f.fail(f"the field 'status' must be a code of SIMULATION_STATUS, got {status}")
    if f.bool("success") != (status == 0):
        f.fail(f"inconsistent: success = {f.bool('success')} but status = {status}")
    events = f.get("events")
    if not isinstance(events, np.recarray) or set(events.dtype.names or ()) < {"t", "node", "kind"}:
        f.fail("the field 'events' must be a record array with fields t, node, kind")
    if events.size and (np.any(events.node < 0) or np.any(events.node >= n)):
        f.fail(f"the field 'events' must hold node indices in [0, {n})")


io.register("SimulationResult", SimulationResult, validate=_validate_simulation)
