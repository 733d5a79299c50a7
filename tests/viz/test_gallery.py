"""The gallery of a real-image evaluation: which estimates it shows and how it frames them."""

from types import SimpleNamespace

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from pressurepose.mat import custom_mat  # noqa: E402
from pressurepose.viz.gallery import gallery_figure, gallery_picks  # noqa: E402


def _rows(image, correct, err_cm, iou, scored=None):
    n = len(image)
    return {"image": np.array(image), "subject": np.array([str(i) for i in image]),
            "posture": np.array(["supine"] * n), "detail": np.array(["supine"] * n),
            "body_model": np.array(["fm"[k % 2] for k in range(n)]),
            "predicted": np.array(["supine" if c else "left" for c in correct]),
            "scored": np.ones(n, bool) if scored is None else np.array(scored),
            "correct": np.array(correct), "stature_m": 1.7 + np.array(err_cm) / 100.0,
            "stature_err_m": np.array(err_cm, dtype=float) / 100.0, "height_m": np.full(n, 1.7),
            "contact_iou": np.array(iou, dtype=float)}


def test_best_and_worst_are_distinct_images_ranked_by_posture_then_stature():
    # four images, each estimated with both body models (rows 2k and 2k + 1)
    rows = _rows(image=[0, 0, 1, 1, 2, 2, 3, 3],
                 correct=[True, True, True, False, True, True, False, False],
                 err_cm=[1, 2, 22, 3, 5, 30, 10, 40],
                 iou=[0.3, 0.3, 0.9, 0.9, 0.4, 0.2, 0.5, 0.5])
    picks = gallery_picks(rows, count=2)
    best = [i for kind, i in picks if kind == "best"]
    worst = [i for kind, i in picks if kind == "worst"]
    # image 0's two estimates are the two best; it shows once, beside image 2 (5 cm), not image 1
    # (22 cm off though its contact IoU is the highest)
    assert best == [0, 4]
    # the worst: image 3 by its posture-wrong, 40 cm-off estimate, then image 1's wrong posture
    assert worst == [7, 3]
    images = [rows["image"][i] for _, i in picks]
    assert len(set(images)) == len(images)


def test_unknown_heights_rank_after_known_ones_then_by_contact_iou():
    rows = _rows(image=[0, 1, 2, 3], correct=[True] * 4, err_cm=[np.nan, 8, np.nan, 12],
                 iou=[0.2, 0.1, 0.7, 0.1])
    assert [i for _, i in gallery_picks(rows, count=2)] == [1, 3, 0, 2]


def _result(n_images=4):
    grid = custom_mat(rows=8, cols=4, pitch_row_m=0.25, pitch_col_m=0.2)  # 0.8 x 2.0 m
    rng = np.random.default_rng(0)
    tetra = np.array([[0, 0, 0], [0.3, 0, 0], [0, 0.6, 0], [0, 0, 0.2]])
    # bodies here and there, one reaching 0.3 m past the mat's side and one past its foot end
    shifts = np.array([[0.2, 0.3, 0], [0.8, 0.5, 0], [0.1, 1.7, 0], [0.3, 0.2, 0]])[:n_images]
    verts = tetra[None] + shifts[:, None]
    est = SimpleNamespace(grid=grid, vertices=verts, faces=np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]),
                          q=rng.uniform(0, 30, (n_images, 8, 4)))
    rows = _rows(image=list(range(n_images)), correct=[True, False] * (n_images // 2),
                 err_cm=list(range(n_images)), iou=[0.5] * n_images)
    return SimpleNamespace(rows=rows, estimate=est, input=rng.uniform(0, 60, (n_images, 8, 4)), contact_mmhg=5.0)


def test_every_body_panel_has_one_extent_holding_the_mat_and_every_body_and_colour_bars():
    result = _result()
    fig = gallery_figure(result, count=2)
    try:
        body_axes = [a for a in fig.axes if a.get_title().startswith("estimated body")]
        assert len(body_axes) == 4
        limits = {(a.get_xlim(), a.get_ylim()) for a in body_axes}
        assert len(limits) == 1  # the same frame on every row
        (x0, x1), (y0, y1) = limits.pop()
        v = result.estimate.vertices
        assert x0 < min(0, v[..., 0].min()) and x1 > max(0.8, v[..., 0].max())  # plot y is -y of the bed
        assert y0 < min(-2.0, -v[..., 1].max()) and y1 > max(0, -v[..., 1].min())
        assert all(a.get_aspect() == 1.0 for a in body_axes)
        bars = [a.get_ylabel() for a in fig.axes]
        assert bars.count("mmHg") == 4 and bars.count("mm of sink") == 4
    finally:
        plt.close(fig)
