r"""One file format for every result: :func:`save` and :func:`load`.

A result file is a NumPy ``.npz`` archive read with ``allow_pickle=False``.  It holds

* ``format`` = ``"tps_solver"`` and ``format_version`` (:data:`FORMAT_VERSION`);
* ``kind``: the result type, a key of :data:`KINDS` (``"PeriodicSolution"``,
  ``"LatticeCycle"``, ``"StabilityResult"``, ``"SimulationResult"``, ``"SecularRoots"``);
* the fields of the result, each a NumPy array (numbers, strings, 0-d arrays for
  scalars); a :class:`~tps_solver.Lattice` is stored as its nodes, geometry,
  boundary and grid, a :class:`~tps_solver.FlatLayer` as (Gamma, M, e, t0).

File names: :func:`save` appends ``.npz`` when the name does not end with it and
returns the path it wrote; :func:`load` accepts the name with or without ``.npz``.

Validation on load: a file that is not a readable ``.npz`` archive (truncated,
damaged, pickled, foreign) raises ``ValueError`` saying so; so does a file of a
newer format version (the message names the version), a missing or mistyped field,
and an inconsistent one.  What is derived is recomputed rather than trusted: the
flat layer from (Gamma, M, t0) and its restitution compared with the stored ``e``
(19); the height harmonics from the velocity harmonics by (39)-(40); the lattice
from its nodes; the physical checks of a TPS solution; the modal decomposition of a
lattice cycle.  Files written before the format was versioned (``PeriodicSolution``
only, no ``format`` entry) are read as format version 0.

The result classes call :func:`save` from their ``save`` method; :func:`load` finds
the class of a file's ``kind`` by the module named in :data:`KINDS`, so this module
imports none of them (no import cycle).

Examples
--------
>>> import os, tempfile
>>> from tps_solver import FlatLayer, check_stability
>>> chk = check_stability(FlatLayer(2.5, 2, e=0.45), periods=3, n_nodes=4)
>>> with tempfile.TemporaryDirectory() as d:
...     path = save(chk, os.path.join(d, "check"))
...     back = load(os.path.join(d, "check"))
...     print(os.path.basename(path), back.stable == chk.stable, type(back).__name__)
check.npz True StabilityResult
"""
import importlib
import math
import os
import tempfile
import zipfile
import zlib

import numpy as np

from tps_solver.model.flat import FlatLayer
from tps_solver.model.harmonics import evaluate, height_from_velocity, mode_numbers, sawtooth, sawtooth_hat
from tps_solver.operators.lattice import Lattice
from tps_solver.core.orbit import STATUS

__all__ = ["save", "load", "npz_path", "FORMAT", "FORMAT_VERSION", "KINDS"]

FORMAT = "tps_solver"
#: Version written by :func:`save`; :func:`load` reads versions 0 .. FORMAT_VERSION.
FORMAT_VERSION = 1
#: kind -> module defining the class of that name
KINDS = {
    "PeriodicSolution": "tps_solver.solvers.tps.result",
    "LatticeCycle": "tps_solver.solvers.tps.cycle",
    "StabilityResult": "tps_solver.analyses.stability",
    "SimulationResult": "tps_solver.solvers.fda.common",
    "SecularRoots": "tps_solver.model.linear_stability",
}
_META = ("format", "format_version", "kind")
_V0_KEYS = {"geometry", "nodes", "tc", "w_hat", "zeta_hat", "zeta_shift", "Gamma", "e", "t0", "M", "N"}


def npz_path(path):
    """The file name :func:`save` writes for ``path``: ``path`` with ``.npz`` appended if missing.

    Examples
    --------
    >>> npz_path("run"), npz_path("run.npz")
    ('run.npz', 'run.npz')
    """
    path = os.fspath(path)
    if not isinstance(path, str) or not path:
        raise ValueError(f"path must be a non-empty file name, got {path!r}")
    return path if path.endswith(".npz") else path + ".npz"


# ----------------------------------------------------------------------------- writing


def _lattice_fields(prefix, lattice):
    if lattice is None:
        return {f"{prefix}.present": np.array(False)}
    return {f"{prefix}.present": np.array(True), f"{prefix}.nodes": np.asarray(lattice.nodes, dtype=float),
            f"{prefix}.geometry": np.array(lattice.geometry), f"{prefix}.boundary": np.array(lattice.boundary),
            f"{prefix}.grid": np.array(lattice.grid)}


