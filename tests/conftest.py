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


#: The paper's arm with other link lengths: the second design the printed parts are tested on.
OTHER_LENGTHS = handarm.ArmDesign(link_lengths=(0.045, 0.055, 0.05, 0.06, 0.045, 0.05, 0.055))


@pytest.fixture(scope="session")
def carved_default():
    """The paper's arm carved at the default 1 degree (with its printed parts on first use)."""
    from handarm.carve import carve

    return carve(handarm.ArmDesign())


@pytest.fixture(scope="session")
def carved_other_lengths():
    """``OTHER_LENGTHS`` carved at the default 1 degree."""
    from handarm.carve import carve

    return carve(OTHER_LENGTHS)
