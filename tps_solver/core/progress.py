"""The one callback convention and the one progress display of the long-running calls.

The callback convention
-----------------------
Every ``callback`` of the package -- the TPS solvers, the lattice cycle, shooting,
:func:`~tps_solver.simulate`, :func:`~tps_solver.check_stability`,
:func:`~tps_solver.continue_branch`, :func:`~tps_solver.sweep`, the one Newton -- is called as
``callback(state)`` with one :class:`ProgressState`: a Bunch whose fields ``stage`` (str),
``iteration`` (int), ``fraction`` (float in [0, 1], NaN when the end is not known in advance)
and ``residual`` (float, NaN where there is none) are always present, next to the fields of
its stage (``tc`` or ``x``, ``parameter_value`` and ``stable``, ``params`` and ``result``,
``t``, ...; each call documents them).  Raising ``KeyboardInterrupt`` in a callback stops the
call, which returns what it has (status 5).

The progress display
--------------------
:class:`Progress` is the only progress wrapper: an instance is itself such a callback (a
percentage bar when ``fraction`` is known, the step and residual otherwise), and
:meth:`Progress.update` counts finished work items (:func:`~tps_solver.sweep`).

tqdm is optional and imported lazily, when the first update arrives (so a call that fails at
once prints nothing); without it the updates become ``logging`` lines of the logger
``tps_solver`` (at most one per tenth of the work for fractions and counts).
"""
import logging
import math

from tps_solver.core.bunch import Bunch

__all__ = ["Progress", "ProgressState", "progress_state"]

_LOG = logging.getLogger("tps_solver")


class ProgressState(Bunch):
    """The one argument of every callback (module docstring).

    Examples
    --------
    >>> state = progress_state("newton", 3, residual=1e-8, tc=None)
    >>> state.stage, state.iteration, state.residual, math.isnan(state.fraction)
    ('newton', 3, 1e-08, True)
    """


def progress_state(stage, iteration=0, fraction=math.nan, residual=math.nan, **fields):
    """A :class:`ProgressState` with the four fields every callback receives, and ``fields``.

    Examples
    --------
    >>> progress_state("sweep", 2, fraction=0.5, total=4).total
    4
    """
    return ProgressState(stage=str(stage), iteration=int(iteration), fraction=float(fraction),
                         residual=float(residual), **fields)


class Progress:
    """A progress display for the callbacks of long-running calls (tqdm, else logging).

    Parameters
    ----------
    desc : str
        Label of the bar or of the log lines.
    total : float, optional
        Total of the work: 1.0 for fraction callbacks (default), the number of items for
        :meth:`update`.
    enabled : bool
        ``False``: the callbacks do nothing (quiet mode).
    initial : int, optional
        Items already done when counting (:meth:`update`), e.g. points found in a store.
    unit : str, optional
        Unit of the counted items (default ``"it"``).

    Pass the instance itself as the ``callback`` of any call (the one convention of the module
    docstring); use :meth:`update` to count finished items.

    Examples
    --------
    >>> with Progress("demo", enabled=False) as bar:
    ...     bar(progress_state("newton", 1, residual=1e-3))
    ...     bar(progress_state("simulate", 0, fraction=0.5))
    >>> with Progress("points", total=3, enabled=False) as bar:
    ...     for _ in range(3):
    ...         bar.update()
    >>> bar.done
    3
    """

    def __init__(self, desc, total=1.0, enabled=True, *, initial=0, unit="it"):
        self.desc, self.total, self.enabled = desc, float(total), bool(enabled)
        self.done, self.unit = int(initial), unit
        self.bar, self._last_log = None, -1.0
        self._next_log = self.done
        self._steps = 0
        self._opened = False
        self._stage = None          # the stage shown (its name is in the bar's label)
        self._finite = None         # whether that stage reports fractions (a 0-100 % bar) or steps

    def _open(self, counting=False):
        """Create the bar at the first update, so a call that fails at once prints nothing."""
        if self._opened:
            return
        self._opened = True
        try:
            from tqdm.auto import tqdm
        except ImportError:
            if counting and self.done:
                _LOG.info("%s: %d of %d %s already done", self.desc, self.done, int(self.total), self.unit)
            return
        if counting:
            self.bar = tqdm(total=int(self.total), initial=self.done, desc=self.desc, unit=self.unit,
                            dynamic_ncols=True)
        else:
            self.bar = tqdm(total=100, desc=self.desc, unit="%", dynamic_ncols=True, leave=False)

    def _enter_stage(self, stage, finite):
        """A new stage (or a stage that switches between fractions and steps): relabel and restart the bar."""
        if stage == self._stage and finite == self._finite:
            return
        self._stage, self._finite, self._steps, self._last_log = stage, finite, 0, -1.0
        if self.bar is not None:
            self.bar.reset(total=100 if finite else None)
            if not finite:
                self.bar.total = None              # reset(total=None) keeps the old total
            self.bar.unit = "%" if finite else "step"
            self.bar.set_description(f"{self.desc} [{stage}]" if stage else self.desc, refresh=True)

    def __call__(self, state):
        """The callback: the stage's name, and a percentage when ``state.fraction`` is known, else the
        steps taken (a count that moves) and the residual."""
        finite = math.isfinite(state.fraction)
        if self.enabled:
            self._open()
            self._enter_stage(state.get("stage"), finite)
        if finite:
            self._fraction(state.fraction)
            return
        self._steps += 1
        if not self.enabled:
            return
        text = f"step {state.iteration}"
        if math.isfinite(state.residual):
            text += f", max|F| = {state.residual:.3e}"
        if self.bar is not None:
            self.bar.update(1)
            self.bar.set_postfix_str(text, refresh=True)
        else:
            _LOG.info("%s: %s [%s]", self.desc, text, state.get("stage"))

    def newton(self, iteration, tc, residual):
        """The display of one Newton step given positionally (as ``self(state)`` of stage "newton")."""
        self(progress_state("newton", iteration, residual=residual, tc=tc))

    def fraction(self, progress):
        """The display of a fraction of the work done (``progress.fraction`` in [0, 1])."""
        self._fraction(float(getattr(progress, "fraction", 0.0)))

    def _fraction(self, frac):
        if not self.enabled:
            return
        self._open()
        frac = float(frac)
        if self.bar is not None:
            self.bar.n = int(round(100 * min(1.0, frac)))
            self.bar.refresh()
        elif frac - self._last_log >= 0.1 or frac >= 1.0 > self._last_log:
            self._last_log = frac
            _LOG.info("%s: %.0f %% done%s", self.desc, 100 * frac, f" [{self._stage}]" if self._stage else "")

    def update(self, n=1):
        """``n`` more items done (counting mode, out of ``total``)."""
        if not self.enabled:
            self.done += int(n)
            return
        self._open(counting=True)
        self.done += int(n)
        if self.bar is not None:
            self.bar.update(int(n))
        elif self.done >= self._next_log or self.done >= self.total:
            _LOG.info("%s: %d of %d %s done", self.desc, self.done, int(self.total), self.unit)
            self._next_log = self.done + max(1, int(self.total) // 10)

    def close(self):
        """Close the bar (if one was opened)."""
        if self.bar is not None:
            self.bar.close()
            self.bar = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False
