"""The picture of a dataset summary: what its panels show."""

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from pressurepose.data.info import Summary  # noqa: E402
from pressurepose.viz.dataset import draw_summary, summary_figure  # noqa: E402


def _summary(counts, peak=41.0):
    edges = np.linspace(0.0, 150.0, 151)  # as summarize bins them: to 1.5 x a 100 mmHg sensor
    hist = np.histogram(np.random.default_rng(0).uniform(1, peak, 500), edges)[0].astype(float)
    return Summary(root=Path("/x/ds"), mat="boditrak_bt3510", shape=(64, 27), samples=sum(counts.values()),
                   datasets=len(counts), counts=counts, attempts=10, pressure_hist=(hist, edges),
                   load_ratio=np.array([0.9, 0.95, 1.0]), pressure_max=peak,
                   examples=[("a", np.zeros((64, 27))), ("b", np.ones((64, 27)))])


def _bottom_axes(fig):
    return [a for a in fig.axes if a.get_xlabel() in ("pressure of loaded taxels (mmHg)", "force on mat / body weight",
                                                       "samples")]


def test_one_partition_draws_no_one_bar_panel_and_names_it_in_the_title():
    fig = summary_figure(_summary({("general_supine", "f", False): 6}))
    try:
        labels = [a.get_xlabel() for a in _bottom_axes(fig)]
        assert labels == ["pressure of loaded taxels (mmHg)", "force on mat / body weight"]
        assert "general_supine, female" in fig._suptitle.get_text()
    finally:
        plt.close(fig)
    fig = summary_figure(_summary({("general_supine", "f", False): 6, ("general", "m", True): 4}))
    try:
        counts = [a for a in _bottom_axes(fig) if a.get_xlabel() == "samples"]
        assert len(counts) == 1 and len(counts[0].patches) == 2
    finally:
        plt.close(fig)


def test_pressure_histogram_axis_ends_with_the_data(tmp_path):
    s = _summary({("general_supine", "f", False): 6}, peak=41.0)
    fig = summary_figure(s)
    try:
        ax = next(a for a in fig.axes if a.get_xlabel().startswith("pressure"))
        lo, hi = ax.get_xlim()
        assert lo == 0 and 41 <= hi <= 42  # the last loaded bin, not the 150 mmHg the bins reach
    finally:
        plt.close(fig)
    assert draw_summary(s, tmp_path / "info.png").stat().st_size > 0
