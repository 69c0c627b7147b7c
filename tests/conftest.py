import math

import numpy as np
import pytest

import handarm


@pytest.fixture
def design():
    return handarm.ArmDesign()


@pytest.fixture
def loose():
    """The paper's lengths with every limit at +-180 degrees: only link crossings matter."""
    return handarm.ArmDesign(joint_limits=((-math.pi, math.pi),) * 6)


@pytest.fixture
def rng():
    return np.random.default_rng(0)
