"""The binned engine of coherent bundles (scans, panoramas) against the hierarchy's
``cast_rays`` bit for bit, analytic truths, the hard directions and Open3D."""

import numpy as np
import pytest
import trimesh

import genie_gl as gg
from genie_gl.bench.lidar import agreement, open3d_cast, open3d_caster, scene_beams
from genie_gl.capture.scan import cast_beams
from genie_gl.render import bundles
from genie_gl.render.rays import Rays, cast_bundle, cast_rays, caster_of


def _generated(seed=0):
    """A floor of 2 m squares and 60 boxes, spheres and cylinders around the origin."""
    rng = np.random.default_rng(seed)
    scene = gg.Scene()
    n = 12
    xs, ys = np.meshgrid(np.linspace(-12, 12, n + 1), np.linspace(-12, 12, n + 1))
    v = np.c_[xs.ravel(), ys.ravel(), np.zeros(xs.size)]
    f = []
    for j in range(n):
        for i in range(n):
            a, b, c, d = (
                j * (n + 1) + i,
                j * (n + 1) + i + 1,
                (j + 1) * (n + 1) + i + 1,
                (j + 1) * (n + 1) + i,
            )
            f += [[a, b, c], [a, c, d]]
    scene.add(gg.Mesh(v, np.array(f)), np.eye(4), semantic=1)
    for k in range(60):
        shape = (
            trimesh.creation.box(rng.uniform(0.3, 2.0, 3)),
            trimesh.creation.icosphere(2, rng.uniform(0.2, 1.0)),
            trimesh.creation.cylinder(rng.uniform(0.1, 0.5), rng.uniform(0.5, 3.0)),
        )[k % 3]
        T = trimesh.transformations.random_rotation_matrix(rng.random(3))
        r, a = rng.uniform(2.5, 11.0), rng.uniform(-np.pi, np.pi)
        T[:3, 3] = [r * np.cos(a), r * np.sin(a), rng.uniform(0.0, 3.0)]
        scene.add(shape, T, semantic=2 + k % 3)
    return scene


@pytest.fixture(scope="module")
def scene():
    return _generated()


def _panorama(origin, azimuth, elevation):
    """(rays on an azimuth-elevation grid, their directions as given to the record): the
    record normalises them, and ``cast_rays`` of the same given directions must agree."""
    ce = np.cos(elevation)[:, None]
    d = np.stack(
        [
            ce * np.cos(azimuth)[None, :],
            ce * np.sin(azimuth)[None, :],
            np.broadcast_to(np.sin(elevation)[:, None], (len(elevation), len(azimuth))),
        ],
        axis=-1,
    ).reshape(-1, 3)
    return Rays(
        np.asarray(origin, float), d, "azimuth_elevation", (len(elevation), len(azimuth))
    ), d


def _same(a, b):
    """Distance, instance, face and normal equal bit for bit."""
    np.testing.assert_array_equal(a.distance, b.distance)
    np.testing.assert_array_equal(a.instance, b.instance)
    np.testing.assert_array_equal(a.face, b.face)
    np.testing.assert_array_equal(a.normal, b.normal)


@pytest.mark.parametrize("cluster", [1, bundles.CLUSTER])
@pytest.mark.parametrize("profile", ["velodyne_vlp16", "ouster_os1_128"])
def test_a_scan_equals_cast_rays_bit_for_bit(scene, profile, cluster, monkeypatch):
    """A VLP-16's and an OS1-128's revolution 1.8 m above the middle, cast as one bundle,
    gives the hierarchy's answer ray for ray, and most beams hit."""
    monkeypatch.setattr(bundles, "CLUSTER", cluster)
    beams = scene_beams(scene, gg.load_scanner(profile))
    ours = cast_beams(scene, beams.origins, beams.directions)
    _same(ours, cast_rays(scene, beams.origins, beams.directions))
    assert ours.hit.mean() > 0.5


def test_the_clusters_grow_with_the_scene_against_the_rays():
    assert bundles.cluster_size(87_608, 202_608) == bundles.CLUSTER  # many rays: the least
    assert bundles.cluster_size(971_312, 28_944) == 4 * bundles.CLUSTER
    assert bundles.cluster_size(9_604_272, 28_944) == 16 * bundles.CLUSTER
    assert bundles.cluster_size(10**9, 10) == 64 * bundles.CLUSTER  # the most
    assert bundles.cluster_size(1000, 100_000) == bundles.CLUSTER  # fewer triangles than rays