def _cutoff_fields(cutoff):
    length = cutoff.get("length")
    out = {"cutoff.kind": np.array(str(cutoff.get("kind"))),
           "cutoff.length": np.array(np.nan if length is None else float(length))}
    if "tau_c" in cutoff:
        out["cutoff.tau_c"] = np.array(float(cutoff["tau_c"]))
    return out


def _orbit_fields(r):
    return {"converged": np.array(bool(r.converged)), "status": np.array(int(r.status)),
            "message": np.array(str(r.message)), "nit": np.array(int(r.nit)),
            "residual": np.array(float(r.residual)),
            "residual_history": np.asarray(r.residual_history, dtype=float),
            "Gamma": np.array(float(r.Gamma)), "e": np.array(float(r.e)), "t0": np.array(float(r.t0)),
            "M": np.array(int(r.M)), "coupling": np.array(float(r.coupling)),
            "continuation_path": np.asarray(r.continuation_path, dtype=float).reshape(-1, 3),
            "time": np.array(float(r.get("time", np.nan)))}


def _encode_periodic_solution(r):
    out = _orbit_fields(r)
    out.update(geometry=np.array(r.geometry), nodes=np.asarray(r.nodes, dtype=float),
               tc=np.asarray(r.tc, dtype=float), w_hat=np.asarray(r.w_hat, dtype=complex),
               zeta_hat=np.asarray(r.zeta_hat, dtype=complex),
               zeta_shift=np.asarray(r.zeta_shift, dtype=float), N=np.array(int(r.N)),
               min_shift=np.array(bool(r.min_shift)), scheme=np.array(str(r.scheme)),
               tail_correction=np.array(bool(r.tail_correction)))
    out.update(_lattice_fields("lattice", r.get("lattice")))
    return out


def _encode_lattice_cycle(r):
    out = _orbit_fields(r)
    out.update(tc=np.asarray(r.tc, dtype=float), branch=np.array(r.flat.branch))
    out.update(_lattice_fields("lattice", r.lattice))
    return out


def _encode_stability(r):
    diff = r.differentiable
    out = {"defects": np.asarray(r.defects, dtype=float).reshape(-1, 2),
           "initial_defect": np.asarray(r.initial_defect, dtype=float),
           "growth_factor": np.array(float(r.growth_factor)),
           "growth_history": np.asarray(r.growth_history, dtype=float),
           "growth_window": np.asarray(r.growth_window, dtype=np.int64),
           "multipliers": np.asarray(r.multipliers, dtype=complex),
           "multipliers_kind": np.array(str(r.multipliers_kind)),
           "uniform_multipliers": np.asarray(r.uniform_multipliers, dtype=complex),
           "differentiable": np.array(-1 if diff is None else int(bool(diff))),
           "stable": np.array(bool(r.stable)), "message": np.array(str(r.message)),
           "events_per_period": np.asarray(r.events_per_period, dtype=np.int64),
           "sticking_nodes": np.asarray(r.sticking_nodes, dtype=np.int64),
           "cutoff_limited": np.array(bool(r.cutoff_limited)), "method": np.array(str(r.method)),
           "period": np.array(float(r.period)), "section_time": np.array(float(r.section_time)),
           "periods": np.array(int(r.periods)), "success": np.array(bool(r.success))}
    out.update(_cutoff_fields(r.cutoff))
    out.update(_lattice_fields("lattice", r.lattice))
    return out


def _encode_simulation(r):
    ev = np.asarray(r.events)
    out = {"t": np.array(float(r.t)), "w": np.asarray(r.w, dtype=float), "zeta": np.asarray(r.zeta, dtype=float),
           "stuck": np.asarray(r.stuck, dtype=bool), "events.t": np.asarray(ev["t"], dtype=float),
           "events.node": np.asarray(ev["node"], dtype=np.int64), "events.kind": np.asarray(ev["kind"], dtype="U7"),
           "events.w_before": np.asarray(ev["w_before"], dtype=float),
           "success": np.array(bool(r.success)), "status": np.array(int(r.status)),
           "message": np.array(str(r.message)), "t_eval": np.asarray(r.t_eval, dtype=float),
           "w_eval": np.asarray(r.w_eval, dtype=float), "zeta_eval": np.asarray(r.zeta_eval, dtype=float),
           "method": np.array(str(r.method)), "n_steps": np.array(int(r.n_steps)),
           "Gamma": np.array(float(r.Gamma)), "e": np.array(float(r.e))}
    out.update(_cutoff_fields(r.cutoff))
    out.update(_lattice_fields("lattice", r.lattice))
    return out


