r"""Pseudo-arclength continuation of periodic orbits: :func:`continue_branch` and :class:`Branch`.

One verb, as in BifurcationKit.jl's ``continuation``: ``continue_branch(start,
parameter, bounds)`` follows the family of periodic orbits through ``start`` in
one parameter, passes around folds, and returns a :class:`Branch` with the
stability of every point and its special points.

The engine
----------
A branch is a curve :math:`y(s) = (x(s), p(s))` of solutions of
:math:`F(x, p) = 0`, :math:`x \in \mathbb R^n`.  Each step predicts along the unit
tangent, :math:`y^{(0)} = y_k + h\,\tau_k`, and corrects by Newton's method on
Keller's bordered system

.. math:: F(y) = 0, \qquad \tau_k\cdot(y - y^{(0)}) = 0 ,

which stays regular at a fold, where :math:`\partial F/\partial x` is singular
but :math:`[\partial_x F\ \ \partial_p F]` has full rank.  The new tangent solves
:math:`[\partial_x F\ \ \partial_p F]\,\tau = 0`, :math:`\tau_k\cdot\tau = 1`
(normalised), so its orientation is kept through the fold.  A step whose
corrector fails is halved; a step that converges fast is lengthened (up to
``max_step``).

Special points
--------------
Between consecutive points the test functions are watched for a sign change:

* ``"fold"`` -- the parameter component of the tangent, :math:`\tau_p`
  (the parameter turns back: a saddle-node, a Floquet multiplier through +1);
* ``"period_doubling"`` -- :math:`\det(I + \mathcal M)` of the monodromy
  :math:`\mathcal M` (a real multiplier through -1);
* ``"branch_point"`` -- :math:`\prod(1 - \mu)` over the multipliers (a real multiplier through
  +1) changes sign while :math:`\tau_p` does not: the parameter goes on, and another family of
  orbits meets the branch (a pitchfork or transcritical point, e.g. where a pinned front
  changes stability);

and each one found is located by bisection in arclength to ``tol_special``
(relative) before the branch goes on.  Every point carries its Floquet
multipliers and ``stable`` (all :math:`|\mu| < 1`).

Problems
--------
``start`` decides the problem that is continued:

* a :class:`~tps_solver.FlatLayer` (single-bounce orbit; parameter ``"Gamma"``
  or ``"e"``): :math:`F(t_0, p) = (2\Gamma/T)\cos t_0 - (1 - e)/(1 + e)`, the
  periodicity condition (19); multipliers of the exact impact map;
* a :class:`~tps_solver.solvers.tps.LatticeCycle` (exact single-contact lattice cycle;
  parameter ``"spacing"``, ``"Gamma"`` or ``"e"``): the contact condition (46)
  of :mod:`tps_solver.solvers.tps.cycle` in the contact times, on the lattice scaled to
  the node spacing; multipliers from the FDA period map by
  :func:`~tps_solver.find_periodic_orbit` (``multipliers=True``);
* a :class:`~tps_solver.solvers.shooting.periodic.ShootingOrbit` (any contact pattern; parameter
  ``"Gamma"``, ``"e"`` or, for the soft contact, ``"cutoff"``): the shooting
  equation :math:`P(x; p) = x` of the FDA period map
  (:class:`~tps_solver.solvers.shooting.period_map.PeriodMap`) at the orbit's section, with a
  dense Jacobian (exact for the soft contact, central differences for point impacts; small
  lattices) whose eigenvalues are the multipliers;
* a :class:`~tps_solver.solvers.tps.stick.StickSolution` (the impact-and-stick TPS; parameter
  ``"Gamma"`` or ``"e"``): its residual in the unknowns ``[t, tau, J, coef]`` of its contact
  pattern, the pattern held fixed (the branch ends where the problem refuses a point, e.g.
  a broken contact order); no multipliers (hand a point to the FDA for them);
* a pair ``(problem, x0)``: any problem of the protocol (:mod:`tps_solver.core.problem`) in
  any of its ``parameters``, from its solution ``x0``; multipliers from its ``monodromy``
  where it has one.

Every corrector is the one Newton (:func:`tps_solver.core.newton.newton`: plain steps, a
dense LU of the bordered matrix).
"""
import math
import time

import numpy as np

from tps_solver.core import archive
from tps_solver.core.checks import check_bool, check_choice, check_int, check_positive, check_real
from tps_solver.core.bunch import Bunch
from tps_solver.core.costs import check_cost
from tps_solver.core.newton import newton
from tps_solver.core.progress import progress_state
from tps_solver.core.orbit import STATUS
from tps_solver.core.problem import Inadmissible, Problem
from tps_solver.solvers.shooting.floquet import multipliers as floquet_multipliers
from tps_solver.solvers.shooting.period_map import PeriodMap, PeriodMapError
from scipy.sparse.linalg import LinearOperator

__all__ = ["continue_branch", "Branch", "SpecialPoint", "load_branch", "BRANCH_STATUS"]

#: The codes of the one table :data:`tps_solver.STATUS` that a branch returns: 0 reached a bound of
#: the parameter interval; 1 point limit; 2 the corrector failed at the smallest step; 4 the orbit
#: stopped existing (not admissible, or the problem refused the point); 5 interrupted.
BRANCH_STATUS = {k: STATUS[k] for k in (0, 1, 2, 4, 5)}



