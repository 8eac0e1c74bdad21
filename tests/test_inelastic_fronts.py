"""Contact classification of validation.inelastic_fronts on hand-built event lists."""
import numpy as np
import pytest

from validation.inelastic_fronts import chain_statistics

T = 4 * np.pi


def test_chain_statistics_hand_built():
    # node 0: touch (impact) at 1.0; stick at 5.0, lift-off at 5.3 when node 1 lands (triggered)
    # node 1: stick at 5.3, smooth lift-off at 7.0; stick landing at 2.0 with lift-off in the same set
    t = np.array([1.0, 5.0, 5.3, 5.3, 7.0, 2.0, 2.0])
    node = np.array([0, 0, 0, 1, 1, 1, 1])
    kind = np.array(["impact", "stick", "liftoff", "stick", "liftoff", "stick", "liftoff"])
    st = chain_statistics(t, node, kind, 0.0, T, 2)
    assert (st["touch"], st["stick_smooth"], st["stick_triggered"]) == (2, 1, 1)
    assert st["chain_nodes"].tolist() == [0]
    assert st["chain_durations"] == pytest.approx([0.3], abs=1e-14)


def test_chain_statistics_wraps_the_period():
    # a stick that starts before the end of the period and lifts off after t_start (cyclic)
    t = np.array([T - 0.2, 0.1, 3.0])
    node = np.array([0, 0, 1])
    kind = np.array(["stick", "liftoff", "impact"])
    st = chain_statistics(t, node, kind, 0.0, T, 2)
    assert (st["touch"], st["stick_smooth"], st["stick_triggered"]) == (1, 1, 0)
