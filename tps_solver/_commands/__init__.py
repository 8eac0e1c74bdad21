"""CLI subcommands, one module each (see :mod:`tps_solver.cli`)."""
