import numpy as np
import pytest

from ssskit.materials import MATERIALS


@pytest.fixture
def rng():
    return np.random.default_rng(20260101)


MATERIAL_CHANNELS = [(name, c) for name in MATERIALS.names() for c in range(3)]