@pytest.mark.parametrize("per_cluster", [2_000, 100_000])
def test_a_scan_in_large_clusters_equals_cast_rays(scene, per_cluster, monkeypatch):
    """Few rays for the scene bin larger subtrees (here forced: 1 k and 16 k triangles)."""
    monkeypatch.setattr(bundles, "RAYS_PER_CLUSTER", per_cluster)
    beams = scene_beams(scene, gg.load_scanner("velodyne_vlp16"))
    triangles = caster_of(scene).triangles
    assert bundles.cluster_size(triangles, len(beams)) in (
        4 * bundles.CLUSTER,
        64 * bundles.CLUSTER,
    )
    _same(
        cast_beams(scene, beams.origins, beams.directions),
        cast_rays(scene, beams.origins, beams.directions),
    )


def test_a_panorama_with_its_poles_and_seam_equals_cast_rays(scene):
    """A 360 x 181 equirectangular panorama (elevations -90 to 90 degrees, azimuth -pi
    included): ``cast_rays`` of the record (the binned engine) equals the hierarchy's."""
    rays, d = _panorama(
        [0.4, -0.3, 1.5],
        np.linspace(-np.pi, np.pi, 360, endpoint=False),
        np.linspace(-np.pi / 2, np.pi / 2, 181),
    )
    ours = cast_rays(scene, rays)
    _same(ours, cast_rays(scene, rays.origins, d))
    assert ours.hit[
        : 360 * 81
    ].all()  # every ray 10 degrees or more below the horizon meets the floor (or an object)


@pytest.mark.parametrize("cluster", [1, bundles.CLUSTER])
def test_a_moving_head_equals_cast_rays(scene, cluster, monkeypatch):
    """Origins spread over a 0.4 m ball (a head moving during its sweep), random
    directions: the widened bins keep every hit."""
    monkeypatch.setattr(bundles, "CLUSTER", cluster)
    rng = np.random.default_rng(3)
    n = 20000
    o = np.array([1.0, 2.0, 1.2]) + rng.uniform(-0.23, 0.23, (n, 3))
    d = rng.normal(size=(n, 3))
    ours = cast_bundle(scene, Rays(o, d))
    _same(ours, cast_rays(scene, o, d))
    assert ours.hit.mean() > 0.4


def test_from_inside_a_box_and_a_sphere_the_analytic_distances():
    """From inside a turned 2 x 4 x 6 box every ray of a panorama meets a wall at the slab
    distance; from inside a sphere mesh of radius 2 every ray hits between the inscribed
    and the circumscribed radius, and a moving origin inside the box changes nothing."""
    T = trimesh.transformations.rotation_matrix(0.4, [1, 2, 3])
    T[:3, 3] = [5, -3, 1]
    scene = gg.Scene()
    iid = scene.add(trimesh.creation.box((2, 4, 6)), T)
    o_box = np.array([0.3, -0.5, 1.0])
    o = T[:3, :3] @ o_box + T[:3, 3]
    rays = Rays.azimuth_elevation(
        o, np.linspace(-np.pi, np.pi, 240, endpoint=False), np.linspace(-1.5, 1.5, 61)
    )
    h = cast_rays(scene, rays)
    db = rays.directions @ T[:3, :3]
    with np.errstate(divide="ignore"):
        t = np.min(
            np.where(
                db > 0, (np.array([1, 2, 3]) - o_box) / db, (-np.array([1, 2, 3]) - o_box) / db
            ),
            axis=1,
        )
    np.testing.assert_allclose(h.distance, t, rtol=1e-12)
    assert (h.instance == iid).all()
    sphere = gg.Scene()
    mesh = trimesh.creation.icosphere(3, 2.0)
    sphere.add(mesh, np.eye(4))
    inscribed = np.abs((mesh.triangles_center * mesh.face_normals).sum(axis=1)).min()
    o = np.array([0.1, 0.2, -0.3])
    rays, d = _panorama(
        o, np.linspace(-np.pi, np.pi, 200, endpoint=False), np.linspace(-np.pi / 2, np.pi / 2, 101)
    )
    hs = cast_rays(sphere, rays)
    off = np.linalg.norm(o)
    assert hs.hit.all() and inscribed > 1.98
    assert (hs.distance >= inscribed - off).all() and (hs.distance <= 2.0 + off).all()
    _same(hs, cast_rays(sphere, o, d))


