"""Periodic orbits of any contact pattern by Newton-Krylov shooting on the FDA period map, and the
exact linearised period map of the soft contact."""
