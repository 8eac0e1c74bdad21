"""One progress display for the long-running calls: a tqdm bar when tqdm is installed, else logging.

:class:`Progress` is the only progress wrapper of the package.  It serves three kinds of
callbacks:

* :meth:`Progress.newton` -- ``callback(iteration, tc, residual)`` of the TPS solvers, of
  :func:`~tps_solver.solve_lattice_cycle` and of the continuation (one step done);
* :meth:`Progress.fraction` -- ``callback(progress)`` of :func:`~tps_solver.simulate` and
  :func:`~tps_solver.check_stability` (``progress.fraction`` in [0, 1]);
* :meth:`Progress.update` -- a counter of finished work items (:func:`~tps_solver.sweep`).

tqdm is optional and imported lazily, when the first update arrives (so a call that fails at
once prints nothing); without it the updates become ``logging`` lines of the logger
``tps_solver`` (at most one per tenth of the work for fractions and counts).
"""
import logging

__all__ = ["Progress"]

_LOG = logging.getLogger("tps_solver")


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

    Use :meth:`newton` as the ``callback`` of the TPS solvers and of
    :func:`~tps_solver.solve_lattice_cycle` (``callback(iteration, tc, residual)``),
    :meth:`fraction` as the ``callback`` of :func:`~tps_solver.simulate` and
    :func:`~tps_solver.check_stability` (``callback(progress)`` with ``progress.fraction``),
    :meth:`update` to count finished items.

    Examples
    --------
    >>> with Progress("demo", enabled=False) as bar:
    ...     bar.newton(1, None, 1e-3)
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

    def newton(self, iteration, tc, residual):
        """Callback of the Newton solvers: one step (or continuation point) done."""
        self._steps += 1
        if not self.enabled:
            return
        self._open()
        if self.bar is not None:
            self.bar.set_postfix_str(f"step {iteration}, max|F| {residual:.2e}", refresh=True)
        else:
            _LOG.info("%s: step %d, max|F| = %.3e", self.desc, iteration, residual)

    def fraction(self, progress):
        """Callback of the FDA (``progress.fraction`` in [0, 1] of the run)."""
        if not self.enabled:
            return
        self._open()
        frac = float(getattr(progress, "fraction", 0.0))
        if self.bar is not None:
            self.bar.n = int(round(100 * min(1.0, frac)))
            self.bar.refresh()
        elif frac - self._last_log >= 0.1 or frac >= 1.0 > self._last_log:
            self._last_log = frac
            _LOG.info("%s: %.0f %% done", self.desc, 100 * frac)

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
