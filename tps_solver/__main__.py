"""``python -m tps_solver``: the ``tps-solver`` console script (see :mod:`tps_solver.cli`)."""
import sys

from tps_solver.cli import main

if __name__ == "__main__":
    sys.exit(main())
