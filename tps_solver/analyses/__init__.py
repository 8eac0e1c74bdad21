"""Analyses built on the solvers: stability checks, continuation, localized states (kinks and
oscillons), basins of the flat layer and parameter sweeps."""
