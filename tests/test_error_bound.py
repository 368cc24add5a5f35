"""simplify(error="hausdorff"): the guaranteed two-sided error bound (docs/error-bound.md).

The bound is checked against what can be measured independently: evaluate()'s dense-sample
Hausdorff distance (a lower bound of the true one, so it may never exceed the guarantee),
surfaces whose distance is known in closed form (bumps of a known height on a plane, a
sphere), and the core's own geometric pieces against brute force."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import lodkit
from lodkit import Mesh, OptionError
from lodkit._core.bound import Bound, triangle_covering_radius
from lodkit._pipeline import prepare

# the core's own numbers agree to a few ulps; evaluate() measures in float32 (Open3D's
# raycasting): its distances are compared with EVAL_TOL of the diagonal to spare
REL_TOL = 1e-9
EVAL_TOL = 1e-6


def grid(n: int, z=None) -> Mesh:
    """An n x n vertex grid over the unit square, two triangles per cell; z heights (n, n)."""
    xs, ys = np.meshgrid(np.linspace(0.0, 1.0, n), np.linspace(0.0, 1.0, n), indexing="ij")
    zs = np.zeros_like(xs) if z is None else z
    v = np.stack([xs.ravel(), ys.ravel(), zs.ravel()], axis=1)
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    f = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    return Mesh(v, f.astype(np.int32))


def icosphere(level: int) -> Mesh:
    t = (1.0 + 5 ** 0.5) / 2.0
    v = np.array([[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t], [0, -1, -t],
                  [0, 1, -t], [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]], dtype=float)
    f = [[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4], [11, 10, 2],
         [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5], [2, 4, 11],
         [6, 2, 10], [8, 6, 7], [9, 8, 1]]
    verts = [tuple(x / np.linalg.norm(x)) for x in v]
    faces = [tuple(x) for x in f]
    for _ in range(level):
        index = {}
        new = []

        def mid(i, j):
            key = (min(i, j), max(i, j))
            if key not in index:
                m = np.add(verts[i], verts[j])
                verts.append(tuple(m / np.linalg.norm(m)))
                index[key] = len(verts) - 1
            return index[key]

        for a, b, c in faces:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            new += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        faces = new
    return Mesh(np.array(verts), np.array(faces, dtype=np.int32))


def hausdorff(original, result, samples=100_000):
    """evaluate()'s two-sided Hausdorff distance, in model units."""
    ev = lodkit.evaluate(original, result.mesh, samples=samples)
    return ev.distance.hausdorff * ev.diagonal


# ----------------------------------------------------------------- the core's pieces


def brute_distance(x, tris):
    """Distance from each point of x to the triangles (k, 9), by dense sampling of nothing:
    the exact formula, vectorised differently (projection, then edges)."""
    a, b, c = tris[:, 0:3], tris[:, 3:6], tris[:, 6:9]
    out = np.full(x.shape[0], np.inf)
    for i, p in enumerate(x):
        best = np.inf
        for t in range(tris.shape[0]):
            n = np.cross(b[t] - a[t], c[t] - a[t])
            nn = n @ n
            cands = []
            if nn > 0:
                q = p - ((p - a[t]) @ n) / nn * n
                # barycentric inside test
                v0, v1, v2 = b[t] - a[t], c[t] - a[t], q - a[t]
                d00, d01, d11, d20, d21 = v0 @ v0, v0 @ v1, v1 @ v1, v2 @ v0, v2 @ v1
                den = d00 * d11 - d01 * d01
                bv = (d11 * d20 - d01 * d21) / den
                bw = (d00 * d21 - d01 * d20) / den
                if bv >= 0 and bw >= 0 and bv + bw <= 1:
                    cands.append(np.linalg.norm(p - q))
            for s, e in ((a[t], b[t]), (b[t], c[t]), (c[t], a[t])):
                d = e - s
                u = np.clip((p - s) @ d / (d @ d), 0.0, 1.0)
                cands.append(np.linalg.norm(p - s - u * d))
            best = min(best, min(cands))
        out[i] = best
    return out


