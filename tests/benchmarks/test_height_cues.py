"""The image-only height cues of benchmarks/bench_height_cues.py on a footprint whose answer is known."""

import numpy as np
import pytest

from benchmarks.bench_height_cues import corr, cues
from pressurepose.mat import get_mat
from tests.eval.test_realism import body

MAT = get_mat("boditrak_bt3510")


def test_extent_and_crown_to_pelvis_of_a_footprint():
    img = body()
    img[31, 8:19] = 40.0  # the pelvis: the heaviest row in the middle of the extent (rows 2-59)
    length, trunk = cues(img[None], MAT)
    assert length[0] == pytest.approx(58 * MAT.pitch_row_m)
    assert trunk[0] == pytest.approx((31 - 2) * MAT.pitch_row_m)
    moved = np.roll(img, 3, axis=0)  # the same body 3 rows lower reads the same
    assert np.allclose(cues(moved[None], MAT), (length, trunk))
    assert np.isnan(cues(np.zeros((1, 64, 27)), MAT)[1][0])
    assert corr([1, 2, np.nan, 4], [2, 4, 5, 8]) == pytest.approx(1.0)
