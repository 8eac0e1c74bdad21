"""One status table: every status code a solver assigns is a code of tps_solver.STATUS, with one meaning."""
import pathlib
import re

import pytest

import tps_solver as tps
from tps_solver.analyses.continuation import BRANCH_STATUS
from tps_solver.core.orbit import outcome
from tps_solver.solvers.fda.common import SIMULATION_STATUS

ROOT = pathlib.Path(__file__).resolve().parents[1] / "tps_solver"
ASSIGN = re.compile(r"\bstatus(?:, message)? = (\d+)\b|\bstatus=(\d+)\b")


def test_every_assigned_code_is_in_the_one_table():
    codes = {}
    for path in ROOT.rglob("*.py"):
        for i, line in enumerate(path.read_text().splitlines(), 1):
            for m in ASSIGN.finditer(line):
                codes.setdefault(int(m.group(1) or m.group(2)), []).append(f"{path.name}:{i}")
    assert codes and set(codes) <= set(tps.STATUS), {c: w for c, w in codes.items() if c not in tps.STATUS}


def test_the_per_solver_tables_are_views_of_the_one_table():
    for table in (SIMULATION_STATUS, BRANCH_STATUS):
        assert all(tps.STATUS[k] == v for k, v in table.items())
    assert 2 not in SIMULATION_STATUS and SIMULATION_STATUS[6] == "event bound exceeded"


@pytest.mark.parametrize("code", sorted(tps.STATUS))
def test_outcome_is_converged_only_for_zero(code):
    assert outcome(code) == {"converged": code == 0, "success": code == 0}


def test_outcome_refuses_an_unknown_code():
    with pytest.raises(ValueError, match="status must be a code"):
        outcome(42)