def _encode_secular_roots(r):
    return {"kappa": np.array(float(r.kappa)), "mode": np.array(str(r.mode)),
            "gamma": np.asarray(r.gamma, dtype=complex), "lam": np.asarray(r.lam, dtype=float),
            "trivial": np.asarray(r.trivial, dtype=complex),
            "trivial_is_eigenvalue": np.asarray(r.trivial_is_eigenvalue, dtype=bool),
            "n_enclosed": np.array(int(r.n_enclosed)), "complete": np.array(bool(r.complete)),
            "contour": np.asarray(r.contour, dtype=float),
            "error_bound": np.asarray(r.get("error_bound", np.full(len(r.gamma), np.nan)), dtype=float),
            "polished": np.asarray(r.get("polished", np.zeros(len(r.gamma), bool)), dtype=bool)}


_ENCODERS = {"PeriodicSolution": _encode_periodic_solution, "LatticeCycle": _encode_lattice_cycle,
             "StabilityResult": _encode_stability, "SimulationResult": _encode_simulation,
             "SecularRoots": _encode_secular_roots}
#: fields recomputed on load (never stored)
_DERIVED = {"PeriodicSolution": {"flat", "checks", "period", "spacing", "success"},
            "LatticeCycle": {"flat", "period", "J", "eigenvalues", "modes", "modes_inv", "zeta_offset", "nodes",
                             "geometry", "success"},
            "StabilityResult": set(), "SimulationResult": {"n_events"}, "SecularRoots": set()}


def _extra_fields(result, fields, kind):
    """Further fields of ``result`` of plain type (numbers, str, numeric arrays), stored as ``extra.<name>``."""
    covered = {k.split(".")[0] for k in fields} | _DERIVED[kind]
    out = {}
    for key, value in result.items():
        if key in covered:
            continue
        if value is None or isinstance(value, (bool, int, float, str, np.generic)):
            if value is None:
                continue
            out[f"extra.{key}"] = np.array(value)
        elif isinstance(value, np.ndarray) and value.dtype.kind in "biufcU":
            out[f"extra.{key}"] = value
    return out


def save(result, path):
    """Write ``result`` to ``path`` (``.npz`` appended if missing); returns the path written.

    Parameters
    ----------
    result : PeriodicSolution, LatticeCycle, StabilityResult, SimulationResult or SecularRoots
    path : str or os.PathLike

    Returns
    -------
    path : str
        The file written (``path``, ending in ``.npz``).

    Raises
    ------
    ValueError
        If ``result`` is not one of the result types of :data:`KINDS`.
    FileNotFoundError, PermissionError
        If the directory does not exist or cannot be written; the file is written to a
        temporary name first and renamed, so a failed save leaves no partial file.

    Examples
    --------
    >>> import os, tempfile
    >>> from tps_solver import secular_roots
    >>> roots = secular_roots(1.0, "sinuous", 3)
    >>> with tempfile.TemporaryDirectory() as d:
    ...     path = save(roots, os.path.join(d, "roots"))
    ...     with np.load(path, allow_pickle=False) as f:
    ...         print(os.path.basename(path), f["format"], f["format_version"], f["kind"])
    roots.npz tps_solver 1 SecularRoots
    >>> save({"gamma": 1.0}, "roots")
    Traceback (most recent call last):
    ...
    ValueError: result must be one of PeriodicSolution, LatticeCycle, StabilityResult, SimulationResult, SecularRoots, got dict
    """
    kind = type(result).__name__
    if kind not in _ENCODERS:
        raise ValueError(f"result must be one of {', '.join(KINDS)}, got {kind}")
    target = npz_path(path)
    fields = _ENCODERS[kind](result)
    fields.update(_extra_fields(result, fields, kind))
    arrays = {"format": np.array(FORMAT), "format_version": np.array(FORMAT_VERSION), "kind": np.array(kind)}
    arrays.update(fields)
    directory = os.path.dirname(os.path.abspath(target))
    if not os.path.isdir(directory):
        raise FileNotFoundError(f"cannot write {target}: the directory {directory} does not exist")
    fd, tmp = tempfile.mkstemp(prefix=".tmp-", suffix=".npz", dir=directory)
    try:
        with os.fdopen(fd, "wb") as fh:
            np.savez_compressed(fh, **arrays)
        os.replace(tmp, target)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return target