@pytest.mark.parametrize("cluster", [1, bundles.CLUSTER])
def test_rays_through_shared_edges_and_vertices_are_never_lost(monkeypatch, cluster):
    """A 20 x 20 grid of unit squares cut in triangles, from a point above it: rays to
    every interior vertex and edge midpoint all hit at the exact distance, the ties going
    to the lower face as ``cast_rays`` sends them (binned by leaves or by clusters)."""
    monkeypatch.setattr(bundles, "CLUSTER", cluster)
    n = 20
    xs, ys = np.meshgrid(np.arange(n + 1.0), np.arange(n + 1.0))
    v = np.c_[xs.ravel() - 10, ys.ravel() - 10, np.zeros(xs.size)]
    f = []
    for j in range(n):
        for i in range(n):
            a, b, c, d = (
                j * (n + 1) + i,
                j * (n + 1) + i + 1,
                (j + 1) * (n + 1) + i + 1,
                (j + 1) * (n + 1) + i,
            )
            f += [[a, b, c], [a, c, d]]
    scene = gg.Scene()
    scene.add(gg.Mesh(v, np.array(f)), np.eye(4))
    g = np.arange(-9.5, 9.6, 0.5)
    targets = np.array([[x, y, 0.0] for x in g for y in g])
    origin = np.array([0.0, 0.0, 5.0])  # straight above a shared vertex: the pole of the grid
    h = cast_bundle(scene, Rays(origin, targets - origin))
    assert h.hit.all()
    np.testing.assert_allclose(h.distance, np.linalg.norm(targets - origin, axis=1), rtol=1e-14)
    _same(h, cast_rays(scene, origin, targets - origin))


def _fine(corners):
    """A triangle (3, 3) cut into 64."""
    v, f = np.array(corners, float), np.array([[0, 1, 2]])
    for _ in range(3):
        v, f = trimesh.remesh.subdivide(v, f)
    return gg.Mesh(v, f)


@pytest.mark.parametrize("cluster", [1, bundles.CLUSTER])
def test_triangles_over_the_seam_the_pole_and_next_to_the_origin(monkeypatch, cluster):
    """A triangle across azimuth +-pi, one over the pole, one 1 mm from the origin (each cut
    in 64, binned by the hierarchy's leaves or by its clusters): rays aimed at their insides
    hit them at the analytic distances, with the head still and with its origins spread
    over 5 cm."""
    monkeypatch.setattr(bundles, "CLUSTER", cluster)
    scene = gg.Scene()
    seam = scene.add(_fine([[-5.0, -1.0, -1.0], [-5.0, 1.0, -1.0], [-5.0, 0.0, 1.0]]), np.eye(4))
    pole = scene.add(_fine([[-1.0, -1.0, 3.0], [1.0, -1.0, 3.0], [0.0, 1.5, 3.0]]), np.eye(4))
    close = scene.add(
        _fine([[0.001, -0.5, -0.5], [0.001, 0.5, -0.5], [0.001, 0.0, 0.5]]), np.eye(4)
    )
    rng = np.random.default_rng(4)
    corners = (
        [[-5.0, -1.0, -1.0], [-5.0, 1.0, -1.0], [-5.0, 0.0, 1.0]],
        [[-1.0, -1.0, 3.0], [1.0, -1.0, 3.0], [0.0, 1.5, 3.0]],
        [[0.001, -0.5, -0.5], [0.001, 0.5, -0.5], [0.001, 0.0, 0.5]],
    )
    targets = np.concatenate([rng.dirichlet([1, 1, 1], 3000) @ np.array(c) for c in corners])
    want = np.repeat([seam, pole, close], 3000)
    for spread in (0.0, 0.05):
        o = rng.uniform(-spread / 2, spread / 2, (9000, 3))
        o[:, 0] = np.minimum(o[:, 0], 0.0)  # all behind the near triangle's plane x = 1 mm
        d = targets - o
        h = cast_bundle(scene, Rays(o, d))
        _same(h, cast_rays(scene, o, d))
        # a ray to the pole's triangle may first cross the near one, at its plane's distance
        crossed = h.instance == close
        dn = d / np.linalg.norm(d, axis=1, keepdims=True)
        assert (h.instance[~crossed] == want[~crossed]).all() and crossed[:3000].sum() == 0
        np.testing.assert_allclose(
            h.distance[~crossed], np.linalg.norm(d[~crossed], axis=1), rtol=1e-12
        )
        np.testing.assert_allclose(
            h.distance[crossed],
            (float(np.float32(0.001)) - o[crossed, 0]) / dn[crossed, 0],
            rtol=1e-9,
        )
        assert (h.instance == want).mean() > 0.8


