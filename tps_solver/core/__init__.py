"""The foundation: argument checks, result bunches, the orbit vocabulary and status table, defaults,
cost estimates (costs), the progress display (progress), and the file archive.  Imports nothing else of ``tps_solver``."""
