"""``split_pairs``: adjacent modes within each other's half-power band and of alike shapes."""

import numpy as np

from physics.identification.split_modes import split_pairs, split_text


def test_overlapping_bands_with_alike_shapes_are_a_split_and_distinct_shapes_are_not():
    f = np.array([3007.5, 3007.4, 4125.0, 4147.4, 100.0, 100.5])
    z = np.array([0.0015, 0.0015, 0.00056, 0.00076, 0.01, 0.01])
    # 3007.4/3007.5: 0.1 Hz apart, bands 4.5 Hz each: split (one channel: MAC 1)
    # 4125/4147.4: 22.4 Hz apart > 2.31 + 3.15 Hz: apart; 100/100.5: 0.5 < 1 + 1.005 Hz but orthogonal shapes
    shapes = np.array([[1, 1, 1, 1, 1, 0], [0.5, 0.5, 1, 1, 0, 1]], complex)
    pairs = split_pairs(f, z, shapes)
    np.testing.assert_array_equal(pairs, [[1, 0]])
    assert split_pairs(f, np.full(6, np.nan), shapes).shape == (0, 2)
    assert split_text("a.uff", [3007.4, 3007.5], [(0, 1)]) == (
        "a.uff: modes 1 and 2 (3007.4 and 3007.5 Hz) lie within each other's half-power band with alike shapes "
        "(MAC >= 0.9): nothing in the data separates them, most likely one mode the fit split in two; try another "
        "--max-order or a --band around it")