# ----------------------------------------------------------------------------- reading


class _Fields:
    """Typed access to the arrays of one file; every failure is a ValueError naming the file and field."""

    def __init__(self, data, path, kind, version):
        self.data, self.path, self.kind, self.version = data, path, kind, version

    def fail(self, what):
        raise ValueError(f"{self.path}: {what} (a {self.kind} file, format version {self.version})")

    def has(self, name):
        return name in self.data

    def _get(self, name):
        if name not in self.data:
            self.fail(f"the field {name!r} is missing")
        return self.data[name]

    def scalar(self, name, kinds, finite=False):
        a = self._get(name)
        if a.shape != () or a.dtype.kind not in kinds:
            self.fail(f"the field {name!r} must be a scalar of kind {kinds!r}, got dtype {a.dtype} shape {a.shape}")
        value = a.item()
        if finite and not math.isfinite(value):
            self.fail(f"the field {name!r} must be finite, got {value!r}")
        return value

    def float(self, name, finite=True):
        return float(self.scalar(name, "fi", finite))

    def int(self, name, minimum=None):
        value = int(self.scalar(name, "iu"))
        if minimum is not None and value < minimum:
            self.fail(f"the field {name!r} must be >= {minimum}, got {value}")
        return value

    def bool(self, name):
        return bool(self.scalar(name, "b"))

    def str(self, name, choices=None):
        value = str(self.scalar(name, "U"))
        if choices is not None and value not in choices:
            self.fail(f"the field {name!r} must be one of {', '.join(map(repr, choices))}, got {value!r}")
        return value

    def array(self, name, kinds, shape=None, ndim=None, finite=False):
        a = self._get(name)
        if a.dtype.kind not in kinds:
            self.fail(f"the field {name!r} must be an array of kind {kinds!r}, got dtype {a.dtype}")
        if ndim is not None and a.ndim != ndim:
            self.fail(f"the field {name!r} must have {ndim} dimension(s), got shape {a.shape}")
        if shape is not None and (a.ndim != len(shape) or any(s is not None and s != n
                                                               for s, n in zip(shape, a.shape))):
            want = "(" + ", ".join("k" if s is None else str(s) for s in shape) + ")"
            self.fail(f"the field {name!r} must have shape {want}, got {a.shape}")
        if finite and a.dtype.kind in "fc" and not np.all(np.isfinite(a)):
            self.fail(f"the field {name!r} holds non-finite values")
        return np.array(a)

    def lattice(self, prefix="lattice"):
        if not self.bool(f"{prefix}.present"):
            return None
        nodes = self.array(f"{prefix}.nodes", "f", ndim=1, finite=True)
        geometry = self.str(f"{prefix}.geometry", ("planar", "axisymmetric"))
        boundary = self.str(f"{prefix}.boundary")
        grid = self.str(f"{prefix}.grid")
        try:
            return Lattice(nodes, geometry, boundary, grid=grid)
        except ValueError as exc:
            self.fail(f"the stored lattice is invalid: {exc}")

    def cutoff(self):
        out = {"kind": self.str("cutoff.kind"), "length": self.float("cutoff.length", finite=False)}
        if math.isnan(out["length"]):
            out["length"] = None
        if self.has("cutoff.tau_c"):
            out["tau_c"] = self.float("cutoff.tau_c")
        return out

    def flat(self):
        """The flat layer of (Gamma, M, t0), checked against the stored restitution (19)."""
        Gamma, M, t0 = self.float("Gamma"), self.int("M", minimum=1), self.float("t0")
        e = self.float("e")
        try:
            fl = FlatLayer(Gamma, M, t0=t0)
        except ValueError as exc:
            self.fail(f"the stored flat layer (Gamma = {Gamma}, M = {M}, t0 = {t0}) is invalid: {exc}")
        if not abs(fl.e - e) <= 1e-9:
            self.fail(f"inconsistent: the stored e = {e!r} but the flat layer launched at the stored "
                      f"t0 = {t0!r} (Gamma = {Gamma}, M = {M}) has e = {fl.e:.15g} by (19)")
        return fl

    def status(self, converged_name="converged"):
        status = self.int("status")
        if status not in STATUS:
            self.fail(f"the field 'status' must be a code of tps_solver.STATUS, got {status}")
        converged = self.bool(converged_name)
        if converged != (status == 0):
            self.fail(f"inconsistent: converged = {converged} but status = {status} ({STATUS[status]})")
        return status, converged