class SpecialPoint(tuple):
    """A special point of a branch: a typed record that reads as the pair ``(kind, value)``.

    Attributes
    ----------
    kind : str
        ``"fold"``, ``"period_doubling"`` or ``"branch_point"``.
    value : float
        The parameter value there.
    parameter : str
        The name of the continued parameter.
    index : int
        The branch point after it.
    state : ndarray of float
        The located solution (the problem's unknowns there).
    multipliers : ndarray of complex
        Its Floquet multipliers, by decreasing modulus.

    Examples
    --------
    >>> sp = SpecialPoint("fold", 2.5, "Gamma", 3, np.zeros(2), np.array([1.0 + 0j]))
    >>> kind, value = sp
    >>> kind, value, sp.parameter, sp == ("fold", 2.5), dict([sp])
    ('fold', 2.5, 'Gamma', True, {'fold': 2.5})
    """

    def __new__(cls, kind, value, parameter, index, state, multipliers):
        self = super().__new__(cls, (str(kind), float(value)))
        self.kind, self.value, self.parameter, self.index = str(kind), float(value), str(parameter), int(index)
        self.state = np.asarray(state, dtype=float)
        self.multipliers = np.asarray(multipliers, dtype=complex)
        return self

    def __getnewargs__(self):
        return (self.kind, self.value, self.parameter, self.index, self.state, self.multipliers)

    def __repr__(self):
        return f"SpecialPoint({self.kind!r}, {self.value!r}, parameter={self.parameter!r}, index={self.index})"

    @classmethod
    def from_detail(cls, d, parameter):
        """The record of one ``special_details`` entry."""
        return cls(d["kind"], d["value"], parameter, d["index"], d["state"], d["multipliers"])


archive.register("SpecialPoint", SpecialPoint,
                 encode=lambda sp: {"kind": sp.kind, "value": sp.value, "parameter": sp.parameter,
                                    "index": sp.index, "state": sp.state, "multipliers": sp.multipliers},
                 decode=lambda d: SpecialPoint(**d))


class Branch(Bunch):
    r"""A branch of periodic orbits from :func:`continue_branch`.

    Attributes
    ----------
    parameter : str
        Name of the continued parameter.
    parameter_values : ndarray of float, shape (k,)
    states : ndarray of float, shape (k, n)
        The unknowns of the problem at each point (``t0`` for a flat layer, the
        contact times for a lattice cycle).
    stable : ndarray of bool, shape (k,)
        All Floquet multipliers known and inside the unit circle (False where none was computed:
        read ``stability`` there).
    stability : ndarray of str, shape (k,)
        ``"stable"``, ``"unstable"`` or ``"unknown"`` (no multipliers computed at the point, e.g.
        ``multipliers=False`` or an impact-and-stick branch).
    multipliers : ndarray of complex, shape (k, m)
        Multipliers per point, by decreasing modulus (NaN where not computed).
    special_points : list of SpecialPoint
        Typed records (kind, value, parameter, index, state, multipliers) that read as the pair
        ``(kind, parameter value)``, kind ``"fold"``, ``"period_doubling"`` or ``"branch_point"``.
    special_details : list of dict
        Per special point: ``kind``, ``value``, ``index`` (the point after it),
        ``state``, ``multipliers``.
    status : int
        A code of :data:`BRANCH_STATUS`.
    message : str
    success : bool
        True when the branch ended at a bound or at the point limit.
    problem : str
        ``"flat"`` or ``"lattice_cycle"``.
    context : dict
        The fixed parameters (Gamma, e, M, ...).
    time : float

    Examples
    --------
    The flat layer continued in Gamma from 2.5: it loses stability by a period
    doubling at the upper end of :meth:`FlatLayer.stability_window`, and every state is the
    launch phase ``t0`` of that Gamma:

    >>> from tps_solver import FlatLayer
    >>> br = continue_branch(FlatLayer(2.5, 2, e=0.45), "Gamma", (2.3, 2.7))
    >>> br.status, br.problem, [kind for kind, _ in br.special_points], br.stable[[0, -1]].tolist()
    (0, 'flat', ['period_doubling'], [True, False])
    >>> bool(abs(br.special_points[0][1] - FlatLayer.stability_window(0.45, 2)[1]) < 1e-8)
    True
    >>> bool(abs(br.states[-1, 0] - FlatLayer(br.parameter_values[-1], 2, e=0.45).t0) < 1e-10)
    True
    """

    def save(self, path):
        """Write the branch to ``path`` (``.npz`` appended if missing; see :mod:`tps_solver.core.archive`); returns the path.

        Every field is stored, ``special_points`` and ``special_details`` with whatever they
        hold (records, nested solutions), by the archive's generic encoder.
        """
        return archive.save(self, path)

    def plot(self, path=None, ax=None):
        """Draw max|mu| against the parameter (points marked stable or unstable) with the special points.

        Parameters
        ----------
        path : str, optional
            Write the figure there (PNG).
        ax : matplotlib Axes, optional

        Returns
        -------
        matplotlib.figure.Figure
        """
        import matplotlib.pyplot as plt

        if ax is None:
            fig, ax = plt.subplots(figsize=(6.5, 4))
        else:
            fig = ax.figure
        p = self.parameter_values
        rho = np.nanmax(np.abs(self.multipliers), axis=1) if self.multipliers.size else np.full(p.size, np.nan)
        ax.plot(p, rho, "-", color="0.7", lw=0.8)
        stability = np.asarray(self.get("stability", np.where(self.stable, "stable", "unstable")))
        for mask, style, label in ((stability == "stable", "o", "stable"), (stability == "unstable", "x", "unstable")):
            ax.plot(p[mask], rho[mask], style, ms=3, color="C0" if label == "stable" else "C1", label=label)
        unknown = stability == "unknown"
        if unknown.any():            # no multiplier there: a rug along the parameter axis, not a |mu|
            ax.plot(p[unknown], np.full(int(unknown.sum()), 0.03), "|", ms=8, color="0.4",
                    transform=ax.get_xaxis_transform(), label="stability unknown (no multipliers)")
        for kind, value in self.special_points:
            ax.axvline(value, color="C3" if kind == "fold" else "C2", lw=0.8, ls=":")
            ax.annotate(kind.replace("_", " "), (value, 1.0), rotation=90, fontsize=7, va="bottom")
        ax.axhline(1.0, color="k", lw=0.5)
        ax.set_xlabel(_LABELS.get(self.parameter, self.parameter))
        ax.set_ylabel(r"largest Floquet multiplier $|\mu|$")
        ctx = ", ".join(f"{k} = {v:g}" for k, v in self.context.items() if k != self.parameter)
        ax.set_title(f"{self.problem} branch in {self.parameter} ({ctx})", fontsize=9)
        ax.legend(fontsize=8)
        fig.tight_layout()
        if path is not None:
            fig.savefig(path, dpi=130)
        return fig


