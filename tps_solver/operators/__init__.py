"""Operators: the FDA lattices and their modes, Green's-function kernels, the per-harmonic Helmholtz
solves and the contact-time polynomial.  Imports ``core`` and ``model``."""
