"""The foundation: argument checks, result bunches, the orbit vocabulary and status table, defaults,
cost budgets and progress, and the file archive.  Imports nothing else of ``tps_solver``."""
