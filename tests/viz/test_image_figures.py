"""The per-image pictures of ``infer`` (estimate_000.png, sites_000.png) without being looked at:
the image named, colour bars in mmHg, the head end and the bed's sides named, site labels for
people that do not overlap, a doubt about the image said over it, and no matplotlib warnings."""

from types import SimpleNamespace

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from pressurepose.body.sites import NO_SITE, site_index, site_stats  # noqa: E402
from pressurepose.mat import custom_mat  # noqa: E402
from pressurepose.viz.estimate import estimate_figure  # noqa: E402
from pressurepose.viz.mesh import ACROSS_BED  # noqa: E402
from pressurepose.viz.sites import site_figure, spread_labels  # noqa: E402

GRID = custom_mat(rows=16, cols=8, pitch_row_m=0.1, pitch_col_m=0.1)  # 0.8 x 1.6 m


def _colour_bar_labels(fig):
    return [a.get_ylabel() for a in fig.axes if a.get_label() == "<colorbar>"]


def _estimate(doubt=None):
    """An estimate of two images on a 16 x 8 mat, with sites crowded together (their labels would
    overlap where they were drawn), a tetrahedron for a body."""
    rng = np.random.default_rng(0)
    pressure = np.zeros((2, 16, 8), np.float32)
    taxel = np.full((2, 16, 8), NO_SITE, np.int8)
    crowd = (("right_shoulder", 3, 3), ("right_elbow", 3, 5), ("right_trochanter", 4, 4), ("sacrum", 8, 3),
             ("left_trochanter", 8, 4), ("head", 0, 0), ("right_knee", 12, 7))
    for name, r, c in crowd:
        pressure[:, r, c] = rng.uniform(20, 80)
        taxel[:, r, c] = site_index(name)
    pressure[:, 10:12, 2:6] = 10.0
    taxel[:, 10:12, 2:6] = site_index("other")
    tetra = np.array([[0.2, 0.2, 0.0], [0.6, 0.3, 0.0], [0.4, 1.4, 0.0], [0.4, 0.6, 0.15]])
    plaus = None if doubt is None else SimpleNamespace(doubt=(None, "few"), reason=("", doubt))
    frame = np.array([3, 4])
    return SimpleNamespace(image_name=lambda i: f"frame {frame[i]}",
        grid=GRID, pressure=pressure, q=rng.uniform(0, 40, (2, 16, 8)), vertices=np.stack([tetra, tetra]),
        faces=np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]), joints=np.stack([tetra, tetra]),
        gender=["f", "m"], frame=frame, plausibility=plaus, sites=site_stats(pressure, taxel, GRID),
        vertex_pressure=rng.uniform(0, 50, (2, 4)))


def _overlap(a, b):
    return a.x0 < b.x1 and b.x0 < a.x1 and a.y0 < b.y1 and b.y0 < a.y1


def test_site_picture_labels_do_not_overlap_and_stay_in_the_picture(no_warnings, drawn):
    fig = site_figure(_estimate(), 0)
    try:
        renderer = drawn(fig)
        ax = fig.axes[0]
        labels = [t for t in ax.texts if t.get_text()]
        assert {t.get_text().split("\n")[0] for t in labels} >= {"right hip (trochanter)", "right shoulder",
                                                                 "right elbow", "sacrum", "left hip (trochanter)"}
        boxes = [t.get_window_extent(renderer) for t in labels]
        frame = ax.get_window_extent(renderer)
        for k, a in enumerate(boxes):
            assert frame.x0 - 0.5 <= a.x0 and a.x1 <= frame.x1 + 0.5
            assert frame.y0 - 0.5 <= a.y0 <= a.y1 <= frame.y1 + 0.5
            assert not any(_overlap(a, b) for b in boxes[k + 1:])
    finally:
        plt.close(fig)


def test_spread_labels_moves_only_labels_that_overlap_and_ties_each_moved_one_to_its_site(drawn):
    fig, ax = plt.subplots(figsize=(3, 3))
    ax.set_xlim(0, 1)
    ax.set_ylim(0, 1)
    anchors = [(0.5, 0.5), (0.52, 0.5), (0.2, 0.9)]
    texts = [ax.text(x, y, "a long label", ha="center", va="center") for x, y in anchors]
    lines_before = len(ax.lines)
    spread_labels(ax, texts, anchors)
    renderer = drawn(fig)
    boxes = [t.get_window_extent(renderer) for t in texts]
    assert not _overlap(boxes[0], boxes[1])
    assert texts[2].get_position() == pytest.approx(anchors[2])  # alone: left where it was
    assert len(ax.lines) - lines_before == 1  # one label moved, one line back to its site
    plt.close(fig)


def test_site_picture_marks_the_head_end_the_sides_and_the_units(no_warnings):
    fig = site_figure(_estimate(), 1)
    try:
        image, body, bars = fig.axes[:3]
        assert image.get_ylabel() == "from the head end (m)"
        assert image.get_xlabel() == ACROSS_BED == body.get_xlabel()
        assert "left" in ACROSS_BED and "right" in ACROSS_BED
        assert _colour_bar_labels(fig) == ["pressure (mmHg)"]
        assert bars.get_xlabel().startswith("peak pressure (mmHg)")
        assert any(t.get_text().strip() == "threshold 32 mmHg" for t in bars.texts)
        assert fig._suptitle.get_text().startswith("frame 4: most loaded")
        assert any("their left at x = 0" in t.get_text() for t in fig.texts)
    finally:
        plt.close(fig)


def test_estimate_picture_names_the_frame_units_head_end_and_sides(no_warnings):
    fig = estimate_figure(_estimate(), 0)
    try:
        pressure, q, body = fig.axes[:3]
        assert fig._suptitle.get_text().startswith("frame 3:")
        assert _colour_bar_labels(fig) == ["pressure (mmHg)", "mm of sink"]
        assert pressure.get_ylabel() == "from the head end (m)"
        assert all(a.get_xlabel() == ACROSS_BED for a in (pressure, q, body))
        # the images lie on the mat in metres, as the body beside them
        assert pressure.get_images()[0].get_extent() == pytest.approx([0, 0.8, -1.6, 0])
    finally:
        plt.close(fig)


@pytest.mark.parametrize("draw", [estimate_figure, site_figure])
def test_a_doubtful_image_says_so_over_its_pictures(draw):
    est = _estimate(doubt="too little of the mat is loaded")
    for i, doubtful in ((0, False), (1, True)):
        fig = draw(est, i)
        try:
            title = fig._suptitle.get_text()
            assert ("does not look like a person lying on the mat" in title) == doubtful
            assert ("too little of the mat is loaded" in title) == doubtful
        finally:
            plt.close(fig)


def test_a_picture_is_drawn_once_when_saved_after_tight_layout(tmp_path):
    from pressurepose.viz.estimate import save_numbered_figures

    draws = []

    def draw(i):
        fig, ax = plt.subplots()
        ax.plot([0, 1], [0, 1])
        fig.tight_layout()
        fig.canvas.mpl_connect("draw_event", lambda event: draws.append(event))
        return fig

    (path,) = save_numbered_figures(tmp_path, "one_", 1, draw)
    assert path.stat().st_size > 0 and len(draws) == 1