_LABELS = {"Gamma": r"$\Gamma = A\omega^2/g$", "e": "restitution $e$",
           "spacing": "node spacing (viscous lengths)"}

#: Lower bound of the time of one continuation point (a corrector solve and its multipliers):
#: measured 1.5e-3 s per point on the flat layer, the smallest problem, divided by ten.
_POINT_SECONDS = 1.5e-4


def load_branch(path):
    """Read a :class:`Branch` written by :meth:`Branch.save`.

    Raises
    ------
    ValueError
        If the file is not a branch file of a known format version.

    Examples
    --------
    >>> import os, tempfile
    >>> from tps_solver import FlatLayer
    >>> br = continue_branch(FlatLayer(2.5, 2, e=0.45), "Gamma", (2.3, 2.7))
    >>> with tempfile.TemporaryDirectory() as d:
    ...     back = load_branch(br.save(os.path.join(d, "branch")))
    ...     print(np.array_equal(back.states, br.states), back.special_points == br.special_points, back.context)
    True True {'Gamma': 2.5, 'e': 0.45, 'M': 2.0}
    """
    from tps_solver.core.archive import load

    try:
        return load(path, kind="Branch")
    except ValueError as exc:
        raise ValueError(f"path {str(path)!r} is not a tps_solver branch file (not readable as one): {exc}") from None



class _Refused(Inadmissible):
    """The problem cannot evaluate this point (the orbit does not exist there)."""


# ------------------------------------------------------------------ problems
class _FlatProblem:
    """Periodicity (19) of the single-bounce flat layer in its launch phase t0."""

    name = "flat"
    parameters = ("Gamma", "e")

    def __init__(self, flat, parameter):
        self.M = flat.M
        self.T = flat.period
        self.fixed = {"Gamma": flat.Gamma, "e": flat.e, "M": flat.M}
        self.parameter = parameter
        self.x0 = np.array([flat.t0])
        self.p0 = self.fixed[parameter]

    def _Ge(self, p):
        G = p if self.parameter == "Gamma" else self.fixed["Gamma"]
        e = p if self.parameter == "e" else self.fixed["e"]
        return G, e

    def residual(self, x, p):
        G, e = self._Ge(p)
        return np.array([2.0 * G / self.T * math.cos(x[0]) - (1.0 - e) / (1.0 + e)])

    def jacobian(self, x, p):
        G, e = self._Ge(p)
        Jx = np.array([[-2.0 * G / self.T * math.sin(x[0])]])
        if self.parameter == "Gamma":
            Jp = np.array([2.0 / self.T * math.cos(x[0])])
        else:
            Jp = np.array([2.0 / (1.0 + e) ** 2])
        return Jx, Jp

    def monodromy(self, x, p):
        from tps_solver.model.flat import FlatLayer

        G, e = self._Ge(p)
        if not 0.0 <= e < 1.0 or G <= 0.0:
            raise _Refused(f"parameter out of range: Gamma = {G:.6g}, e = {e:.6g}")
        try:
            fl = FlatLayer(G, self.M, t0=float(x[0]))
        except ValueError as exc:
            raise _Refused(str(exc)) from None
        return fl.impact_map_jacobian()


class _LawFlatProblem:
    """The single bounce with a speed-dependent law (v (1 + e(v)) = T/Gamma, v = T/2Gamma + cos t0)
    in Gamma or one of the law's parameters."""

    name = "flat"

    def __init__(self, flat, parameter):
        self.M, self.T = flat.M, flat.period
        self.law = flat.restitution
        self.parameters = ("Gamma",) + tuple(self.law.parameters)
        self.fixed = {"Gamma": flat.Gamma, "M": flat.M, **self.law.parameters}
        self.parameter = parameter
        self.x0 = np.array([flat.t0])
        self.p0 = self.fixed[parameter]
        self.with_multipliers = True

    def _G_law(self, p):
        if self.parameter == "Gamma":
            if not p > 0.0:
                raise _Refused(f"parameter out of range: Gamma = {p:.6g}")
            return p, self.law
        try:
            return self.fixed["Gamma"], self.law.at(**{self.parameter: p})
        except ValueError as exc:
            raise _Refused(str(exc)) from None

    def residual(self, x, p):
        G, law = self._G_law(p)
        v = self.T / (2.0 * G) + math.cos(x[0])
        if not v > 0.0:
            raise _Refused(f"non-positive impact speed {v:.6g}")
        return np.array([v * (1.0 + law(v)) - self.T / G])

    def jacobian(self, x, p):
        G, law = self._G_law(p)
        v = self.T / (2.0 * G) + math.cos(x[0])
        Jx = np.array([[-(1.0 + law.rebound_derivative(v)) * math.sin(x[0])]])
        return Jx, _dF_dp(self, x, p)

    def monodromy(self, x, p):
        from tps_solver.model.flat import FlatLayer

        G, law = self._G_law(p)
        try:
            fl = FlatLayer(G, self.M, e=law, t0=float(x[0]))
        except ValueError as exc:
            raise _Refused(str(exc)) from None
        return fl.impact_map_jacobian()


