"""tools/draw_body_sites.py: the picture of the body sites in docs/monitoring.md."""

import numpy as np

from tests.toolscript import load_tool


def _tool():
    return load_tool("draw_body_sites")


def test_every_site_has_its_own_colour():
    from pressurepose.body.sites import SITES

    colours = _tool().site_colours()
    assert colours.shape == (len(SITES), 4)
    assert len({tuple(c) for c in colours}) == len(SITES)


def test_a_view_paints_only_the_triangles_facing_the_viewer():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tool = _tool()
    verts = np.array([[0, 0, 0], [1, 0, 0], [0, 0, 1], [0, 0.1, 0], [0, 0.1, 1], [1, 0.1, 0]], float)
    faces = np.array([[0, 1, 2], [3, 4, 5]])  # the first turned toward -y (the front), the second toward +y
    fig, ax = plt.subplots()
    tool.draw_view(ax, verts, faces, np.array([0, 1]), tool.site_colours(), (1.0, 0, 0), (0, -1.0, 0))
    (polys,) = ax.collections
    assert len(polys.get_paths()) == 1
    assert np.allclose(polys.get_facecolor()[0], tool.site_colours()[0])
    plt.close(fig)


def test_it_draws_the_picture(tmp_path):
    out = tmp_path / "sites.png"
    assert _tool().main(["--out", str(out)]) == 0
    assert out.stat().st_size > 10_000
