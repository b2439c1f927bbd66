"""The compiled search's box-pruned nearest node (planner/search/tree_kernels.py) against the
full scan (band_kernels.nearest): the same index on trees grown in chains as CBiRRT grows them,
with exact ties and targets on nodes, inside boxes and far away, the boxes grown as they fill."""

import numpy as np
import pytest

pytest.importorskip("numba")

from hriplan.planner.search.band_kernels import nearest
from hriplan.planner.search.tree_kernels import BLOCK, boxed, boxes_room, nearest_boxed


def _grown(rng, n: int, dims: int, chains: int) -> np.ndarray:
    """`chains` walks of short steps from random nodes, as extensions add them (some nodes repeated: ties)."""
    nodes = [rng.uniform(-3.0, 3.0, dims)]
    for _ in range(chains):
        x = nodes[int(rng.integers(0, len(nodes)))].copy()
        ahead = rng.normal(size=dims)
        for _ in range(int(rng.integers(1, 3 * BLOCK))):
            x = x + 0.05 * ahead / np.linalg.norm(ahead) + rng.normal(0.0, 0.005, dims)
            nodes.append(x if rng.random() > 0.1 else nodes[int(rng.integers(0, len(nodes)))].copy())
            if len(nodes) == n:
                return np.array(nodes)
    return np.array(nodes)


def test_the_nearest_is_the_full_scans(rng):
    """Trees grown a chain at a time (the boxes widened by each chain, their arrays grown from
    one box): every query answers as the full scan, ties to the first of equals."""
    answers = 0
    for _ in range(60):
        dims = int(rng.integers(1, 13))
        nodes = _grown(rng, int(rng.integers(1, 700)), dims, 400)
        low, high = np.empty((dims, 1)), np.empty((dims, 1))
        count = 0
        while count < len(nodes):
            grown = min(len(nodes), count + int(rng.integers(1, 30)))
            low, high = boxes_room(low, high, grown)
            boxed(nodes, count, grown, low, high)
            count = grown
            node = nodes[int(rng.integers(0, count))]
            for x in (node, node + rng.normal(0.0, 0.01, dims), rng.uniform(-4.0, 4.0, dims)):
                index = nearest_boxed(nodes, count, x, low, high)
                assert index == nearest(nodes, count, x)
                answers += index > 0
        assert low.shape[1] * BLOCK >= len(nodes)
    assert answers > 1000


def test_boxes_hold_their_nodes(rng):
    """Box b is the bounding box of nodes b*BLOCK.. (b+1)*BLOCK - 1, exactly (a coordinate's
    bounds of every box in a row)."""
    nodes = rng.normal(size=(5 * BLOCK + 3, 4))
    low, high = boxes_room(np.empty((4, 1)), np.empty((4, 1)), len(nodes))
    boxed(nodes, 0, 7, low, high)
    boxed(nodes, 7, len(nodes), low, high)
    for b in range(6):
        run = nodes[b * BLOCK : (b + 1) * BLOCK]
        assert (low[:, b] == run.min(axis=0)).all() and (high[:, b] == run.max(axis=0)).all()