def _dF_dp(problem, x, p):
    """dF/dp by a central difference of relative step 1e-6; one-sided (second order) at the end of the
    parameter's range (e = 0: the completely inelastic layer)."""
    hp = 1e-6 * max(1.0, abs(p))
    try:
        return (problem.residual(x, p + hp) - problem.residual(x, p - hp)) / (2.0 * hp)
    except _Refused as exc:
        if "out of range" not in str(exc):
            raise
    for h in (hp, -hp):
        try:
            return (-3.0 * problem.residual(x, p) + 4.0 * problem.residual(x, p + h)
                    - problem.residual(x, p + 2.0 * h)) / (2.0 * h)
        except _Refused as exc:
            if "out of range" not in str(exc):
                raise
    raise _Refused(f"no parameter step around {p:.6g} stays in range")


class _CycleProblem:
    """Exact single-contact lattice cycles (:mod:`tps_solver.solvers.tps.cycle`) in their contact times."""

    name = "lattice_cycle"
    parameters = ("spacing", "Gamma", "e")

    def __init__(self, cycle, parameter, multipliers):
        self.lattice = cycle.lattice
        self.h0 = float(self.lattice.spacing)
        self.M = cycle.M
        self.T = cycle.period
        self.fixed = {"Gamma": cycle.Gamma, "e": cycle.e, "M": cycle.M, "spacing": self.h0}
        self.parameter = parameter
        self.x0 = np.asarray(cycle.tc, dtype=float).copy()
        self.p0 = self.fixed[parameter]
        self.with_multipliers = multipliers
        self._cache = {}

    def _setup(self, p):
        from tps_solver.model.flat import FlatLayer
        from tps_solver.operators.lattice import Lattice
        from tps_solver.solvers.tps.cycle import CycleProblem

        key = float(p)
        if key in self._cache:
            return self._cache[key]
        G = p if self.parameter == "Gamma" else self.fixed["Gamma"]
        e = p if self.parameter == "e" else self.fixed["e"]
        h = p if self.parameter == "spacing" else self.h0
        if h <= 0.0 or G <= 0.0 or not 0.0 <= e < 1.0:
            raise _Refused(f"parameter out of range: spacing = {h:.6g}, Gamma = {G:.6g}, e = {e:.6g}")
        lat = self.lattice
        scaled = Lattice(np.asarray(lat.nodes) * (h / self.h0), lat.geometry, lat.boundary, grid=lat.grid)
        try:
            flat = FlatLayer(G, self.M, e=e, pattern="bounce")
        except ValueError as exc:
            raise _Refused(str(exc)) from None
        prob = CycleProblem(scaled, flat, 1.0)
        if len(self._cache) > 8:
            self._cache.clear()
        self._cache[key] = (prob, scaled, flat)
        return prob, scaled, flat

    def residual(self, x, p):
        prob, _, _ = self._setup(p)
        return prob.residual(x)[0]

    def jacobian(self, x, p):
        prob, _, _ = self._setup(p)
        F, H, _ = prob.residual(x)
        op, _ = prob.jacobian_operator(x, H, None)
        return op.matmat(np.eye(x.size)), _dF_dp(self, x, p)

    def monodromy(self, x, p):
        if not self.with_multipliers:
            return None
        from tps_solver.solvers.shooting.periodic import find_periodic_orbit
        from tps_solver.solvers.tps.cycle import solve_lattice_cycle

        _, lat, flat = self._setup(p)
        cyc = solve_lattice_cycle(lat, Gamma=flat.Gamma, M=flat.M, e=flat.e, t0=None,
                                  tc_initial=np.mod(x, self.T), continuation=False)
        if cyc.status == 5:
            raise KeyboardInterrupt
        if not cyc.converged:
            raise _Refused(f"the lattice cycle did not converge at {self.parameter} = {p:.6g}: {cyc.message}")
        orb = find_periodic_orbit(lat, Gamma=flat.Gamma, M=flat.M, e=flat.e, guess=cyc)
        if orb.status == 5:
            raise KeyboardInterrupt
        mu = np.asarray(orb.multipliers, dtype=complex)
        if mu.size == 0:
            raise _Refused(f"multipliers undefined at {self.parameter} = {p:.6g}: {orb.message}")
        return mu


