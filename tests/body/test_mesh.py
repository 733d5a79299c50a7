import numpy as np
import trimesh

from pressurepose.body.mesh import mesh_volume, points_inside


def test_points_inside_and_volume_of_a_box():
    box = trimesh.creation.box(extents=(1.0, 2.0, 3.0))
    pts = np.array([[0, 0, 0], [0.49, 0.99, 1.49], [0.51, 0, 0], [0, 0, 1.6], [2, 2, 2]], float)
    np.testing.assert_array_equal(points_inside(pts, box.vertices, box.faces), [True, True, False, False, False])
    np.testing.assert_allclose(mesh_volume(box.vertices[None], box.faces), [6.0])
    # reversed winding gives the negative volume, the inside test does not care
    np.testing.assert_allclose(mesh_volume(box.vertices[None], box.faces[:, ::-1]), [-6.0])
    np.testing.assert_array_equal(points_inside(pts[:2], box.vertices, box.faces[:, ::-1]), [True, True])
