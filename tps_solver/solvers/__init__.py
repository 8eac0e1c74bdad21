"""Solvers: the spectral time-periodic solver (``tps``), the event-driven time steppers (``fda``) and
periodic orbits by shooting (``shooting``).  Imports ``core``, ``model`` and ``operators``."""
