"""Shared fixtures of the picture tests."""

import warnings

import pytest


@pytest.fixture
def no_warnings():
    """Any warning raised inside the test (matplotlib's included) fails it."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        yield


@pytest.fixture
def drawn():
    """fig -> its renderer, once the figure is drawn (text extents are known only then)."""
    def draw(fig):
        fig.canvas.draw()
        return fig.canvas.get_renderer()
    return draw