def core_bound(mesh: Mesh, eps: float, spacing: float = 0.25) -> tuple[Bound, np.ndarray]:
    prep = prepare(mesh)
    vdata = np.zeros((prep.positions.shape[0], 14))
    vdata[:, 11:] = prep.positions
    tris = prep.positions[np.asarray(prep.hm.corners)].reshape(-1, 9)
    return Bound(prep.hm, vdata, 11, eps, spacing), tris


def test_point_distance_matches_brute_force():
    rng = np.random.default_rng(1)
    mesh = grid(5, rng.uniform(0.0, 0.3, (5, 5)))
    b, tris = core_bound(mesh, 0.01)
    x = rng.uniform(-0.7, 0.7, (60, 3))
    np.testing.assert_allclose(b.distance(x), brute_distance(x, tris), rtol=1e-9, atol=1e-12)


def test_covering_radius_bounds_every_point():
    rng = np.random.default_rng(2)
    for _ in range(40):
        t = rng.normal(size=(3, 3))
        h = triangle_covering_radius(t.reshape(-1))
        w = rng.dirichlet([1, 1, 1], size=4000)
        pts = w @ t
        far = np.min(np.linalg.norm(pts[:, None, :] - t[None, :, :], axis=2), axis=1).max()
        longest = max(np.linalg.norm(t[i] - t[(i + 1) % 3]) for i in range(3))
        assert far <= h * (1 + REL_TOL)
        assert h <= longest / math.sqrt(3) * (1 + REL_TOL)


def test_face_certificate_is_an_upper_bound():
    """face_distance(t) certifies t: no point of t is farther from the original."""
    rng = np.random.default_rng(3)
    mesh = grid(9, 0.05 * rng.uniform(size=(9, 9)))
    b, tris = core_bound(mesh, 0.04)
    checked = 0
    for _ in range(30):
        t = rng.uniform(-0.4, 0.4, (3, 3))
        t[:, 2] = rng.uniform(-0.02, 0.05, 3)
        cert = b.face_distance(t.reshape(-1))
        if cert < 0:
            continue
        w = rng.dirichlet([1, 1, 1], size=300)
        true = b.distance(w @ t).max()
        assert true <= cert * (1 + REL_TOL) + 1e-15
        assert cert <= b.eps * (1 + REL_TOL)
        checked += 1
    assert checked > 0


def test_face_certificate_across_a_ridge():
    """Triangles across the ridge of a roof whose two slopes are single input triangles
    near them: certified (two triangles sharing an edge, each for its side of the plane
    between them), and never below their true distance."""
    x, y = np.meshgrid(np.linspace(0.0, 1.0, 3), np.linspace(0.0, 1.0, 3), indexing="ij")
    mesh = grid(3, 0.3 * (0.5 - np.abs(x - 0.5)))
    b, _ = core_bound(mesh, 0.03)
    rng = np.random.default_rng(7)
    prep = prepare(mesh)
    ridge_z = prep.positions[:, 2].max()
    lo, hi = prep.positions.min(0), prep.positions.max(0)
    mid = 0.5 * (lo + hi)
    checked = 0
    for _ in range(60):
        t = np.empty((3, 3))
        t[:, 0] = mid[0] + rng.uniform(-0.15, 0.15, 3) * (hi[0] - lo[0])
        t[:, 1] = mid[1] + rng.uniform(-0.3, 0.3, 3) * (hi[1] - lo[1])
        t[:, 2] = ridge_z + rng.uniform(-1.0, 0.8, 3) * b.eps
        cert = b.face_distance(t.reshape(-1))
        if cert < 0:
            continue
        w = rng.dirichlet([1, 1, 1], size=2000)
        assert b.distance(w @ t).max() <= cert * (1 + REL_TOL) + 1e-15
        assert cert <= b.eps * (1 + REL_TOL)
        checked += 1
    assert checked >= 20


def patch_setup(mesh: Mesh, eps: float):
    """core_bound, the input's normalised box and a sampler of triangles over it."""
    b, tris = core_bound(mesh, eps)
    pos = prepare(mesh).positions
    return b, tris, pos.min(0), pos.max(0)