class _ProtocolProblem:
    """Any problem of the protocol (:mod:`tps_solver.core.problem`) continued in one of its
    parameters: ``F(x, p)`` is its residual at ``problem.at(parameter=p)``; ``dF/dx`` its
    Jacobian made dense (or ``monodromy_matrix - I`` where the problem has one, e.g. the
    :class:`~tps_solver.solvers.shooting.period_map.PeriodMap`: exact for the soft contact, central
    differences for point impacts); ``dF/dp`` a central difference; the multipliers those of its
    monodromy (none if it has no monodromy)."""

    _RANGES = {"Gamma": (0.0, math.inf, "> 0"), "e": (0.0, 1.0, "in [0, 1)"), "cutoff": (0.0, math.inf, "> 0"),
               "spacing": (0.0, math.inf, "> 0")}

    def __init__(self, problem, x0, parameter, multipliers, name="problem", max_unknowns=64, dense=True):
        self.base = problem
        self.name = name
        self.parameters = tuple(problem.parameters)
        self.parameter = check_choice(parameter, "parameter", self.parameters)
        self.x0 = np.asarray(x0, dtype=float).copy()
        if dense and self.x0.size > max_unknowns:
            raise ValueError(f"start has {self.x0.size} unknowns; continuation uses a dense Jacobian and "
                             f"takes at most {max_unknowns}")
        self.fixed = {k: float(v) for k, v in problem.parameters.items()}
        self.p0 = self.fixed[self.parameter]
        self.with_multipliers = multipliers
        self._problems = {}
        self._last = self._mono = self._jac = None       # one-point caches of residual, monodromy, Jacobian

    def _at(self, p):
        key = float(p)
        if key not in self._problems:
            lo, hi, text = self._RANGES.get(self.parameter, (-math.inf, math.inf, ""))
            if not (lo < key < hi or (self.parameter == "e" and key == 0.0)):
                raise _Refused(f"parameter out of range: {self.parameter} = {key:.6g} (must be {text})")
            if len(self._problems) > 8:
                self._problems.clear()
            self._problems[key] = self.base.at(**{self.parameter: key}) if key != self.p0 else self.base
        return self._problems[key]

    def _evaluate(self, x, p):
        key = (x.tobytes(), float(p))
        if self._last is not None and self._last[0] == key:
            return self._last[1]
        prob = self._at(p)
        try:
            F, *data = prob.residual(x)
        except (Inadmissible, PeriodMapError) as exc:
            raise _Refused(f"at {self.parameter} = {p:.6g}: {exc}") from None
        out = (prob, np.asarray(F, dtype=float), tuple(data))
        self._last = (key, out)
        return out

    def residual(self, x, p):
        return self._evaluate(x, p)[1]

    def _monodromy_matrix(self, x, p):
        key = (x.tobytes(), float(p))
        if self._mono is not None and self._mono[0] == key:      # the tangent and the multipliers
            return self._mono[1]                                  # of one point share it
        prob, F, data = self._evaluate(x, p)
        try:
            mono = prob.monodromy_matrix(x) if hasattr(prob, "monodromy_matrix") else prob.monodromy(x, data)
        except NotImplementedError:
            mono = None
        except PeriodMapError as exc:
            raise _Refused(f"at {self.parameter} = {p:.6g}: {exc}") from None
        if mono is not None:
            mono = mono.matmat(np.eye(x.size)) if isinstance(mono, LinearOperator) else np.asarray(mono, float)
        self._mono = (key, mono)
        return mono

    def jacobian(self, x, p):
        key = (x.tobytes(), float(p))
        if self._jac is not None and self._jac[0] == key:        # corrector, tangent, fold test
            return self._jac[1]
        prob, F, data = self._evaluate(x, p)
        if hasattr(prob, "monodromy_matrix"):
            Jx = self._monodromy_matrix(x, p) - np.eye(x.size)
        else:
            J = prob.jacobian(x, F, data)
            Jx = J.matmat(np.eye(x.size)) if isinstance(J, LinearOperator) else np.asarray(J, float)
        self._jac = (key, (Jx, _dF_dp(self, x, p)))
        return self._jac[1]

    def monodromy(self, x, p):
        if not self.with_multipliers:
            return None
        return self._monodromy_matrix(x, p)


def _make_problem(start, parameter, multipliers):
    from tps_solver.model.flat import FlatLayer
    from tps_solver.solvers.shooting.periodic import ShootingOrbit
    from tps_solver.solvers.tps.cycle import LatticeCycle
    from tps_solver.solvers.tps.stick import StickSolution

    if isinstance(start, tuple) and len(start) == 2 and isinstance(start[0], Problem):
        problem, x0 = start
        return _ProtocolProblem(problem, x0, parameter, multipliers, name=type(problem).__name__)
    if isinstance(start, Problem):
        raise ValueError("start must be a (problem, x0) pair for a problem of the protocol: the problem "
                         "and a solution of it")
    if isinstance(start, ShootingOrbit):
        if not start.converged:
            raise ValueError("start must be a converged ShootingOrbit (got converged=False)")
        stuck = np.asarray(start.get("stuck0", np.zeros(start.lattice.n_nodes, bool)), dtype=bool)
        if np.any(stuck):
            raise ValueError("start must have no node stuck at its section t_start for continuation "
                             f"(got {int(stuck.sum())}); shoot again with another t_start")
        if parameter == "cutoff" and start.cutoff is None:
            raise ValueError("parameter 'cutoff' needs a soft-contact start orbit (cutoff is None)")
        extra = {} if start.cutoff is None else {"cutoff": start.cutoff}
        pm = PeriodMap(start.lattice, start.Gamma, start.e, start.period, start.t_start, method=start.method,
                       require_free=True, **extra)
        parameter = check_choice(parameter, "parameter", tuple(pm.parameters))
        out = _ProtocolProblem(pm, np.concatenate([start.w0, start.zeta0]), parameter, multipliers,
                               name="shooting")
        out.fixed["M"] = float(start.M)
        return out
    if isinstance(start, StickSolution):
        if not start.converged:
            raise ValueError("start must be a converged StickSolution (got converged=False)")
        parameter = check_choice(parameter, "parameter", ("Gamma", "e"))
        out = _ProtocolProblem(start.problem, start.unknowns, parameter, False, name="stick", dense=False)
        out.fixed["M"] = float(start.M)
        return out
    if isinstance(start, FlatLayer):
        if getattr(start, "pattern", "bounce") not in ("bounce", None):
            raise ValueError(f"start must be a single-bounce FlatLayer for continuation, got pattern "
                             f"{start.pattern!r}")
        problem = _FlatProblem
    elif isinstance(start, LatticeCycle):
        if not start.converged:
            raise ValueError("start must be a converged LatticeCycle (got converged=False)")
        problem = _CycleProblem
    else:
        raise ValueError(f"start must be a FlatLayer, a LatticeCycle, a ShootingOrbit, a StickSolution or "
                         f"a (problem, x0) pair, got {type(start).__name__}")
    if problem is _FlatProblem and not start.restitution.constant:
        law = start.restitution
        parameter = check_choice(parameter, "parameter", ("Gamma",) + tuple(law.parameters))
        return _LawFlatProblem(start, parameter)
    parameter = check_choice(parameter, "parameter", problem.parameters)
    if problem is _FlatProblem:
        return problem(start, parameter)
    return problem(start, parameter, multipliers)


