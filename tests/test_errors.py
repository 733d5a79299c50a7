"""The shared input checks of pressurepose.errors: what each accepts, and that its message names the
input, the value given and what was expected."""

import numpy as np
import pytest

from pressurepose.errors import BadInput, require_between, require_non_negative, require_positive, require_whole


@pytest.mark.parametrize("v", [1, 0, 5, np.int64(3)])
def test_require_whole_without_a_top_takes_any_whole_number_from_lo(v):
    require_whole("n", v, 0)
    require_whole("n", 10 ** 30, 1)


@pytest.mark.parametrize("v", [0, -1, 1.0, True, "2", None, np.float64(2.0)])
def test_require_whole_without_a_top_refuses_the_rest(v):
    with pytest.raises(BadInput, match=r"^n is .*; expected a whole number >= 1$"):
        require_whole("n", v, 1)


def test_require_whole_with_a_top_keeps_its_range_and_message():
    require_whole("n", 3, 1, 3)
    with pytest.raises(BadInput, match=r"^n is 4; expected a whole number from 1 to 3$"):
        require_whole("n", 4, 1, 3)


@pytest.mark.parametrize("check, good, bad, expected", [
    (require_positive, [1e-9, 2, np.float32(0.5)], [0, -1.0], "a positive number"),
    (require_non_negative, [0, 0.0, 3, np.int32(1)], [-1e-9, -2], "zero or a positive number"),
])
def test_positive_and_non_negative(check, good, bad, expected):
    for v in good:
        check("x", v)
    for v in bad:
        with pytest.raises(BadInput, match=rf"^x is {v!r}; expected {expected}$"):
            check("x", v)
    for v in (float("nan"), float("inf"), True, "1", None):
        with pytest.raises(BadInput, match=r"^x is .*; expected a finite number$"):
            check("x", v)


def test_require_between_takes_the_closed_interval_and_refuses_the_rest():
    for v in (1, 1.0, 2.5, 4, np.float32(3.0), np.int64(2)):
        require_between("f", v, 1, 4)
    for v in (0.99, 4.01, float("nan"), float("inf"), -float("inf"), True, "2", None):
        with pytest.raises(BadInput, match=r"^f is .*; expected a number from 1 to 4$"):
            require_between("f", v, 1, 4)


def test_require_bool_takes_true_and_false_only():
    import numpy as np
    import pytest

    from pressurepose.errors import BadInput, require_bool

    assert require_bool("flag", True) is True and require_bool("flag", np.bool_(False)) is False
    for v in ("no", 1, None):
        with pytest.raises(BadInput, match=r"^flag is .*; expected True or False$"):
            require_bool("flag", v)