def _class(kind):
    return getattr(importlib.import_module(KINDS[kind]), kind)


def _orbit_common(f):
    status, converged = f.status()
    nit = f.int("nit", minimum=0)
    history = f.array("residual_history", "f", ndim=1)
    coupling = f.float("coupling")
    if not 0.0 < coupling <= 1.0:
        f.fail(f"the field 'coupling' must be in (0, 1], got {coupling}")
    return dict(converged=converged, success=converged, status=status, message=f.str("message"), nit=nit,
                residual=f.float("residual", finite=False), residual_history=history, coupling=coupling,
                continuation_path=f.array("continuation_path", "f", shape=(None, 3)),
                time=f.float("time", finite=False) if f.has("time") else float("nan"))


def _decode_periodic_solution(f):
    fl = f.flat()
    M, T = fl.M, fl.period
    N = f.int("N", minimum=1)
    geometry = f.str("geometry", ("planar", "axisymmetric"))
    nodes = f.array("nodes", "f", ndim=1, finite=True)
    n = nodes.size
    if n < 1 or np.any(np.diff(nodes) <= 0):
        f.fail("the field 'nodes' must be a non-empty, strictly increasing array")
    tc = f.array("tc", "f", shape=(n,), finite=True)
    if np.any(tc < 0) or np.any(tc >= T):
        f.fail(f"the field 'tc' must lie in [0, T) with T = 2 pi M = {T:.6g}")
    w_hat = f.array("w_hat", "fc", shape=(2 * N + 1, n), finite=True).astype(complex)
    zeta_hat = f.array("zeta_hat", "fc", shape=(2 * N + 1, n), finite=True).astype(complex)
    zeta_shift = f.array("zeta_shift", "f", shape=(n,), finite=True)
    tail = f.bool("tail_correction") if f.has("tail_correction") else True
    # (39)-(40): the height harmonics follow from the velocity harmonics and the contact times
    expect = height_from_velocity(w_hat, M)
    k = mode_numbers(N)
    nz = k != 0
    expect[N] = -np.real(np.sum(expect[nz] * np.exp(1j * np.outer(k[nz] / M, tc)), axis=0))
    if tail:
        J = T / fl.Gamma
        expect[N] -= J * float(sawtooth(0.0, M, "height") - evaluate(sawtooth_hat(N, M, [0.0], "height"),
                                                                       [0.0], M)[0, 0])
    scale = max(1.0, float(np.max(np.abs(expect))))
    gap = float(np.max(np.abs(zeta_hat - expect)))
    if not gap <= 1e-9 * scale:
        f.fail(f"inconsistent: zeta_hat does not follow from w_hat and tc by (39)-(40) "
               f"(max difference {gap:.3g})")
    common = _orbit_common(f)
    lattice = f.lattice() if f.has("lattice.present") else None
    if f.version == 0 and "lattice" in f.data and f.data["lattice"].size:
        geometry_l, boundary, grid = (str(v) for v in f.data["lattice"])
        lattice = Lattice(nodes, geometry_l, boundary, grid=grid)
    if lattice is not None and (lattice.geometry != geometry or lattice.n_nodes != n
                                or not np.array_equal(lattice.nodes, nodes)):
        f.fail("inconsistent: the stored lattice does not have the solution's nodes and geometry")
    sol = _class("PeriodicSolution")(
        geometry=geometry, nodes=nodes, tc=tc, w_hat=w_hat, zeta_hat=zeta_hat, zeta_shift=zeta_shift,
        Gamma=fl.Gamma, e=f.float("e"), t0=fl.t0, M=M, N=N, period=T, flat=fl,
        min_shift=f.bool("min_shift"), scheme=f.str("scheme"), tail_correction=tail,
        spacing=float(np.min(np.diff(nodes))) if n > 1 else float("inf"), lattice=lattice, **common)
    from tps_solver.solvers.tps.checks import physical_checks

    sol.checks = physical_checks(sol)
    return sol


