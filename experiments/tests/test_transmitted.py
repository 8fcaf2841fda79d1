"""lab.transmitted: region levels and the transmitted part's table on a frame with known answers, and the
oblique table's limit at normal incidence (two independent runs of the same slab agree)."""

import math

import numpy as np
import pytest

from lab.transmitted import oblique_table, region_levels, transmitted_table
from ssskit.materials import get_material


def test_levels_and_the_transmitted_part():
    e = np.full((4, 6, 3), 2.0)
    masks = {"left": np.zeros((4, 6), bool), "right": np.zeros((4, 6), bool)}
    masks["left"][:, :3] = True
    masks["right"][:, 3:] = True
    backed = np.full((4, 6, 3), 0.5)
    ref = backed + np.where(masks["left"][..., None], 1.0, 3.0)  # transmitted: 1 on the left, 3 on the right
    se = np.full((4, 6, 3), 0.12)
    part = np.where(masks["left"][..., None], 1.1, 2.7)
    lev = region_levels(ref, e, masks, se)
    assert lev["left"]["level"] == pytest.approx([0.75] * 3) and lev["left"]["pixels"] == 12
    assert lev["left"]["se"] == pytest.approx([0.12 * math.sqrt(12) / 12 / 2] * 3)
    t = transmitted_table(part, ref, backed, se, se, e, masks)
    assert t["left"]["ratio"] == pytest.approx([1.1] * 3) and t["right"]["ratio"] == pytest.approx([0.9] * 3)
    assert t["left"]["path_traced_se"] == pytest.approx([0.12 * math.sqrt(2) * math.sqrt(12) / 12 / 2] * 3)


def test_oblique_table_at_normal_incidence_repeats_itself():
    rows = oblique_table(get_material("skin1"), (1.0,), (0.0,), photons=200_000)  # 20 batches: a sound SE
    (row,) = rows
    for c in range(3):
        assert abs(row["normal_over_oblique"][c] - 1.0) < 4 * row["ratio_se"][c]
        assert row["Ts"][c] > 0