# -------------------------------------------------------------------- engine
def _tangent(Jx, Jp, previous):
    """Unit null vector of [Jx Jp], oriented along ``previous`` (or with dp > 0 if None)."""
    A = np.hstack([Jx, Jp[:, None]])
    _, _, vt = np.linalg.svd(A)
    t = vt[-1]
    ref = previous if previous is not None else np.eye(t.size)[-1]
    if np.dot(t, ref) < 0.0:
        t = -t
    return t / np.linalg.norm(t)


class _Bordered(Problem):
    """Keller's bordered system [F(x, p); tangent.(y - y_pred)] = 0 in y = (x, p)."""

    def __init__(self, problem, y_pred, tangent):
        self.problem, self.y_pred, self.tangent = problem, y_pred, tangent
        self.refused = None

    def residual(self, y):
        n = y.size - 1
        try:
            F = self.problem.residual(y[:n], y[n])
        except _Refused as exc:
            self.refused = str(exc)
            raise
        return np.concatenate([F, [float(np.dot(self.tangent, y - self.y_pred))]]),

    def jacobian(self, y, F, data):
        n = y.size - 1
        Jx, Jp = self.problem.jacobian(y[:n], y[n])
        return np.vstack([np.hstack([Jx, Jp[:, None]]), self.tangent[None, :]])


def _correct(problem, y_pred, tangent, tol, max_iter):
    """The one Newton (plain steps, dense LU) on the bordered system; returns (y, converged,
    iterations, why the problem refused a point or None)."""
    bordered = _Bordered(problem, y_pred, tangent)
    try:
        out = newton(bordered, y_pred, tol=tol, max_iter=max_iter, linear="dense", line_search="none",
                     xtol=1e-3 * tol)
    except _Refused:
        return y_pred.copy(), False, 0, bordered.refused
    if out.status == 5:
        raise KeyboardInterrupt
    return out.x, out.converged, out.nit, None if out.converged else bordered.refused


def _branch_test(mu):
    """prod(1 - mu) (real for a real map; nan without multipliers): its sign flips where a real
    multiplier passes +1."""
    if mu.size == 0:
        return np.nan
    return float(np.real(np.prod(1.0 - mu)))


def _multipliers(problem, y):
    n = y.size - 1
    J = problem.monodromy(y[:n], y[n])
    if J is None:
        return np.array([], dtype=complex), np.nan
    J = np.asarray(J)
    if J.ndim == 2:
        mu = floquet_multipliers(J)
        pd = float(np.real(np.linalg.det(np.eye(J.shape[0]) + J)))
    else:
        mu = J
        # det(I + M) from the multipliers themselves (real for a real map)
        pd = float(np.real(np.prod(1.0 + mu)))
    order = np.argsort(-np.abs(mu), kind="stable")
    return mu[order], pd