def assert_certifies(b: Bound, t: np.ndarray, cert: float, rng) -> None:
    w = rng.dirichlet([1, 1, 1], size=3000)
    pts = np.concatenate([w @ t, t, 0.5 * (t + np.roll(t, 1, axis=0))])
    assert b.distance(pts).max() <= cert * (1 + REL_TOL) + 1e-15
    assert cert <= b.eps * (1 + REL_TOL)


def test_flat_patch_certificate_over_a_plane():
    """A triangle over many small input triangles of a plane, at height z below eps, is
    certified whole by the flat patch under it, at z (and the margins' slack); one that
    reaches past the plane's border is not."""
    eps = 0.02
    b, _, lo, hi = patch_setup(grid(17), eps)
    rng = np.random.default_rng(11)
    z0 = lo[2]
    certified = 0
    for _ in range(40):
        t = np.empty((3, 3))
        t[:, :2] = lo[:2] + rng.uniform(0.05, 0.95, (3, 2)) * (hi[:2] - lo[:2])
        z = rng.uniform(-0.9, 0.9) * eps
        t[:, 2] = z0 + z
        area = 0.5 * abs(np.cross(t[1] - t[0], t[2] - t[0])[2])
        if area < 0.01:
            continue                                # a sliver: not what this is about
        cert = b.patch_distance(t.reshape(-1))
        assert cert >= 0.0
        assert abs(cert - abs(z)) < 1e-7
        assert_certifies(b, t, cert, rng)
        assert 0.0 <= b.face_distance(t.reshape(-1)) <= cert + 1e-12
        certified += 1
    assert certified >= 20
    # past the border: the border edges cross its projection
    t = np.array([[lo[0] - 0.05, lo[1] + 0.2, z0], [hi[0] - 0.2, lo[1] + 0.1, z0], [lo[0] + 0.3, hi[1] - 0.1, z0]])
    assert b.patch_distance(t.reshape(-1)) < 0.0


