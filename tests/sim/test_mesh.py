"""Mesh generator, quality report, refinement and I/O."""

import math

import numpy as np
import pytest

from xlotkit import InputError
from xlotkit.sim.mesh import (
    BOTTOM,
    HOLE,
    LEFT,
    RIGHT,
    TOP,
    FractureBand,
    borehole_mesh,
    mesh_from_triangles,
    mesh_quality,
    read_mesh,
    rectangle_mesh,
    refine_uniform,
    write_mesh,
)


def test_default_borehole_mesh_geometry_and_tags():
    m = borehole_mesh()
    # every hole-wall node on the circle; 64 wall segments by default
    hn = m.hole_nodes
    assert len(hn) == 64 and len(m.hole_edges) == 64
    np.testing.assert_allclose(np.hypot(*m.nodes[hn].T), 0.15, rtol=1e-12)
    # the four sides are tagged, and the domain is the square minus the (polygonal) hole
    for tag in (LEFT, RIGHT, BOTTOM, TOP):
        assert np.any(m.boundary_tags == tag)
    polygon = 0.5 * 64 * 0.15 ** 2 * math.sin(2 * math.pi / 64)
    assert m.areas.sum() == pytest.approx(100.0 ** 2 - polygon, rel=1e-12)
    assert np.all(m.areas > 0)
    q = mesh_quality(m)
    # the ring layout gives near-equilateral triangles; 25 deg is a safe lower bound
    assert q.min_angle_deg > 25.0
    assert q.max_neighbour_size_ratio < 1.6
    # graded: wall triangles are orders of magnitude smaller than far-field ones
    assert q.max_area / q.min_area > 1e4


def test_mesh_is_deterministic_and_jitter_is_seeded():
    a = borehole_mesh(size=20.0, jitter=0.2, seed=3)
    b = borehole_mesh(size=20.0, jitter=0.2, seed=3)
    c = borehole_mesh(size=20.0, jitter=0.2, seed=4)
    np.testing.assert_array_equal(a.nodes, b.nodes)
    np.testing.assert_array_equal(a.triangles, b.triangles)
    assert not np.array_equal(a.nodes, c.nodes)
    assert mesh_quality(a).min_angle_deg > 15.0


def test_fracture_band_is_finer_and_marked():
    band = FractureBand(azimuth=0.0, width=0.1, h=0.01, length=1.0)
    m = borehole_mesh(size=10.0, fracture_band=band)
    inband = m.triangle_markers == 1
    assert inband.sum() > 100
    c = m.centroids
    edge = np.sqrt(4 * m.areas / math.sqrt(3))  # equilateral-equivalent edge length
    # inside the band the edge length is close to the requested h
    assert np.median(edge[inband & (np.abs(c[:, 0]) > 0.3)]) == pytest.approx(0.01, rel=0.25)
    q = mesh_quality(m)
    assert q.min_angle_deg > 20.0


def test_mesh_is_immutable_and_replace_returns_new_object():
    m = borehole_mesh(size=10.0)
    with pytest.raises(ValueError):
        m.nodes[0, 0] = 1.0
    with pytest.raises(AttributeError):
        m.nodes = m.nodes  # frozen dataclass
    m2 = m.with_triangle_markers(np.ones(m.n_triangles, dtype=int))
    assert m2 is not m and m.triangle_markers.sum() == 0 and m2.triangle_markers.sum() == m.n_triangles


@pytest.mark.parametrize("kw,key", [({"radius": -1.0}, "radius"), ({"growth": 3.0}, "growth"),
                                    ({"h_wall": 1.0}, "h_wall"), ({"jitter": 0.9}, "jitter")])
def test_bad_generator_input_names_the_key(kw, key):
    with pytest.raises(InputError) as exc:
        borehole_mesh(**kw)
    assert exc.value.key == key


def test_refine_uniform_projects_wall_nodes():
    m = borehole_mesh(size=10.0)
    r = refine_uniform(m)
    assert r.n_triangles == 4 * m.n_triangles
    assert len(r.hole_edges) == 2 * len(m.hole_edges)
    np.testing.assert_allclose(np.hypot(*r.nodes[r.hole_nodes].T), 0.15, rtol=1e-12)


def test_vtu_round_trip_identifies_the_hole(tmp_path):
    m = borehole_mesh(size=10.0)
    path = tmp_path / "m.vtu"
    write_mesh(m, path, cell_data={"area": m.areas},
               point_data={"u": np.zeros((m.n_nodes, 2))})
    r = read_mesh(path)
    assert r.n_triangles == m.n_triangles
    assert len(r.hole_edges) == len(m.hole_edges)
    assert r.hole_radius == pytest.approx(0.15, rel=1e-9)
    np.testing.assert_allclose(r.hole_center, 0.0, atol=1e-12)
    assert np.all(r.boundary_tags[r.boundary_tags != HOLE] > 0)


def test_read_mesh_errors_are_input_errors(tmp_path):
    bad = tmp_path / "x.vtu"
    bad.write_text("not a mesh")
    with pytest.raises(InputError):
        read_mesh(bad)


def test_mesh_from_triangles_orients_and_finds_boundary():
    nodes = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)
    m = mesh_from_triangles(nodes, [[0, 2, 1], [0, 2, 3]])  # first one clockwise
    assert np.all(m.areas > 0)
    assert len(m.boundary_edges) == 4 and m.hole_radius is None
    r = rectangle_mesh(2.0, 1.0, 4, 2, jitter=0.2, seed=1)
    assert r.areas.sum() == pytest.approx(2.0)


def test_crack_strip_straddles_the_axis_from_wall_to_band_end():
    """mesh.band_strip: every strip triangle has nodes on both sides of the band axis, no
    node lies on the axis, and the strip is one chain of edge-sharing triangles from the
    hole wall (whose mouth edge the axis cuts in the middle) to the band's end."""
    import math

    band = FractureBand(0.0, 1.0, 0.4, 4.0, strip=True)
    mesh = borehole_mesh(size=12.0, radius=0.15, growth=1.5, h_wall=2 * math.pi * 0.15 / 12,
                         fracture_band=band)
    strip = np.flatnonzero(mesh.triangle_markers == 1)
    y = mesh.nodes[mesh.triangles[strip]][..., 1]
    assert np.all(y.max(axis=1) > 0) and np.all(y.min(axis=1) < 0)
    x = mesh.nodes[:, 0]
    on_axis = (np.abs(mesh.nodes[:, 1]) < 1e-9) & (np.abs(x) < 4.0)
    assert not on_axis.any()
    for wing in (1.0, -1.0):
        tri = strip[wing * mesh.centroids[strip, 0] > 0]
        tri = tri[np.argsort(wing * mesh.centroids[tri, 0])]
        # consecutive strip triangles share an edge (two nodes)
        for a, b in zip(tri[:-1], tri[1:]):
            assert len(set(mesh.triangles[a]) & set(mesh.triangles[b])) == 2
        first = mesh.nodes[mesh.triangles[tri[0]]]
        r = np.hypot(first[:, 0], first[:, 1])
        assert np.sum(np.isclose(r, 0.15)) == 2                  # the mouth wall edge
        # its two wall nodes mirror each other about the axis
        wall = first[np.isclose(r, 0.15)]
        assert wall[0, 0] == pytest.approx(wall[1, 0]) and wall[0, 1] == pytest.approx(
            -wall[1, 1])
        # 0.4 m spacing: the last strip triangle within one spacing of the band end
        assert wing * mesh.centroids[tri[-1], 0] > 4.0 - 0.4