def _decode_lattice_cycle(f):
    fl = f.flat()
    branch = f.str("branch", ("stable", "unstable"))
    if branch != fl.branch:
        f.fail(f"inconsistent: branch = {branch!r} but the flat layer launched at t0 = {fl.t0!r} is {fl.branch!r}")
    lattice = f.lattice()
    if lattice is None or lattice.boundary != "neumann":
        f.fail("a lattice cycle needs its lattice, with Neumann ends")
    n = lattice.n_nodes
    tc = f.array("tc", "f", shape=(n,), finite=True)
    if np.any(tc < 0) or np.any(tc >= fl.period):
        f.fail(f"the field 'tc' must lie in [0, T) with T = 2 pi M = {fl.period:.6g}")
    common = _orbit_common(f)
    module = importlib.import_module(KINDS["LatticeCycle"])
    problem = module.CycleProblem(lattice, fl, common["coupling"])
    cyc = module.LatticeCycle(
        tc=tc, nodes=np.array(lattice.nodes, dtype=float), geometry=lattice.geometry, lattice=lattice, flat=fl,
        Gamma=fl.Gamma, e=f.float("e"), M=fl.M, t0=fl.t0, period=fl.period, J=problem.J, **common)
    cyc.eigenvalues, cyc.modes, cyc.modes_inv = problem.lam, problem.V, problem.Vinv
    cyc.zeta_offset = np.zeros(n)
    cyc.zeta_offset = np.diag(cyc.height(tc)).copy()   # zeta(tc) = 0 at every node (40)
    return cyc


def _decode_stability(f):
    lattice = f.lattice()
    if lattice is None:
        f.fail("a stability result needs its lattice")
    periods = f.int("periods", minimum=2)
    defects = f.array("defects", "f", shape=(None, 2))
    if defects.shape[0] > periods:
        f.fail(f"inconsistent: {defects.shape[0]} per-period defects for periods = {periods}")
    history = f.array("growth_history", "f", ndim=1)
    if history.size > periods + 1:
        f.fail(f"inconsistent: {history.size} growth distances for periods = {periods}")
    window = f.array("growth_window", "iu", shape=(2,))
    multipliers = f.array("multipliers", "fc", ndim=1).astype(complex)
    if np.any(np.diff(np.abs(multipliers)) > 1e-12 * max(1.0, float(np.max(np.abs(multipliers), initial=0)))):
        f.fail("inconsistent: the multipliers are not sorted by decreasing modulus")
    diff = f.int("differentiable")
    if diff not in (-1, 0, 1):
        f.fail(f"the field 'differentiable' must be -1 (not tested), 0 or 1, got {diff}")
    growth = f.float("growth_factor", finite=False)
    stable, success = f.bool("stable"), f.bool("success")
    if stable and not (success and growth < 1.0):
        f.fail(f"inconsistent: stable = True with growth factor {growth!r} and success = {success}")
    cutoff = f.cutoff()
    limited = f.bool("cutoff_limited")
    if cutoff["kind"] == "lattice spacing" and not limited:
        f.fail("inconsistent: point impacts (cut-off = lattice spacing) but cutoff_limited = False")
    events = f.array("events_per_period", "iu", shape=(periods,))
    return _class("StabilityResult")(
        defects=defects, initial_defect=f.array("initial_defect", "f", shape=(2,)), growth_factor=growth,
        growth_history=history, growth_window=tuple(int(v) for v in window), multipliers=multipliers,
        multipliers_kind=f.str("multipliers_kind", ("full period map", "uniform mode", "none")),
        uniform_multipliers=f.array("uniform_multipliers", "fc", ndim=1).astype(complex),
        differentiable=None if diff == -1 else bool(diff), stable=stable, message=f.str("message"),
        events_per_period=events.astype(np.int64),
        sticking_nodes=f.array("sticking_nodes", "iu", ndim=1).astype(np.int64), cutoff=cutoff,
        cutoff_limited=limited, lattice=lattice, method=f.str("method"), period=f.float("period"),
        section_time=f.float("section_time"), periods=periods, success=success)


