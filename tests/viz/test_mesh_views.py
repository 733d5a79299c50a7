import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from pressurepose.errors import BadInput  # noqa: E402
from pressurepose.viz.mesh import VIEWS, draw_capsules, draw_mesh, label_along_bed  # noqa: E402


@pytest.mark.parametrize("name", list(VIEWS))
def test_views_are_rotations_not_mirrors(name):
    right, up, toward = VIEWS[name]
    np.testing.assert_allclose(np.cross(right, up), toward)


def test_front_view_shows_body_left_on_image_right_and_culls_back_faces():
    # one triangle facing -y (toward a front viewer) and one facing +y
    verts = np.array([[0, 0, 0], [1, 0, 0], [0, 0, 1], [0, 1, 0], [2, 1, 0], [0, 1, 1]], float)
    faces = np.array([[0, 1, 2], [3, 5, 4]])  # normals -y (seen) and +y (culled; reaches x = 2)
    fig, ax = plt.subplots()
    draw_mesh(ax, verts, faces, "front")
    polys = ax.collections[0].get_paths()
    assert len(polys) == 1                      # the back-facing one is culled
    assert polys[0].vertices[:, 0].max() == 1   # +x is drawn at the image's right
    draw_capsules(ax, np.zeros((1, 2, 3)) + [[0, 0, 0], [0, 0, 1]], np.array([0.1]), "front")
    plt.close(fig)
    with pytest.raises(BadInput, match="unknown view"):
        draw_mesh(ax, verts, faces, "diagonal")


def test_the_bed_axis_reads_the_distance_from_the_head_end_not_negative_y():
    fig, ax = plt.subplots()
    ax.plot([0.0, 0.5], [0.0, -1.8])  # pictures seen from above or below the mat plot -y: feet below
    ax.set_yticks([0.0, -0.5, -1.0, -1.5])
    label_along_bed(ax)
    fig.canvas.draw()
    assert [t.get_text() for t in ax.get_yticklabels()] == ["0.00", "0.50", "1.00", "1.50"]
    assert ax.get_ylabel() == "from the head end (m)"
    plt.close(fig)