def test_a_scan_agrees_with_open3d(scene):
    """Open3D's RaycastingScene on the same OS1-128 beams: ids agree on >= 99.99 % of
    rays, the ranges' p99 relative difference <= 1e-6."""
    beams = scene_beams(scene, gg.load_scanner("ouster_os1_128"))
    ours = cast_beams(scene, beams.origins, beams.directions)
    a = agreement(
        ours, open3d_cast(open3d_caster(scene, beams.origins[0]), beams.origins, beams.directions)
    )
    assert a["id_agree"] >= 0.9999 and a["hit_agree"] >= 0.9999
    assert a["range_rel_p99"] <= 1e-6


def test_an_empty_bundle_and_an_empty_scene():
    """No rays: an empty record; no triangles: every ray misses (distance 0, face -1)."""
    box = gg.Scene()
    box.add(trimesh.creation.box((1, 1, 1)), np.eye(4))
    assert len(cast_bundle(box, Rays(np.zeros(3), np.zeros((0, 3)))).distance) == 0
    h = cast_bundle(gg.Scene(), Rays(np.zeros(3), [[1.0, 0, 0], [0, 0, -1.0]]))
    assert not h.hit.any() and (h.face == -1).all() and (h.distance == 0).all()


def test_the_binned_azimuth_is_within_its_bound_of_the_arctangent():
    """The polynomial azimuth a ray is binned by lies within ``AZ_ERR`` of atan2 on every
    octant, the axes, the diagonals and both sides of the seam, and is 0 at (0, 0)."""
    rng = np.random.default_rng(7)
    t = np.concatenate(
        [rng.uniform(-np.pi, np.pi, 200_000), np.arange(-8, 9) * np.pi / 4, [np.pi - 1e-12]]
    )
    r = rng.uniform(1e-3, 1e3, len(t))
    x, y = r * np.cos(t), r * np.sin(t)
    got = np.array([bundles.azimuth(b, a) for a, b in zip(x, y)])
    err = np.abs(got - np.arctan2(y, x))
    err = np.minimum(err, 2 * np.pi - err)  # +-pi: the same direction
    assert err.max() <= bundles.AZ_ERR and err.max() > 1e-6  # a bound that is needed
    assert bundles.azimuth(0.0, 0.0) == 0.0


def test_a_ray_binned_across_a_column_edge_still_meets_its_triangle():
    """A sliver 7 urad wide ending 1 urad short of a column's edge, where the polynomial
    azimuth runs most ahead of the arctangent: rays aimed at its middle are binned in the
    next column, and still hit it (the clusters' spans are widened by the azimuth's bound;
    without that they miss)."""
    # a VLP-16-like band of rays: the grid they make, and its column edges
    az = np.linspace(-np.pi, np.pi, 1800, endpoint=False)
    el = np.radians(np.linspace(-15, 15, 16))
    _, d = _panorama([0.0, 0.0, 0.0], az, el)
    k = 64  # rays aimed at the sliver, at elevation 0 (inside the band: the grid is the same)
    lo, hi, n_el, n_az = bundles.grid_for(np.concatenate([d, np.tile([1.0, 0, 0], (k, 1))]))
    edges = -np.pi + 2 * np.pi * np.arange(1, n_az) / n_az
    aim = edges - 4e-6
    ahead = np.array([bundles.azimuth(np.sin(a), np.cos(a)) for a in aim]) - aim
    j = int(np.argmax(ahead))
    assert ahead[j] > 5e-6  # binned past the edge, in the next column
    a0, a1 = edges[j] - 8e-6, edges[j] - 1e-6
    r = 5.0
    sliver = np.array(
        [[r * np.cos(a0), r * np.sin(a0), -0.5], [r * np.cos(a1), r * np.sin(a1), -0.5],
         [r * np.cos(0.5 * (a0 + a1)), r * np.sin(0.5 * (a0 + a1)), 0.5]]
    )  # fmt: skip
    scene = gg.Scene()
    scene.add(gg.Mesh(sliver, np.array([[0, 1, 2]])), np.eye(4))
    aimed = np.tile([np.cos(aim[j]), np.sin(aim[j]), 0.0], (k, 1))
    aimed[:, 2] = np.linspace(-0.05, 0.05, k)  # within the sliver's middle
    dirs = np.concatenate([d, aimed])
    h = cast_bundle(scene, Rays(np.zeros(3), dirs))
    _same(h, cast_rays(scene, np.zeros(3), dirs))
    assert h.hit[-k:].all()