def test_flat_patch_certificate_not_over_a_hole():
    """A plane with a square hole: a triangle over the hole gets no patch certificate (the
    hole's border crosses it); one beside it does."""
    n = 13
    mesh = grid(n)
    idx = np.arange(n * n).reshape(n, n)
    hole = set(idx[5:7, 5:7].ravel())       # faces whose first corner is in the middle cells
    keep = [i for i, f in enumerate(mesh.faces) if f[0] not in hole]
    mesh = Mesh(mesh.vertices, mesh.faces[keep])
    eps = 0.05
    b, _, lo, hi = patch_setup(mesh, eps)
    span = hi - lo
    z0 = lo[2]
    over = np.array([[0.3, 0.3, 0.0], [0.7, 0.35, 0.0], [0.45, 0.7, 0.0]])
    beside = np.array([[0.05, 0.05, 0.0], [0.35, 0.05, 0.0], [0.05, 0.35, 0.0]])
    for t, ok in ((over, False), (beside, True)):
        t = lo + t * np.array([span[0], span[1], 0.0])
        t[:, 2] = z0 + 0.2 * eps
        cert = b.patch_distance(t.reshape(-1))
        assert (cert >= 0.0) == ok
        if ok:
            assert_certifies(b, t, cert, np.random.default_rng(5))


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, 2**31 - 1))
def test_flat_patch_certificate_is_an_upper_bound(seed):
    """On bumpy planes (with a hole at times), tilted triangles near them: a patch
    certificate is never below their true distance."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(6, 14))
    eps = 0.04
    z = rng.uniform(0.0, 0.5, (n, n)) * eps * rng.choice([0.0, 0.5, 1.0, 3.0])
    mesh = grid(n, z)
    if rng.uniform() < 0.4:
        drop = rng.choice(mesh.n_faces, size=int(rng.integers(1, 4)), replace=False)
        mesh = Mesh(mesh.vertices, np.delete(mesh.faces, drop, axis=0))
    b, _, lo, hi = patch_setup(mesh, eps)
    for _ in range(10):
        t = lo + rng.uniform(0.0, 1.0, (3, 3)) * (hi - lo)
        t[:, 2] = rng.uniform(lo[2] - eps, hi[2] + eps, 3)
        cert = b.patch_distance(t.reshape(-1))
        if cert >= 0.0:
            assert_certifies(b, t, cert, rng)


# ----------------------------------------------------------------- known distances


@pytest.mark.parametrize("driver", ["pass", "greedy"])
def test_plane_bumps_reach_the_bound(driver):
    """A flat 33 x 33 grid with nine single-vertex bumps of height 0.02: a bound above the
    height (with the samples' slack) flattens every bump -- the distance is then exactly the
    height, at the apexes; one below keeps them, and the measured distance stays under it."""
    n, height = 33, 0.02
    z = np.zeros((n, n))
    for i in (8, 16, 24):
        for j in (8, 16, 24):
            z[i, j] = height
    mesh = grid(n, z)
    # the samples of the original need eps - spacing * eps to spare: 1.25 h - 0.1 * 1.25 h > h
    above = lodkit.simplify(mesh, max_error=1.25 * height, absolute=True, error="hausdorff", driver=driver,
                            boundary="lock", sample_spacing=0.1, placement="endpoint")
    h_above = hausdorff(mesh, above)
    assert above.bound.absolute <= 1.25 * height * (1 + REL_TOL)
    diag = float(np.linalg.norm(mesh.vertices.max(0) - mesh.vertices.min(0)))
    assert h_above <= above.bound.absolute * (1 + REL_TOL) + EVAL_TOL * diag
    # every bump is gone: the result is flat, each apex exactly `height` from it (the
    # bound is reached; evaluate's random samples come near the apexes only)
    assert np.abs(above.mesh.vertices[:, 2]).max() <= 1e-12
    apex = mesh.vertices[np.abs(mesh.vertices[:, 2] - height) < 1e-12]
    out = above.mesh
    d = brute_distance(apex, out.vertices[out.faces].reshape(-1, 9))
    np.testing.assert_allclose(d, height, rtol=1e-9)
    assert d.max() <= above.bound.absolute * (1 + REL_TOL)
    assert h_above >= 0.8 * height
    # below the height, placed at the ends like the run above: the bumps stay, so it stops
    # with more faces, and what stopped it is the bound (the bumps): the stop reason says so
    below = lodkit.simplify(mesh, max_error=0.8 * height, absolute=True, error="hausdorff", driver=driver,
                            boundary="lock", placement="endpoint")
    h_below = hausdorff(mesh, below)
    assert h_below <= below.bound.absolute * (1 + REL_TOL) + EVAL_TOL * diag
    assert below.bound.absolute <= 0.8 * height * (1 + REL_TOL)
    assert below.mesh.n_faces > above.mesh.n_faces
    assert below.stop_reason == "max_error"
    assert "max_error" in below.report["stop_detail"]
    # optimal placement, with the end / midpoint fallback once nothing planned fits: the
    # bumps may be lowered, by no more than the bound
    lowered = lodkit.simplify(mesh, max_error=0.8 * height, absolute=True, error="hausdorff", driver=driver,
                              boundary="lock")
    assert hausdorff(mesh, lowered) <= lowered.bound.absolute * (1 + REL_TOL) + EVAL_TOL * diag
    assert lowered.mesh.vertices[:, 2].max() >= height - lowered.bound.absolute * (1 + REL_TOL)
    assert lowered.mesh.n_faces <= below.mesh.n_faces


@pytest.mark.parametrize("eps", [0.01, 0.03])
def test_sphere_analytic_distance(eps):
    """An icosphere (5120 faces) approximates the unit sphere to within delta0 (at its faces'
    centres); the simplified mesh, within eps of the icosphere, is within eps + delta0 of the
    sphere -- measured in closed form, | |y| - 1 |, both ways."""
    mesh = icosphere(4)
    v, f = mesh.vertices, mesh.faces
    # the farthest a face gets from the sphere: its plane's distance to the centre
    n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    plane = np.abs(np.einsum("ij,ij->i", n / np.linalg.norm(n, axis=1, keepdims=True), v[f[:, 0]]))
    delta0 = float(1.0 - plane.min())
    assert delta0 < 0.01
    res = lodkit.simplify(mesh, max_error=eps, absolute=True, error="hausdorff")
    assert res.bound.absolute <= eps * (1 + REL_TOL)
    assert res.mesh.n_faces < mesh.n_faces // 4
    out = res.mesh
    rng = np.random.default_rng(4)
    w = rng.dirichlet([1, 1, 1], size=(out.n_faces, 40))
    pts = np.einsum("fsk,fkd->fsd", w, out.vertices[out.faces]).reshape(-1, 3)
    pts = np.concatenate([pts, out.vertices])
    assert np.abs(np.linalg.norm(pts, axis=1) - 1.0).max() <= res.bound.absolute + delta0 + 1e-12
    # and evaluate()'s measure of the two meshes, both ways
    ev = lodkit.evaluate(mesh, out, samples=50_000)
    assert ev.distance.hausdorff <= res.bound.relative * (1 + REL_TOL) + EVAL_TOL


def bump(n: int, height: float) -> Mesh:
    """An n x n grid over the unit square, flat but for its middle vertex at ``height``."""
    z = np.zeros((n, n))
    z[n // 2, n // 2] = height
    return grid(n, z)


@pytest.mark.parametrize("n, height", [(9, 0.01), (65, 0.1)])
def test_bump_flattened_just_above_its_height(n, height):
    """A single-vertex bump, on triangles 12 to 17 times longer than eps (n=9: the input's
    triangles split where the output's edges cross them) or 5 to 7 times shorter (n=65:
    whole triangles suffice).  Input triangles need no slack: a bound 2 % above the height
    flattens the bump -- the apex is then the height away, so the bound is all but reached
    -- and one 2 % below does not (it may lower it, by less than the bound)."""
    mesh = bump(n, height)
    diag = float(np.linalg.norm(mesh.vertices.max(0) - mesh.vertices.min(0)))
    above = lodkit.simplify(mesh, max_error=1.02 * height, absolute=True, error="hausdorff", boundary="lock")
    assert above.bound.absolute <= 1.02 * height * (1 + REL_TOL)
    assert np.abs(above.mesh.vertices[:, 2]).max() <= 1e-3 * height
    h_above = hausdorff(mesh, above)
    assert 0.95 * height <= h_above <= above.bound.absolute * (1 + REL_TOL) + EVAL_TOL * diag
    if n == 9:
        assert above.report["error_bound"]["pieces"] > mesh.n_faces
    else:
        assert above.report["error_bound"]["pieces"] == mesh.n_faces
    below = lodkit.simplify(mesh, max_error=0.98 * height, absolute=True, error="hausdorff", boundary="lock")
    assert below.bound.absolute <= 0.98 * height * (1 + REL_TOL)
    # lowered (an end or midpoint may stay within the bound), by no more than the bound
    assert below.mesh.vertices[:, 2].max() >= height - below.bound.absolute * (1 + REL_TOL)
    assert hausdorff(mesh, below) <= below.bound.absolute * (1 + REL_TOL) + EVAL_TOL * diag


def keep_collapsers(monkeypatch) -> list:
    """The EdgeCollapsers simplify() builds from now on, kept: their Bound stays readable
    after the run."""
    import lodkit.drivers.edge as edge_driver

    made = []
    build = edge_driver.EdgeCollapser

    def keep(*args, **kwargs):
        made.append(build(*args, **kwargs))
        return made[-1]

    monkeypatch.setattr(edge_driver, "EdgeCollapser", keep)
    return made


def triangle_areas(t):
    return 0.5 * np.linalg.norm(np.cross(t[:, 3:6] - t[:, 0:3], t[:, 6:9] - t[:, 0:3]), axis=1)


@pytest.mark.parametrize("eps", [0.004, 0.02])
def test_pieces_tile_the_input_within_their_faces(monkeypatch, eps):
    """After a run the pieces of the input cover it exactly (their areas add up to its
    area), each is on a live face (none is left on a face a collapse removed) and lies
    within its face's certificate of that face, at its corners and so everywhere
    (convexity)."""
    rng = np.random.default_rng(6)
    mesh = grid(12, 0.04 * rng.uniform(size=(12, 12)))
    made = keep_collapsers(monkeypatch)
    res = lodkit.simplify(mesh, max_error=eps, error="hausdorff", threads=1)
    b = made[-1].bound
    pieces, faces, cert, alive = b.pieces()
    assert len(pieces) == b.n_pieces == res.report["error_bound"]["pieces"]
    assert alive.all()
    prep = prepare(mesh)
    tris = prep.positions[np.asarray(prep.hm.corners)].reshape(-1, 9)
    np.testing.assert_allclose(triangle_areas(pieces).sum(), triangle_areas(tris).sum(), rtol=1e-12)
    assert cert.max() <= b.eps * (1 + REL_TOL)
    for corner in range(3):
        d = np.array([brute_distance(p[None, 3 * corner:3 * corner + 3], f[None])[0] for p, f in zip(pieces, faces)])
        assert np.all(d <= cert * (1 + REL_TOL) + 1e-15)


@pytest.mark.parametrize("eps", [0.004, 0.02])
def test_faces_within_their_certificate(monkeypatch, eps):
    """After a run every live face's points are within the distance it is certified for
    (mostly taken over from the face in its slot before a collapse plus how far the moved
    end went, in chains of such steps): dense samples of each face, measured exactly."""
    rng = np.random.default_rng(8)
    mesh = grid(12, 0.04 * rng.uniform(size=(12, 12)))
    made = keep_collapsers(monkeypatch)
    res = lodkit.simplify(mesh, max_error=eps, error="hausdorff", threads=1)
    assert res.mesh.n_faces < mesh.n_faces
    b = made[-1].bound
    faces, own, cert = b.face_certificates()
    assert np.all(own <= cert) and cert.max() <= b.eps * (1 + REL_TOL)
    assert np.any(own > 0.0)
    n = 12
    w = np.array([(i, j, n - i - j) for i in range(n + 1) for j in range(n + 1 - i)], dtype=float) / n
    for t, c in zip(faces, own):
        x = w @ t.reshape(3, 3)
        assert np.all(b.distance(x) <= c * (1 + REL_TOL) + 1e-15)


def test_too_many_pieces(monkeypatch):
    """More pieces than MAX_PIECES: an OptionError, before the run when the input's own
    triangles are too many, after it when splitting them needed more."""
    import lodkit._core.bound as bound_module

    mesh = bump(9, 0.05)
    monkeypatch.setattr(bound_module, "MAX_PIECES", 100)
    with pytest.raises(OptionError, match="at most 100 triangles"):
        lodkit.simplify(mesh, max_error=0.005, error="hausdorff")
    monkeypatch.setattr(bound_module, "MAX_PIECES", 140)
    with pytest.raises(OptionError, match="pieces of the input"):
        lodkit.simplify(mesh, max_error=0.005, error="hausdorff")


# ----------------------------------------------------------------- property tests


@st.composite
def small_meshes(draw):
    kind = draw(st.sampled_from(["terrain", "blob"]))
    seed = draw(st.integers(0, 2**31 - 1))
    rng = np.random.default_rng(seed)
    if kind == "terrain":
        n = draw(st.integers(5, 14))
        amp = draw(st.floats(0.0, 0.3))
        return grid(n, amp * rng.uniform(size=(n, n)))
    sphere = icosphere(draw(st.integers(1, 3)))
    noise = draw(st.floats(0.0, 0.15))
    v = sphere.vertices * (1.0 + noise * rng.uniform(-1, 1, (sphere.n_vertices, 1)))
    return Mesh(v, sphere.faces)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(mesh=small_meshes(), eps=st.floats(0.002, 0.1), driver=st.sampled_from(["pass", "greedy"]),
       placement=st.sampled_from(["optimal", "endpoint"]), spacing=st.sampled_from([0.1, 0.25, 0.6]))
def test_evaluate_never_exceeds_the_bound(mesh, eps, driver, placement, spacing):
    res = lodkit.simplify(mesh, max_error=eps, error="hausdorff", driver=driver, placement=placement,
                          sample_spacing=spacing, record=True)
    assert res.bound is not None
    assert res.bound.relative <= eps * (1 + REL_TOL)
    ev = lodkit.evaluate(mesh, res.mesh, samples=20_000)
    assert ev.distance.hausdorff <= res.bound.relative * (1 + REL_TOL) + EVAL_TOL
    # the records' running bound ends at (or above) the result's certificate
    if res.n_collapses:
        steps = res.collapses["bound"]
        assert np.all(np.diff(steps) >= 0)
        assert steps[-1] >= res.bound.relative * (1 - REL_TOL)


# ----------------------------------------------------------------- options and reports


def test_pass_driver_same_output_for_any_thread_count(monkeypatch):
    import lodkit.drivers.edge as edge_driver

    monkeypatch.setattr(edge_driver, "PASS_MIN_PARALLEL", 0)     # a small mesh: on threads all the same
    rng = np.random.default_rng(5)
    mesh = grid(40, 0.05 * rng.uniform(size=(40, 40)))
    outs = [lodkit.simplify(mesh, max_error=0.01, error="hausdorff", threads=t) for t in (1, 2, 4)]
    for o in outs[1:]:
        np.testing.assert_array_equal(o.mesh.faces, outs[0].mesh.faces)
        np.testing.assert_array_equal(o.mesh.vertices, outs[0].mesh.vertices)
        assert o.bound == outs[0].bound


def test_off_by_default_and_options():
    mesh = grid(8)
    plain = lodkit.simplify(mesh, target_faces=10)
    assert plain.bound is None
    assert "error" not in plain.report["settings"]
    res = lodkit.simplify(mesh, max_error=0.01, error="hausdorff")
    assert res.report["settings"]["error"]["value"] == "hausdorff"
    assert res.report["error_bound"]["pieces"] > 0
    with pytest.raises(OptionError, match="needs max_error"):
        lodkit.simplify(mesh, target_faces=10, error="hausdorff")
    with pytest.raises(OptionError, match="error must be one of"):
        lodkit.simplify(mesh, max_error=0.1, error="metro")
    with pytest.raises(OptionError, match="triangle"):
        lodkit.simplify(mesh, max_error=0.1, error="hausdorff", operator="triangle")
    with pytest.raises(OptionError, match="vertex removal"):
        lodkit.simplify(mesh, max_error=0.1, error="hausdorff", metric="schroeder")
    with pytest.raises(OptionError, match="sample_spacing"):
        lodkit.simplify(mesh, max_error=0.1, error="hausdorff", sample_spacing=1.5)
    with pytest.raises(OptionError, match="sample_spacing"):
        lodkit.simplify(mesh, max_error=0.1, sample_spacing=0.5)


def test_target_reached_first_and_zero_bound():
    mesh = grid(12)                                    # flat: everything within any bound
    res = lodkit.simplify(mesh, target_faces=50, max_error=0.01, error="hausdorff")
    assert res.stop_reason == "target_faces"
    assert res.mesh.n_faces <= 50
    assert res.bound.relative <= 0.01 * (1 + REL_TOL)
    assert hausdorff(mesh, res) <= 1e-5            # evaluate() measures in float32 (Open3D)
    # max_error=0: nothing may move the surface (the samples leave no room): no collapse
    zero = lodkit.simplify(grid(6, np.random.default_rng(0).uniform(size=(6, 6))), max_error=0.0,
                           error="hausdorff")
    assert zero.n_collapses == 0
    assert zero.bound.absolute == pytest.approx(0.0, abs=1e-15)
    assert zero.stop_reason == "max_error"


# ----------------------------------------------------------------- progressive meshes


@pytest.mark.parametrize("driver", ["pass", "greedy"])
def test_progressive_cut_at_a_guaranteed_distance(tmp_path, driver):
    rng = np.random.default_rng(6)
    mesh = grid(24, 0.08 * rng.uniform(size=(24, 24)))
    eps = 0.02
    pm = lodkit.progressive(mesh, max_error=eps, error="hausdorff", driver=driver)
    assert pm.bounds_per_step is not None and np.all(np.diff(pm.bounds_per_step) >= 0)
    faces = []
    for x in (eps / 8, eps / 4, eps / 2, eps):
        s = pm.step_for(bound=x)
        level = pm.level(bound=x)
        assert pm.bounds_per_step[s] <= x
        ev = lodkit.evaluate(mesh, level.mesh, samples=30_000)
        assert ev.distance.hausdorff <= x * (1 + REL_TOL) + EVAL_TOL
        faces.append(level.n_faces)
    assert faces == sorted(faces, reverse=True) and faces[0] > faces[-1]
    # the whole run is the cut at eps
    full = lodkit.simplify(mesh, max_error=eps, error="hausdorff", driver=driver)
    assert pm.at(bound=eps).n_faces == full.mesh.n_faces
    path = tmp_path / "pm.npz"
    pm.save(path)
    back = lodkit.ProgressiveMesh.load(path)
    np.testing.assert_array_equal(back.bounds_per_step, pm.bounds_per_step)
    assert back.step_for(bound=eps / 2) == pm.step_for(bound=eps / 2)


def test_progressive_bound_needs_hausdorff():
    pm = lodkit.progressive(grid(8, np.random.default_rng(0).uniform(size=(8, 8)) * 0.1))
    assert pm.bounds_per_step is None
    with pytest.raises(OptionError, match="hausdorff"):
        pm.at(bound=0.1)
    pmh = lodkit.progressive(grid(8), max_error=0.01, error="hausdorff")
    with pytest.raises(OptionError, match="bound must be"):
        pmh.at(bound=-1.0)
    with pytest.raises(OptionError, match="exactly one"):
        pmh.at(bound=0.1, faces=3)


# ----------------------------------------------------------------- the command line


@pytest.mark.parametrize("given, absolute, expect", [
    ("0.5%", False, 0.005),          # percent of the diagonal, reported relative
    ("0.01", True, 0.01),            # model units, reported in model units
    ("0.5%", True, "diag"),          # percent, reported in model units: converted
    ("0.01", False, "rel"),          # model units, reported relative: converted
])
def test_cli_max_distance(tmp_path, capsys, given, absolute, expect):
    from lodkit.cli import main

    mesh = grid(16, 0.1 * np.random.default_rng(7).uniform(size=(16, 16)))
    src, out = tmp_path / "in.ply", tmp_path / "out.ply"
    lodkit.save(mesh, src)
    argv = ["simplify", str(src), str(out), "--max-distance", given] + (["--absolute"] if absolute else [])
    assert main(argv) == 0
    line = capsys.readouterr().out
    assert "both ways" in line and "stop: max_error" in line
    diag = float(np.linalg.norm(mesh.vertices.max(0) - mesh.vertices.min(0)))
    limit = {0.005: 0.005 * diag, 0.01: 0.01, "diag": 0.005 * diag, "rel": 0.01}[expect]
    ev = lodkit.evaluate(mesh, lodkit.load(out), samples=30_000)
    assert ev.distance.hausdorff * diag <= limit * (1 + REL_TOL) + EVAL_TOL * diag


def test_cli_max_distance_usage(tmp_path, capsys):
    from lodkit.cli import main

    src = tmp_path / "in.ply"
    lodkit.save(grid(6), src)
    assert main(["simplify", str(src), str(tmp_path / "o.ply"), "--max-distance", "1%", "--max-error", "0.1"]) != 0
    assert "not both" in capsys.readouterr().err
    assert main(["simplify", str(src), str(tmp_path / "o.ply"), "--max-distance", "x%"]) != 0


# ----------------------------------------------------------------- metrics and seams


@pytest.mark.parametrize("metric", ["qem_native", "curvature", "appearance"])
def test_other_metrics_and_seams(metric):
    """Native kernels (the pass driver's one-thread mode) and attribute quadrics, on a mesh
    with uv seams (their pairs collapse together, both checked before either is done)."""
    from conftest import shared_mesh

    mesh = lodkit.load(shared_mesh("spot_triangulated.obj"))
    res = lodkit.simplify(mesh, max_error=0.01, error="hausdorff", metric=metric)
    assert res.report["seams"]["pair_collapses"] > 0
    assert res.mesh.n_faces < mesh.n_faces // 4
    assert res.stop_reason == "max_error"
    ev = lodkit.evaluate(mesh, res.mesh, samples=30_000)
    assert ev.distance.hausdorff <= res.bound.relative * (1 + REL_TOL) + EVAL_TOL
