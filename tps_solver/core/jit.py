r"""Optional compiled inner loops: numba when the ``fast`` extra is installed, the interpreter otherwise.

A *kernel* is a small function written in the subset of Python that numba compiles
(scalar ``math``, loops, NumPy arrays).  :func:`kernel` compiles it with
``numba.njit(cache=True)`` when numba can be imported and the environment variable
``TPS_SOLVER_NUMBA`` is not ``"0"``; otherwise it returns the function unchanged, so
the same source is the reference path run by the interpreter.  Compiled kernels are
cached next to their module (``__pycache__``), so a second process does not compile
them again.

The decision is taken when a kernel module is imported; kernel modules are imported
lazily by the functions that use them, so ``import tps_solver`` never imports numba.

Examples
--------
>>> from tps_solver.model.ball_kernel import ball_cycles
>>> ball_cycles(4.1, 0.0, 1e-6, 0.0, 0.0, 0.5, 2).shape      # compiled if enabled()
(3, 3)
"""
import importlib.util
import os

__all__ = ["available", "compiled_option", "enabled", "kernel", "reference"]


def available():
    """Whether numba can be imported (the ``fast`` extra is installed).

    Examples
    --------
    >>> isinstance(available(), bool)
    True
    """
    return importlib.util.find_spec("numba") is not None


def enabled():
    """Whether kernels are compiled: numba is available and ``TPS_SOLVER_NUMBA`` is not ``"0"``.

    Examples
    --------
    >>> enabled() == (available() and os.environ.get("TPS_SOLVER_NUMBA", "1") != "0")
    True
    """
    return available() and os.environ.get("TPS_SOLVER_NUMBA", "1") != "0"


def kernel(func):
    """``numba.njit(cache=True)(func)`` when :func:`enabled`, else ``func`` itself.

    Parameters
    ----------
    func : callable
        A module-level function in numba's subset of Python.

    Returns
    -------
    callable
        The compiled dispatcher (compiles on its first call) or ``func``.

    Examples
    --------
    A kernel is compiled on its first call and cached on disk (a function typed in a session is
    compiled but not cached):

    >>> def square(x):
    ...     return x * x
    >>> (kernel(square) is square) == (not enabled())
    True
    >>> reference(kernel(square)) is square
    True
    """
    if not enabled():
        return func
    import numba
    try:
        return numba.njit(cache=True, nogil=True)(func)
    except RuntimeError:            # no place to cache it (a function typed in a session): compile only
        return numba.njit(nogil=True)(func)


def reference(func):
    """The interpreted function behind a kernel (``func.py_func`` of a dispatcher), else ``func``.

    Examples
    --------
    >>> def one():
    ...     return 1
    >>> reference(one) is one
    True
    """
    return getattr(func, "py_func", func)


def compiled_option(compiled, default=True):
    """The ``compiled`` option of an integrator, checked: whether its compiled kernels run.

    Parameters
    ----------
    compiled : bool or None
        ``True`` (compiled, refused without numba), ``False`` (the numpy reference path) or
        ``None`` (compiled where numba is enabled and ``default`` holds).
    default : bool
        The integrator's own choice for ``None`` (for example: the lattice is large enough).

    Returns
    -------
    bool

    Raises
    ------
    ValueError
        If ``compiled`` is not True, False or None, or True without numba.

    Examples
    --------
    >>> compiled_option(False)
    False
    >>> compiled_option(None) == enabled()
    True
    """
    if compiled not in (None, True, False):
        raise ValueError(f"compiled must be True, False or None, got {compiled!r}")
    if compiled and not enabled():
        raise ValueError("compiled=True needs numba (pip install tps-solver[fast]) and TPS_SOLVER_NUMBA "
                         "not set to 0; use compiled=None or False")
    return bool(enabled() and default) if compiled is None else bool(compiled)