def continue_branch(start, parameter="Gamma", bounds=None, *, step=None, max_step=None, min_step=None,
                    max_points=400, tol=1e-11, tol_special=1e-10, direction=1, bothsides=False,
                    multipliers=True, max_corrector=10, callback=None):
    r"""Follow the branch of periodic orbits through ``start`` in one parameter (module docstring).

    Parameters
    ----------
    start : FlatLayer, LatticeCycle, ShootingOrbit, StickSolution or (Problem, ndarray)
        A point on the branch (module docstring).
    parameter : str
        ``"Gamma"`` or ``"e"`` (flat layer, impact-and-stick solution; a flat layer or shooting
        orbit with a speed-dependent restitution law takes ``"Gamma"`` or one of the law's
        parameters, e.g. ``"b"``); ``"spacing"``,
        ``"Gamma"`` or ``"e"`` (lattice cycle); ``"Gamma"``, ``"e"`` or ``"cutoff"`` (shooting
        orbit); a name of ``problem.parameters`` for a ``(problem, x0)`` pair.
    bounds : (float, float)
        The parameter interval; the branch stops where it leaves it.  It must contain
        the start's parameter value.
    step : float, optional
        Initial arclength step; default 1 % of the interval.
    max_step, min_step : float, optional
        Largest step (default 5 % of the interval) and the step below which a failing
        corrector ends the branch (default 1e-6 of the interval).
    max_points : int
        Bound on the number of points.
    tol : float
        Corrector tolerance on max|F|.
    tol_special : float
        Relative accuracy in arclength of the located special points.
    direction : {1, -1}
        Initial direction of the parameter.
    bothsides : bool
        Follow the branch in both directions from ``start`` and join the two halves
        (ordered along the branch, the start in between).
    multipliers : bool
        Compute Floquet multipliers (and period doublings) at every point.  For a
        lattice cycle each costs a few FDA periods per unknown.
    max_corrector : int
        Newton iterations per corrector.
    callback : callable, optional
        ``callback(state)`` after each accepted point (a
        :class:`~tps_solver.core.progress.ProgressState`: stage ``"continuation"``,
        ``iteration`` k, ``parameter``, ``parameter_value``, ``stable``: bool, None where no
        multiplier was computed).  A ``KeyboardInterrupt`` -- also while the start is corrected --
        returns ``status = 5`` with the points so far (none if the start was not done).

    Returns
    -------
    Branch

    Examples
    --------
    >>> from tps_solver import FlatLayer
    >>> br = continue_branch(FlatLayer(2.5, 2, e=0.45), "Gamma", (2.3, 3.2), bothsides=True)
    >>> [kind for kind, _ in br.special_points]
    ['fold', 'period_doubling']
    >>> lo, hi = FlatLayer.stability_window(0.45, 2)
    >>> bool(abs(br.special_points[0][1] - lo) < 1e-8 and abs(br.special_points[1][1] - hi) < 1e-8)
    True
    """
    bothsides = check_bool(bothsides, "bothsides")
    multipliers = check_bool(multipliers, "multipliers")
    if bothsides:
        kw = dict(step=step, max_step=max_step, min_step=min_step, max_points=max_points, tol=tol,
                  tol_special=tol_special, multipliers=multipliers, max_corrector=max_corrector,
                  callback=callback)
        down = continue_branch(start, parameter, bounds, direction=-1, **kw)
        up = continue_branch(start, parameter, bounds, direction=1, **kw)
        return _join(down, up)
    problem = _make_problem(start, parameter, multipliers)
    if bounds is None:
        raise ValueError("bounds must be given: a (low, high) interval of the parameter")
    try:
        if len(bounds) != 2:
            raise ValueError(f"bounds must be a pair (low, high) of finite numbers, got {len(bounds)} values "
                             f"{tuple(bounds)!r}")
        lo, hi = (check_real(b, "bounds") for b in bounds)
    except TypeError:
        raise ValueError(f"bounds must be a pair (low, high) of finite numbers, got {bounds!r}") from None
    if not lo < hi:
        raise ValueError(f"bounds must satisfy low < high, got {bounds!r}")
    p0 = problem.p0
    if not lo <= p0 <= hi:
        raise ValueError(f"bounds {bounds!r} must contain the start's {parameter} = {p0:.12g}")
    width = hi - lo
    step = 0.01 * width if step is None else check_positive(step, "step")
    max_step = 0.05 * width if max_step is None else check_positive(max_step, "max_step")
    min_step = 1e-6 * width if min_step is None else check_positive(min_step, "min_step")
    if min_step > step or step > max_step:
        raise ValueError(f"steps must satisfy min_step <= step <= max_step, got {min_step}, {step}, {max_step}")
    max_points = check_int(max_points, "max_points", minimum=2)
    check_cost("continue_branch", "max_points", max_points, 3 * 8.0 * (np.size(problem.x0) + 1) * max_points,
               _POINT_SECONDS * max_points,
               hint=f"the point limit bounds the run: each point is a corrector solve and its multipliers"
                    f"{'; with max_step = %g the interval needs about %.3g points' % (max_step, width / max_step)}")
    tol = check_positive(tol, "tol")
    tol_special = check_positive(tol_special, "tol_special")
    if direction not in (1, -1):
        raise ValueError(f"direction must be +1 or -1, got {direction!r}")
    if callback is not None and not callable(callback):
        raise ValueError("callback must be callable or None")
    clock = time.perf_counter()

    y = np.concatenate([problem.x0, [p0]])
    points, tangents, mus, pds, bps = [], [], [], [], []
    specials, details = [], []
    status, message = 1, f"point limit ({max_points}) reached"
    h = step
    try:      # the interrupt guard covers the start's correction and multipliers too
        y, ok, _, _ = _correct(problem, y, np.eye(y.size)[-1], tol, max_corrector)
        if not ok:
            raise ValueError(f"start is not a solution of the continued problem to tol = {tol:g}")
        Jx, Jp = problem.jacobian(y[:-1], y[-1])
        tau = _tangent(Jx, Jp, direction * np.eye(y.size)[-1])
        try:
            mu, pd = _multipliers(problem, y)
        except _Refused as exc:
            raise ValueError(f"start: {exc}") from None
        points.append(y)
        tangents.append(tau)
        mus.append(mu)
        pds.append(pd)
        bps.append(_branch_test(mu))
        while len(points) < max_points:
            y_prev, tau_prev = points[-1], tangents[-1]
            y_new, ok, nit, refused = _correct(problem, y_prev + h * tau_prev, tau_prev, tol, max_corrector)
            if ok:
                try:
                    Jx, Jp = problem.jacobian(y_new[:-1], y_new[-1])
                    tau_new = _tangent(Jx, Jp, tau_prev)
                    mu, pd = _multipliers(problem, y_new)
                except _Refused as exc:
                    ok, refused = False, str(exc)
            if not ok:
                h *= 0.5
                if h < min_step:
                    if refused is not None:
                        status, message = 4, (f"the orbit stops existing near {parameter} = {y_prev[-1]:.10g}: "
                                              f"{refused}")
                    else:
                        status, message = 2, (f"the corrector failed for every step down to {min_step:.2g} "
                                              f"at {parameter} = {y_prev[-1]:.10g}; try a smaller tol or "
                                              "max_step")
                    break
                continue
            # special points between y_prev and y_new
            bp = _branch_test(mu)
            folded = tau_prev[-1] * tau_new[-1] < 0.0
            for kind, f_prev, f_new in (("fold", tau_prev[-1], tau_new[-1]),
                                        ("period_doubling", pds[-1], pd),
                                        ("branch_point", bps[-1] if not folded else np.nan, bp)):
                if np.isfinite(f_prev) and np.isfinite(f_new) and f_prev * f_new < 0.0:
                    sp = _locate(problem, kind, y_prev, tau_prev, h, f_prev, tol, tol_special, max_corrector)
                    if sp is not None:
                        sp["index"] = len(points)
                        specials.append(SpecialPoint.from_detail(sp, parameter))
                        details.append(sp)
            points.append(y_new)
            tangents.append(tau_new)
            mus.append(mu)
            pds.append(pd)
            bps.append(bp)
            if callback is not None:
                callback(progress_state("continuation", len(points) - 1, parameter=parameter,
                                        parameter_value=float(y_new[-1]),
                                        stable=(bool(np.max(np.abs(mu)) < 1.0) if mu.size else None)))
            if not lo <= y_new[-1] <= hi:
                status, message = 0, f"left the interval [{lo:g}, {hi:g}] at {parameter} = {y_new[-1]:.10g}"
                break
            h = min(max_step, h * (1.5 if nit <= 3 else 1.0 if nit <= 6 else 0.5))
    except KeyboardInterrupt:
        status, message = 5, ("interrupted (KeyboardInterrupt); the points so far are returned" if points else
                              "interrupted (KeyboardInterrupt) while correcting the start; no point yet")
    P = np.array(points) if points else np.empty((0, y.size))
    m = max((mu.size for mu in mus), default=0)
    mult = np.full((len(mus), m), np.nan, dtype=complex)
    for i, mu in enumerate(mus):
        mult[i, :mu.size] = mu
    stable, stability, note = _verdicts(mult)
    names = ", ".join(f"{k} at {v:.10g}" for k, v in specials) or "none"
    return Branch(parameter=parameter, parameter_values=P[:, -1], states=P[:, :-1], stable=stable,
                  stability=stability, multipliers=mult, special_points=specials, special_details=details,
                  status=status, message=f"{message}; {len(points)} points; special points: {names}{note}",
                  success=status in (0, 1), problem=problem.name,
                  context={k: float(v) for k, v in problem.fixed.items()}, time=time.perf_counter() - clock)