def _decode_simulation(f):
    lattice = f.lattice()
    if lattice is None:
        f.fail("a simulation result needs its lattice")
    n = lattice.n_nodes
    t_eval = f.array("t_eval", "f", ndim=1)
    k = t_eval.size
    from tps_solver.solvers.fda.events import EVENT_DTYPE

    ev_t = f.array("events.t", "f", ndim=1)
    m = ev_t.size
    events = np.empty(m, dtype=EVENT_DTYPE)
    events["t"] = ev_t
    events["node"] = f.array("events.node", "iu", shape=(m,))
    events["kind"] = f.array("events.kind", "U", shape=(m,))
    events["w_before"] = f.array("events.w_before", "f", shape=(m,))
    if m and (np.any(events["node"] < 0) or np.any(events["node"] >= n)):
        f.fail(f"the field 'events.node' must hold node indices in [0, {n})")
    if not set(np.unique(events["kind"])) <= {"impact", "stick", "liftoff"}:
        f.fail("the field 'events.kind' must hold 'impact', 'stick' or 'liftoff'")
    status = f.int("status")
    success = f.bool("success")
    if success != (status == 0):
        f.fail(f"inconsistent: success = {success} but status = {status}")
    return _class("SimulationResult")(
        t=f.float("t"), w=f.array("w", "f", shape=(n,)), zeta=f.array("zeta", "f", shape=(n,)),
        stuck=f.array("stuck", "b", shape=(n,)), events=events.view(np.recarray), n_events=m,
        success=success, status=status, message=f.str("message"), t_eval=t_eval,
        w_eval=f.array("w_eval", "f", shape=(k, n)), zeta_eval=f.array("zeta_eval", "f", shape=(k, n)),
        cutoff=f.cutoff(), method=f.str("method"), n_steps=f.int("n_steps", minimum=0), lattice=lattice,
        Gamma=f.float("Gamma"), e=f.float("e"), segments=None)


def _decode_secular_roots(f):
    kappa = f.float("kappa")
    if not kappa > 0:
        f.fail(f"the field 'kappa' must be > 0, got {kappa}")
    mode = f.str("mode", ("sinuous", "varicose"))
    gamma = f.array("gamma", "fc", ndim=1, finite=True).astype(complex)
    n = gamma.size
    lam = f.array("lam", "f", shape=(n,), finite=True)
    # lam = gamma^2 - 1 (computed without cancellation), sorted least damped first, all < 0
    if not np.all(np.abs(lam - ((gamma ** 2).real - 1.0)) <= 1e-12 * (np.abs(gamma) ** 2 + 1)):
        f.fail("inconsistent: lam is not gamma**2 - 1")
    if np.any(lam >= 0) or np.any(np.diff(lam) >= 0):
        f.fail("inconsistent: lam must be negative and strictly decreasing")
    trivial = f.array("trivial", "fc", ndim=1).astype(complex)
    return _class("SecularRoots")(
        kappa=kappa, mode=mode, gamma=gamma, lam=lam, trivial=trivial,
        trivial_is_eigenvalue=f.array("trivial_is_eigenvalue", "b", shape=(trivial.size,)),
        n_enclosed=f.int("n_enclosed", minimum=0), complete=f.bool("complete"),
        contour=tuple(float(v) for v in f.array("contour", "f", shape=(2,))),
        error_bound=f.array("error_bound", "f", shape=(n,)), polished=f.array("polished", "b", shape=(n,)))


_DECODERS = {"PeriodicSolution": _decode_periodic_solution, "LatticeCycle": _decode_lattice_cycle,
             "StabilityResult": _decode_stability, "SimulationResult": _decode_simulation,
             "SecularRoots": _decode_secular_roots}


def _read_archive(path):
    """All arrays of the archive at ``path``; ValueError saying what is wrong with the file."""
    if os.path.getsize(path) == 0:
        raise ValueError(f"{path} cannot be read: the file is empty")
    try:
        with open(path, "rb") as fh:                 # np.load(path) leaks the handle on a bad zip
            archive = np.load(fh, allow_pickle=False)
            if not isinstance(archive, np.lib.npyio.NpzFile):
                raise ValueError(f"{path} is a single .npy array, not a tps_solver result file (.npz)")
            with archive:
                return {k: archive[k] for k in archive.files}
    except zipfile.BadZipFile as exc:
        why = ("its data are damaged (CRC check failed)" if "CRC" in str(exc)
               else "it is not a complete .npz (zip) archive: truncated, damaged or another file type")
        raise ValueError(f"{path} cannot be read: {why} [{exc}]") from None
    except (zlib.error, EOFError) as exc:
        raise ValueError(f"{path} cannot be read: its compressed data are damaged or truncated "
                         f"[{type(exc).__name__}: {exc}]") from None
    except ValueError as exc:
        text = str(exc)
        if "pickle" in text and "Object arrays" in text:
            why = "it holds Python objects (pickled arrays), which are never loaded"
        elif "pickle" in text:
            why = "it is not an .npz archive (NumPy took it for pickled data)"
        else:
            why = text
        raise ValueError(f"{path} cannot be read: {why}") from None
    except (OSError, KeyError, IndexError, TypeError, NotImplementedError) as exc:
        if isinstance(exc, (FileNotFoundError, IsADirectoryError, PermissionError)):
            raise
        raise ValueError(f"{path} cannot be read: it is damaged or not an .npz archive "
                         f"[{type(exc).__name__}: {exc}]") from None


