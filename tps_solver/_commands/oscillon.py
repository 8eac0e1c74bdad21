"""``tps-solver oscillon``: the TPS oscillon (Sec. 4.3.2)."""
from tps_solver._commands import _tps_common

NAME = "oscillon"
#: API parameter -> flag, for error messages.
FLAGS = _tps_common.flags("axisymmetric")
HELP = "Time-periodic axisymmetric oscillon by the spectral TPS; prints convergence and the physical checks."


def configure(parser):
    _tps_common.configure(parser, "axisymmetric")


def run(args):
    return _tps_common.run(args, "axisymmetric")