def _verdicts(mult):
    """Per point: ``stable`` (bool), ``stability`` ("stable", "unstable" or "unknown") and a note.

    A point without multipliers (none computed) is "unknown", not unstable; ``stable`` is
    True only where every multiplier is known and inside the unit circle.
    """
    known = np.all(np.isfinite(mult), axis=1) & (mult.shape[1] > 0)
    with np.errstate(invalid="ignore"):
        rho = np.max(np.abs(mult), axis=1) if mult.shape[1] else np.full(mult.shape[0], np.nan)
    stable = known & (rho < 1.0)
    stability = np.where(~known, "unknown", np.where(stable, "stable", "unstable"))
    n_unknown = int(np.count_nonzero(~known))
    note = (f"; stability unknown at {n_unknown} of {known.size} points (no multipliers computed there; "
            "Branch.stable is False there only because nothing was decided)" if n_unknown else "")
    return stable, stability, note


def _join(down, up):
    """One branch from the two halves of a two-sided continuation (``down`` reversed, then ``up``)."""
    m = max(down.multipliers.shape[1], up.multipliers.shape[1])

    def pad(a):
        out = np.full((a.shape[0], m), np.nan, dtype=complex)
        out[:, :a.shape[1]] = a
        return out

    k = down.parameter_values.size
    details = ([dict(d, index=k - d["index"]) for d in reversed(down.special_details)]
               + [dict(d, index=d["index"] + k - 1) for d in up.special_details])
    status = down.status if down.status not in (0, 1) else up.status
    return Branch(
        parameter=up.parameter,
        parameter_values=np.concatenate([down.parameter_values[::-1], up.parameter_values[1:]]),
        states=np.concatenate([down.states[::-1], up.states[1:]]),
        stable=np.concatenate([down.stable[::-1], up.stable[1:]]),
        stability=np.concatenate([down.stability[::-1], up.stability[1:]]),
        multipliers=np.concatenate([pad(down.multipliers)[::-1], pad(up.multipliers)[1:]]),
        special_points=[SpecialPoint.from_detail(d, up.parameter) for d in details],
        special_details=details, status=status,
        message=f"decreasing side: {down.message}. Increasing side: {up.message}",
        success=down.success and up.success, problem=up.problem, context=up.context,
        time=down.time + up.time)


def _locate(problem, kind, y0, tau0, h, f0, tol, tol_special, max_corrector):
    """Bisect in arclength from ``y0`` for the zero of the test function of ``kind``."""
    a, b = 0.0, h
    fa = f0
    best = None
    for _ in range(200):
        if b - a <= tol_special * max(1.0, h):
            break
        s = 0.5 * (a + b)
        y, ok, _, _ = _correct(problem, y0 + s * tau0, tau0, tol, max_corrector)
        if not ok:
            return None
        try:
            if kind == "fold":
                Jx, Jp = problem.jacobian(y[:-1], y[-1])
                f = _tangent(Jx, Jp, tau0)[-1]
                mu = None
            elif kind == "branch_point":
                mu, _ = _multipliers(problem, y)
                f = _branch_test(mu)
            else:
                mu, f = _multipliers(problem, y)
        except _Refused:
            return None
        best = (y, mu)
        if f * fa > 0.0:
            a, fa = s, f
        else:
            b = s
    if best is None:
        return None
    y, mu = best
    if mu is None:
        try:
            mu, _ = _multipliers(problem, y)
        except _Refused:
            mu = np.array([], dtype=complex)
    return dict(kind=kind, value=float(y[-1]), state=y[:-1].copy(), multipliers=mu)


# ------------------------------------------------------------------ file codec (tps_solver.core.archive)
def _validate_branch(f):
    k = f.array("parameter_values", "f", ndim=1, finite=True).size
    f.array("stable", "b", shape=(k,))
    if f.has("stability"):
        f.array("stability", "U", shape=(k,))
    f.array("states", "f", shape=(k, None), finite=True)
    f.array("multipliers", "fc", shape=(k, None))
    f.str("parameter")
    f.int("status")
    if f.has("time"):
        f.float("time")


archive.register("Branch", Branch, validate=_validate_branch)