def load(path, kind=None):
    """Read a result written by :func:`save` (or by a result's ``save`` method).

    Parameters
    ----------
    path : str or os.PathLike
        The file, with or without its ``.npz`` ending.
    kind : str, optional
        The result type expected (a key of :data:`KINDS`); another one is an error.

    Returns
    -------
    PeriodicSolution, LatticeCycle, StabilityResult, SimulationResult or SecularRoots

    Raises
    ------
    FileNotFoundError
        If neither ``path`` nor ``path + ".npz"`` exists.
    ValueError
        If the file cannot be read (truncated, damaged, pickled, not an ``.npz``), is not
        a tps_solver file, has a newer format version (named), lacks or mistypes a field,
        or is inconsistent (e.g. ``e`` does not belong to the stored ``t0``).

    Examples
    --------
    >>> import os, tempfile
    >>> from tps_solver import secular_roots
    >>> roots = secular_roots(1.0, "sinuous", 3)
    >>> with tempfile.TemporaryDirectory() as d:
    ...     back = load(save(roots, os.path.join(d, "roots")), kind="SecularRoots")
    ...     print(type(back).__name__, np.array_equal(back.gamma, roots.gamma), back.mode)
    ...     with open(os.path.join(d, "junk.npz"), "w") as f:
    ...         _ = f.write("not an archive")
    ...     try:
    ...         load(os.path.join(d, "junk"))
    ...     except ValueError as exc:
    ...         print(str(exc).split(": ", 1)[1])
    SecularRoots True sinuous
    it is not an .npz archive (NumPy took it for pickled data)
    """
    if kind is not None and kind not in KINDS:
        raise ValueError(f"kind must be one of {', '.join(KINDS)} or None, got {kind!r}")
    name = os.fspath(path)
    candidates = [name] if name.endswith(".npz") else [name, name + ".npz"]
    found = next((c for c in candidates if os.path.isfile(c)), None)
    if found is None:
        raise FileNotFoundError(f"no such file: {' or '.join(candidates)}")
    data = _read_archive(found)
    if "format" not in data:
        if _V0_KEYS <= set(data):
            file_kind, version = "PeriodicSolution", 0
        else:
            keys = ", ".join(sorted(data)[:8]) or "none"
            raise ValueError(f"{found} is not a tps_solver result file (no 'format' entry; its arrays: {keys})")
    else:
        fmt = data["format"]
        if fmt.shape != () or fmt.dtype.kind != "U" or str(fmt) != FORMAT:
            raise ValueError(f"{found} is not a tps_solver result file (format {fmt!r}, expected {FORMAT!r})")
        try:
            version = int(data["format_version"])
            file_kind = str(data["kind"])
        except (KeyError, TypeError, ValueError):
            raise ValueError(f"{found}: the entries 'format_version' and 'kind' are missing or damaged") from None
        if version > FORMAT_VERSION or version < 0:
            raise ValueError(f"{found} has format version {version}; this tps_solver reads versions "
                             f"0 to {FORMAT_VERSION} (a newer tps_solver wrote it)")
        if file_kind not in KINDS:
            raise ValueError(f"{found} holds an unknown kind of result {file_kind!r} "
                             f"(known: {', '.join(KINDS)})")
    if kind is not None and file_kind != kind:
        raise ValueError(f"{found} holds a {file_kind}, not a {kind}")
    fields = {k: v for k, v in data.items() if k not in _META}
    result = _DECODERS[file_kind](_Fields(fields, found, file_kind, version))
    for key, value in fields.items():
        if key.startswith("extra."):
            result[key[len("extra."):]] = value.item() if value.shape == () else np.array(value)
    return result
