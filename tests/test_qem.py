"""Quadric error metrics: a slow pure-numpy Garland-Heckbert reference against
``vertex_quadrics`` and ``EdgeCollapser.plan_edge``, and exact answers on tiny meshes.

Quadric layout (columns): a11 a12 a13 a22 a23 a33 b1 b2 b3 c w, for
Q(p) = p^T A p + 2 b^T p + c, w = summed area of the faces it stands for.
"""
from __future__ import annotations

import numpy as np
import pytest

import lodkit
from lodkit._core.decimate import EdgeCollapser, vertex_quadrics
from lodkit._core.halfedge import build

OPTIMAL, ENDPOINT = 0, 1
LOCK, PRESERVE, FREE = 0, 1, 2


# ---------------------------------------------------------------------- meshes
def grid_mesh(nx: int, ny: int, z=None):
    """An nx x ny grid of unit quads in the plane z = 0 (or heights ``z``), faces
    counter-clockwise from +z, diagonals alternating."""
    xs, ys = np.meshgrid(np.arange(nx + 1, dtype=float), np.arange(ny + 1, dtype=float))
    vertices = np.stack([xs.ravel(), ys.ravel(), np.zeros(xs.size)], axis=1)
    if z is not None:
        vertices[:, 2] = z(vertices[:, 0], vertices[:, 1])
    faces = []
    for j in range(ny):
        for i in range(nx):
            a = j * (nx + 1) + i
            b, c, d = a + 1, a + nx + 2, a + nx + 1
            faces += [[a, b, c], [a, c, d]] if (i + j) % 2 == 0 else [[a, b, d], [b, c, d]]
    return vertices, np.array(faces)


def bumpy_grid():
    rng = np.random.default_rng(7)
    v, f = grid_mesh(6, 5, z=lambda x, y: 0.4 * np.sin(x) * np.cos(0.7 * y))
    v[:, 2] += rng.normal(0.0, 0.05, len(v))
    return v, f


def uv_sphere(n_lon: int = 10, n_lat: int = 6, jitter: float = 0.03, seed: int = 3, uniform: bool = False):
    """A closed UV sphere: poles 0 and 1, then n_lat - 1 rings of n_lon vertices, radii
    jittered by a normal (or, with ``uniform``, a uniform +-jitter) factor."""
    rng = np.random.default_rng(seed)
    verts = [[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]]
    for j in range(1, n_lat):
        theta = np.pi * j / n_lat
        for i in range(n_lon):
            phi = 2 * np.pi * i / n_lon
            verts.append([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)])
    noise = rng.uniform(-jitter, jitter, (len(verts), 1)) if uniform else jitter * rng.standard_normal((len(verts), 1))
    verts = np.array(verts) * (1.0 + noise)
    ring = lambda j, i: 2 + j * n_lon + i % n_lon  # noqa: E731
    faces = []
    for i in range(n_lon):
        faces.append([0, ring(0, i), ring(0, i + 1)])
        faces.append([1, ring(n_lat - 2, i + 1), ring(n_lat - 2, i)])
    for j in range(n_lat - 2):
        for i in range(n_lon):
            a, b, c, d = ring(j, i), ring(j + 1, i), ring(j + 1, i + 1), ring(j, i + 1)
            faces += [[a, b, c], [a, c, d]]
    return verts, np.array(faces)


CUBE_VERTICES = np.array([[x, y, z] for x in (0.0, 1.0) for y in (0.0, 1.0) for z in (0.0, 1.0)])
CUBE_FACES = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                       [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])


def subdivided_cube(n: int):
    """The unit cube with every side an n x n grid of quads (two triangles each), welded."""
    index, verts, faces = {}, [], []

    def vid(p):
        key = tuple(int(round(c * n)) for c in p)
        if key not in index:
            index[key] = len(verts)
            verts.append([k / n for k in key])
        return index[key]

    for axis in range(3):
        u, w = [a for a in range(3) if a != axis]
        for side in (0, 1):
            # (u, w, axis) cyclic => u x w = +axis; flip where the outward normal is -axis
            outward_positive = (axis, u, w) in [(0, 1, 2), (1, 2, 0), (2, 0, 1)]
            flip = (side == 1) != outward_positive
            for i in range(n):
                for j in range(n):
                    def corner(a, b):
                        p = [0.0, 0.0, 0.0]
                        p[axis], p[u], p[w] = side, a / n, b / n
                        return vid(p)
                    q = [corner(i, j), corner(i + 1, j), corner(i + 1, j + 1), corner(i, j + 1)]
                    tris = [[q[0], q[1], q[2]], [q[0], q[2], q[3]]] if (i + j) % 2 == 0 else \
                           [[q[0], q[1], q[3]], [q[1], q[2], q[3]]]
                    faces += [t[::-1] for t in tris] if flip else tris
    return np.array(verts), np.array(faces)


TETRA_VERTICES = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
TETRA_FACES = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])

MESHES = {
    "bumpy_grid": bumpy_grid,
    "sphere": uv_sphere,
    "cube": lambda: (CUBE_VERTICES.copy(), CUBE_FACES.copy()),
    "cube3": lambda: subdivided_cube(3),
    "flat_grid": lambda: grid_mesh(4, 3),
}


def test_test_meshes_are_what_they_claim():
    for name, make in MESHES.items():
        v, f = make()
        report = lodkit.topology(lodkit.Mesh(v, f))
        assert report.is_manifold and report.is_oriented, name
        closed = name in ("sphere", "cube", "cube3")
        assert report.is_closed == closed, name
        assert report.genus == 0, name
        if closed:       # outward normals: positive signed volume
            a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
            assert np.einsum("ij,ij->i", a, np.cross(b, c)).sum() > 0, name


# ---------------------------------------------------------------------- the reference
def plane_row(n, d, weight):
    return weight * np.array([n[0] * n[0], n[0] * n[1], n[0] * n[2], n[1] * n[1], n[1] * n[2],
                              n[2] * n[2], d * n[0], d * n[1], d * n[2], d * d])


def boundary_halfedges(faces):
    """(face, a, b) for every half-edge a -> b whose edge has no other face."""
    count = {}
    for f in faces:
        for k in range(3):
            key = frozenset((int(f[k]), int(f[(k + 1) % 3])))
            count[key] = count.get(key, 0) + 1
    return [(i, int(f[k]), int(f[(k + 1) % 3])) for i, f in enumerate(faces) for k in range(3)
            if count[frozenset((int(f[k]), int(f[(k + 1) % 3])))] == 1]


def reference_quadrics(vertices, faces, boundary_weight=0.0):
    """Garland-Heckbert: each face adds area * (n n^T, d n, d^2) of its plane (unit normal n,
    n.p + d = 0) to its three vertices; w sums the areas.  Each boundary edge adds the plane
    through it perpendicular to its face, weighted boundary_weight * |e|^2, to both ends."""
    q = np.zeros((len(vertices), 11))
    normals = {}
    for i, (a, b, c) in enumerate(faces):
        cross = np.cross(vertices[b] - vertices[a], vertices[c] - vertices[a])
        length = np.linalg.norm(cross)
        if length == 0:
            continue
        n = cross / length
        normals[i] = n
        row = plane_row(n, -n @ vertices[a], 0.5 * length)
        for v in (a, b, c):
            q[v, :10] += row
            q[v, 10] += 0.5 * length
    if boundary_weight > 0:
        for i, a, b in boundary_halfedges(faces):
            e = vertices[b] - vertices[a]
            m = np.cross(e, normals[i])
            m /= np.linalg.norm(m)
            row = plane_row(m, -m @ vertices[a], boundary_weight * (e @ e))
            q[a, :10] += row
            q[b, :10] += row
    return q


def split(q):
    a = np.array([[q[0], q[1], q[2]], [q[1], q[3], q[4]], [q[2], q[4], q[5]]])
    return a, q[6:9], q[9]


def q_eval(q, p):
    a, b, c = split(q)
    return float(p @ a @ p + 2 * b @ p + c)


def within_reach(p, a, b):
    """Inside the bounding box of a and b grown by their distance (quadric.pxd within_reach)."""
    grow = np.linalg.norm(a - b)
    return bool(np.all(p >= np.minimum(a, b) - grow) and np.all(p <= np.maximum(a, b) + grow))


def reference_plan(u, v, q_all, positions, boundary, fixed, interior, placement, policy):
    """What plan_edge(u, v) must return, as (removed, kept, position, cost, error, exact):
    ``exact`` False means the 3x3 system is ill-conditioned and only the fallback's
    guarantees hold (cost no worse than either end or the midpoint)."""
    bu, bv = boundary[u], boundary[v]
    if bu and bv and interior:
        return None                                       # would pinch the surface
    fu, fv = bool(fixed[u]), bool(fixed[v])
    if policy == LOCK:                                    # a border vertex never moves at all
        fu, fv = fu or bu, fv or bv
    if policy == PRESERVE:                                # a border vertex never moves inwards
        fu = fu or (bu and not bv)
        fv = fv or (bv and not bu)
    if fu and fv:
        return None
    q = q_all[u] + q_all[v]
    w = q[10]
    exact = True
    if fu or fv:
        kept = u if fu else v
        p = positions[kept].copy()
    elif placement == ENDPOINT:
        cu, cv = q_eval(q, positions[u]), q_eval(q, positions[v])
        kept = u if (cu, u) < (cv, v) else v
        p = positions[kept].copy()
    else:
        a, b, _ = split(q)
        p = np.linalg.solve(a, -b) if np.linalg.cond(a) < 1e3 else None
        if p is None or not within_reach(p, positions[u], positions[v]):
            p, exact = None, False           # ill-conditioned, or flung off the edge: the fallback
        kept = None
    removed = None if kept is None else (v if kept == u else u)
    cost = None if p is None else max(q_eval(q, p), 0.0)
    return removed, kept, p, cost, w, exact


def mesh_setup(vertices, faces, boundary_weight, fixed=None, placement=OPTIMAL, policy=PRESERVE,
               **options):
    hm = build(faces.astype(np.int32), len(vertices))
    positions = vertices.astype(np.float64).copy()
    quadrics = vertex_quadrics(hm, positions, boundary_weight)
    fixed = np.zeros(len(vertices), np.uint8) if fixed is None else fixed.astype(np.uint8)
    collapser = EdgeCollapser(hm, positions.copy(), quadrics.copy(), None, fixed,
                              placement=placement, boundary=policy, **options)
    return hm, quadrics, collapser


def edges_of(faces):
    """{(u, v): True if interior} for the undirected edges, u < v."""
    count = {}
    for f in faces:
        for k in range(3):
            key = tuple(sorted((int(f[k]), int(f[(k + 1) % 3]))))
            count[key] = count.get(key, 0) + 1
    return {key: c == 2 for key, c in count.items()}


# ---------------------------------------------------------------------- quadrics
@pytest.mark.parametrize("name", sorted(MESHES))
@pytest.mark.parametrize("boundary_weight", [0.0, 10.0])
def test_vertex_quadrics_match_reference(name, boundary_weight):
    vertices, faces = MESHES[name]()
    hm = build(faces.astype(np.int32), len(vertices))
    got = vertex_quadrics(hm, vertices, boundary_weight)
    want = reference_quadrics(vertices, faces, boundary_weight)
    assert got.shape == (len(vertices), 11) and got.dtype == np.float64
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12 * np.abs(want).max())


@pytest.mark.parametrize("name", sorted(MESHES))
def test_vertex_quadric_vanishes_at_its_vertex(name):
    # every plane a vertex collects passes through it (faces and boundary edges alike)
    vertices, faces = MESHES[name]()
    hm = build(faces.astype(np.int32), len(vertices))
    q = vertex_quadrics(hm, vertices, 10.0)
    for v in range(len(vertices)):
        assert abs(q_eval(q[v], vertices[v])) <= 1e-12 * q[v, 10]


def test_quadric_area_column_is_the_one_ring_area():
    vertices, faces = grid_mesh(3, 2)                  # unit quads: every triangle has area 1/2
    hm = build(faces.astype(np.int32), len(vertices))
    q = vertex_quadrics(hm, vertices, 5.0)
    counts = np.bincount(faces.ravel(), minlength=len(vertices))
    np.testing.assert_array_equal(q[:, 10], 0.5 * counts)
    # flat: only the z^2 term; boundary planes add x or y terms on the border only
    np.testing.assert_array_equal(q[:, 5], 0.5 * counts)
    interior = [5, 6]
    np.testing.assert_array_equal(q[interior][:, [0, 1, 2, 3, 4, 6, 7, 8, 9]], 0.0)


def threaded_test_mesh():
    """Above the threads' threshold (16,384 vertex slots): a bumpy 130 x 130 grid (a
    border), a fan of 100 faces round one vertex (more than a vertex's faces sorted on the
    stack), a zero-area face and two faces sharing one vertex only (split copies)."""
    v, f = grid_mesh(130, 130, z=lambda x, y: 0.3 * np.sin(0.3 * x) * np.cos(0.2 * y))
    n = len(v)
    k = 100
    angles = np.linspace(0.0, 2.0 * np.pi, k, endpoint=False)
    fan = np.stack([np.cos(angles), np.sin(angles), 0.1 * np.sin(3 * angles)], axis=1) + [200.0, 0.0, 0.0]
    centre, ring = n, n + 1 + np.arange(k)
    fan_faces = np.stack([np.full(k, centre), ring, np.roll(ring, -1)], axis=1)
    m = n + 1 + k
    extra = np.array([[300.0, 0, 0], [301, 0, 0], [302, 0, 0],            # collinear: zero area
                      [400, 0, 0], [401, 0, 0], [400, 1, 0], [399, 0, 0], [400, -1, 0]])   # bowtie
    extra_faces = np.array([[m, m + 1, m + 2], [m + 3, m + 4, m + 5], [m + 3, m + 6, m + 7]])
    vertices = np.concatenate([v, [[200.0, 0.0, 0.5]], fan, extra])
    # half the fan first, half last: its centre's faces lie in several runs of face slots
    # (the threads' runs), so it gathers them, more than fit on the stack
    faces = np.concatenate([fan_faces[:50], f, fan_faces[50:], extra_faces]).astype(np.int32)
    return vertices, faces


def test_set_up_is_the_same_on_any_number_of_threads():
    # each thread scatters a run of faces to the vertices it owns, the others gather in
    # the face order of the serial scatter; the input normals are per face: the same bits
    # for any number of threads, on the input and on a mesh with dead faces
    from lodkit._core.decimate import face_unit_normals

    vertices, faces = threaded_test_mesh()
    hm = build(faces, len(vertices), 2)
    assert hm.n_vertices >= 16384 and hm.n_split_vertices == 1
    positions = vertices[hm.vertex_sources]
    one = vertex_quadrics(hm, positions, 0.0, threads=1)
    want = reference_quadrics(positions, hm.corners, 0.0)
    np.testing.assert_allclose(one, want, rtol=1e-12, atol=1e-12 * np.abs(want).max())
    for threads in (2, 3):
        assert vertex_quadrics(hm, positions, 0.0, threads=threads).tobytes() == one.tobytes()
        assert (face_unit_normals(hm, positions, threads).tobytes()
                == face_unit_normals(hm, positions, 1).tobytes())
    collapser = EdgeCollapser(hm, positions, one, None, np.zeros(hm.n_vertices, np.uint8), threads=2)
    collapser.run(hm.n_faces // 2)
    moved = np.ascontiguousarray(collapser.positions)
    assert not hm.alive_faces.all()
    one = vertex_quadrics(hm, moved, 5.0, threads=1)
    assert vertex_quadrics(hm, moved, 5.0, threads=2).tobytes() == one.tobytes()


def test_vertex_quadrics_make_the_collapsers_input_normals():
    # vertex_quadrics(normals=) fills the int16 input normals from the face planes it
    # computes anyway (the pass driver's set-up): the bits face_unit_normals gives, on one
    # thread and on the threaded scatter, degenerate faces left alone; the quadrics are
    # unchanged, and a collapser handed them runs as one that made its own
    from lodkit._core.decimate import face_unit_normals

    vertices, faces = threaded_test_mesh()
    k = len(vertices)
    line = np.array([[300.0, 0.0, 0.0], [301.0, 0.0, 0.0], [302.0, 0.0, 0.0]])
    vertices = np.concatenate([vertices, line])
    faces = np.concatenate([faces, [[k, k + 1, k + 2]]]).astype(np.int32)   # zero area
    hm = build(faces, len(vertices), 2)
    positions = vertices[hm.vertex_sources]
    want = face_unit_normals(hm, positions, 1)
    assert not want[-3:].any() and want.any()
    for threads in (1, 2, 3):
        normals = np.zeros(3 * hm.n_faces, dtype=np.int16)
        q = vertex_quadrics(hm, positions, 0.0, threads=threads, normals=normals)
        assert normals.tobytes() == want.tobytes()
        assert q.tobytes() == vertex_quadrics(hm, positions, 0.0, threads=threads).tobytes()
    with pytest.raises(ValueError, match="normals"):
        vertex_quadrics(hm, positions, 0.0, normals=np.zeros(3, dtype=np.int16))
    runs = []
    for given in (False, True):
        hm = build(faces, len(vertices), 2)
        normals = np.zeros(3 * hm.n_faces, dtype=np.int16)
        q = vertex_quadrics(hm, positions, 0.0, normals=normals)
        collapser = EdgeCollapser(hm, positions, q, None, np.zeros(hm.n_vertices, np.uint8),
                                  input_normals=normals if given else None)
        collapser.run(hm.n_faces // 2)
        runs.append((hm.corners.tobytes(), hm.alive_faces.tobytes(), np.asarray(collapser.positions).tobytes()))
    assert runs[0] == runs[1]


# ---------------------------------------------------------------------- plan_edge
CONFIGS = [
    (OPTIMAL, PRESERVE, 10.0, False),
    (OPTIMAL, FREE, 0.0, False),
    (OPTIMAL, FREE, 3.0, True),
    (ENDPOINT, PRESERVE, 10.0, False),
    (ENDPOINT, FREE, 0.0, True),
    (OPTIMAL, LOCK, 0.0, True),
]


@pytest.mark.parametrize("name", ["bumpy_grid", "sphere", "cube", "cube3", "flat_grid"])
@pytest.mark.parametrize("placement, policy, boundary_weight, with_fixed", CONFIGS)
def test_plan_edge_matches_reference(name, placement, policy, boundary_weight, with_fixed):
    vertices, faces = MESHES[name]()
    n = len(vertices)
    fixed = np.zeros(n, bool)
    if with_fixed:
        fixed[::4] = True
    hm, quadrics, collapser = mesh_setup(vertices, faces, boundary_weight, fixed, placement, policy)
    boundary = np.array([hm.vertex_is_boundary(v) for v in range(n)])
    n_exact = 0
    for (u, v), interior in edges_of(faces).items():
        got = collapser.plan_edge(u, v)
        assert _same_plan(got, collapser.plan_edge(v, u)), "plan depends on the argument order"
        want = reference_plan(u, v, quadrics, vertices, boundary, fixed, interior, placement, policy)
        if want is None:
            assert got is None, (u, v)
            continue
        assert got is not None, (u, v)
        removed, kept, position, cost, error = got
        assert {removed, kept} == {u, v}
        # never placed outside the box of the two ends grown by the edge's length
        assert within_reach(position, vertices[u], vertices[v]), (u, v, position)
        scale = quadrics[u, 10] + quadrics[v, 10]
        q = quadrics[u] + quadrics[v]
        # always: cost is the summed quadric at the returned position, error its RMS form
        assert cost >= 0.0
        assert cost == pytest.approx(max(q_eval(q, position), 0.0), rel=1e-9, abs=1e-12 * scale)
        assert error == pytest.approx(np.sqrt(cost / scale), rel=1e-9, abs=1e-12)
        w_removed, w_kept, w_pos, w_cost, _, exact = want
        if w_pos is not None:
            np.testing.assert_allclose(position, w_pos, rtol=1e-9, atol=1e-9)
            assert cost == pytest.approx(w_cost, rel=1e-9, abs=1e-12 * scale)
            n_exact += 1
            if w_kept is not None:
                assert (removed, kept) == (w_removed, w_kept)
        if not exact:
            # the fallback never does worse than the ends or the midpoint of the edge
            floor = min(q_eval(q, vertices[u]), q_eval(q, vertices[v]),
                        q_eval(q, 0.5 * (vertices[u] + vertices[v])))
            assert cost <= floor + 1e-12 * scale
            # and it cannot beat the true minimum of the quadric
            a, b, c = split(q)
            p_min = np.linalg.lstsq(a, -b, rcond=None)[0]
            assert cost >= q_eval(q, p_min) - 1e-9 * scale
        if placement == OPTIMAL and kept is not None and w_kept is None:
            # provenance: the kept slot is the end nearer to the new position
            du = np.linalg.norm(position - vertices[u])
            dv = np.linalg.norm(position - vertices[v])
            assert kept == (u if (du, u) < (dv, v) else v)
    if name != "flat_grid" and placement == OPTIMAL and not with_fixed:
        assert n_exact > 0          # the comparison really compared something


def _same_plan(a, b):
    if a is None or b is None:
        return a is None and b is None
    return a[0] == b[0] and a[1] == b[1] and np.array_equal(a[2], b[2]) and a[3] == b[3] and a[4] == b[4]


def test_plan_edge_rejects_non_edges():
    vertices, faces = grid_mesh(2, 2)
    _, _, collapser = mesh_setup(vertices, faces, 0.0)
    with pytest.raises(ValueError, match="not an edge"):
        collapser.plan_edge(0, 8)


def test_plan_edge_exact_on_a_cube_corner_pair():
    # corners (0,0,0) and (0,0,1): planes x=0, y=0 (both) and z=0 / z=1 (one each, area 1
    # per side, shared between the corner's triangles).  The optimum keeps x = y = 0 and
    # puts z at the area-weighted mean of the two z planes.
    vertices, faces = CUBE_VERTICES.copy(), CUBE_FACES.copy()
    _, quadrics, collapser = mesh_setup(vertices, faces, 0.0)
    removed, kept, p, cost, error = collapser.plan_edge(0, 1)
    a0 = quadrics[0, 5]                     # area of the z = 0 triangles at vertex 0
    a1 = quadrics[1, 5]                     # area of the z = 1 triangles at vertex 1
    z = a1 / (a0 + a1)
    np.testing.assert_allclose(p, [0.0, 0.0, z], atol=1e-12)
    assert cost == pytest.approx(a0 * z * z + a1 * (1 - z) ** 2, rel=1e-12)
    assert error == pytest.approx(np.sqrt(cost / (quadrics[0, 10] + quadrics[1, 10])), rel=1e-12)


# ---------------------------------------------------------------------- exact tiny cases
def test_flat_grid_every_collapse_is_free():
    vertices, faces = grid_mesh(5, 4)
    for policy, weight in [(PRESERVE, 10.0), (FREE, 0.0)]:
        _, _, collapser = mesh_setup(vertices, faces, weight, policy=policy)
        for u, v in edges_of(faces):
            plan = collapser.plan_edge(u, v)
            if plan is None:
                continue
            assert plan[3] <= 1e-24 and plan[2][2] == 0.0, (u, v, plan)


@pytest.mark.parametrize("boundary", ["lock", "preserve", "free"])
@pytest.mark.parametrize("placement", ["optimal", "endpoint"])
def test_flat_grid_stays_flat(boundary, placement):
    vertices, faces = grid_mesh(8, 6)
    vertices[:, :2] *= [0.37, 1.3]                         # not a power-of-two scale
    result = lodkit.simplify(lodkit.Mesh(vertices, faces), target_faces=2, boundary=boundary,
                             placement=placement)
    out = result.mesh.vertices
    assert np.all(out[:, 2] == 0.0)
    assert result.error <= 1e-7          # sqrt of a cost at rounding level
    assert lodkit.topology(result.mesh).n_boundary_loops == 1
    if boundary == "lock":
        # the 28 border vertices are all left, unmoved; (greedy collapse may strand an
        # interior vertex or two: moving it onto a straight side would make a flat face)
        border = np.flatnonzero((vertices[:, 0] == 0) | (vertices[:, 1] == 0)
                                | (vertices[:, 0] == vertices[:, 0].max())
                                | (vertices[:, 1] == vertices[:, 1].max()))
        rows = np.isin(result.vertex_map, border)
        assert rows.sum() == 28
        np.testing.assert_array_equal(out[rows], vertices[result.vertex_map[rows]])
        assert result.stop_reason == "no_valid_collapse"
        assert result.mesh.n_vertices <= 31
    else:
        assert (result.mesh.n_faces, result.stop_reason) == (2, "target_faces")
    if boundary == "preserve":
        # the outline is kept: the four corners survive
        corners = np.array([[0.0, 0.0], [0.0, 6 * 1.3], [8 * 0.37, 0.0], [8 * 0.37, 6 * 1.3]])
        got = out[np.lexsort((out[:, 1], out[:, 0])), :2]
        np.testing.assert_allclose(got, corners, atol=1e-12)


def test_tetrahedron_cannot_collapse():
    mesh = lodkit.Mesh(TETRA_VERTICES, TETRA_FACES)
    result = lodkit.simplify(mesh, target_faces=0)
    assert result.stop_reason == "no_valid_collapse"
    assert result.mesh.n_faces == 4 and result.n_collapses == 0
    np.testing.assert_array_equal(result.mesh.vertices, TETRA_VERTICES)
    np.testing.assert_array_equal(result.mesh.faces, TETRA_FACES)


def test_cube_at_its_own_size_is_untouched():
    result = lodkit.simplify(lodkit.Mesh(CUBE_VERTICES, CUBE_FACES), target_faces=12)
    assert (result.n_collapses, result.stop_reason) == (0, "target_faces")
    np.testing.assert_array_equal(result.mesh.vertices, CUBE_VERTICES)


@pytest.mark.parametrize("placement", ["optimal", "endpoint"])
def test_first_cube_collapse_is_the_cheapest_reference_plan(placement):
    """Through simplify(): positions are normalised (bbox centre at 0, unit diagonal), the
    quadrics built, and the cheapest legal edge collapsed first."""
    vertices, faces = CUBE_VERTICES.copy(), CUBE_FACES.copy()
    result = lodkit.simplify(lodkit.Mesh(vertices, faces), target_faces=10, placement=placement,
                             record=True, max_normal_angle=180.0)
    assert result.n_collapses == 1 and result.mesh.n_faces == 10
    scale = np.sqrt(3.0)
    centred = (vertices - 0.5) / scale
    quadrics = reference_quadrics(centred, faces)
    hm = build(faces.astype(np.int32), 8)
    costs = {}
    for (u, v), interior in edges_of(faces).items():
        if hm.can_collapse(u, v):
            plan = reference_plan(u, v, quadrics, centred, np.zeros(8, bool), np.zeros(8), interior,
                                  OPTIMAL if placement == "optimal" else ENDPOINT, PRESERVE)
            costs[(u, v)] = plan[3]
    rec = result.collapses
    assert rec["cost"][0] == pytest.approx(min(costs.values()), rel=1e-9)
    done = tuple(sorted((int(rec["removed"][0]), int(rec["kept"][0]))))
    assert costs[done] == pytest.approx(min(costs.values()), rel=1e-9)
    kept_row = result.vertex_map == rec["kept"][0]
    np.testing.assert_allclose(rec["position"][0], result.mesh.vertices[kept_row][0])


@pytest.mark.parametrize("n", [2, 3, 4, 5, 6])
@pytest.mark.parametrize("placement", ["optimal", "endpoint"])
def test_subdivided_cube_simplifies_to_its_corners(n, placement):
    """Every collapse down to 12 faces can be free (an interior vertex of a side slides into
    a neighbour, an edge vertex along its cube edge), and greedy QEM must find them: the
    result is the 12-triangle cube on the 8 corners, with zero error."""
    vertices, faces = subdivided_cube(n)
    result = lodkit.simplify(lodkit.Mesh(vertices, faces), target_faces=12, placement=placement)
    assert (result.mesh.n_faces, result.stop_reason) == (12, "target_faces")
    out = result.mesh.vertices
    assert result.mesh.n_vertices == 8
    corners = np.round(out)
    assert np.abs(out - corners).max() <= 1e-12
    assert sorted(map(tuple, corners.tolist())) == sorted(map(tuple, CUBE_VERTICES.tolist()))
    assert result.error <= 1e-6
    if placement == "endpoint":
        np.testing.assert_array_equal(out, vertices[result.vertex_map])


def sample_meshes():
    yield "bumpy_grid", bumpy_grid()
    yield "sphere", uv_sphere(16, 10)
    v, f = subdivided_cube(4)
    yield "jittered_cube", (v + np.random.default_rng(1).normal(0.0, 0.01, v.shape), f)


@pytest.mark.parametrize("name, mesh", list(sample_meshes()))
def test_endpoint_placement_keeps_input_vertices(name, mesh):
    vertices, faces = mesh
    result = lodkit.simplify(lodkit.Mesh(vertices, faces), target_ratio=0.2, placement="endpoint",
                             record=True)
    out = result.mesh.vertices
    np.testing.assert_array_equal(out, vertices[result.vertex_map])       # bitwise
    assert len(np.unique(result.vertex_map)) == len(result.vertex_map)
    # every recorded position is the input position of the kept vertex
    rec = result.collapses
    np.testing.assert_allclose(rec["position"], vertices[rec["kept"]], rtol=0, atol=1e-14)


def test_endpoint_records_hold_input_positions_bitwise():
    """A half-edge collapse moves nothing, so the collapse records of a progressive mesh
    should replay onto exactly the input coordinates (not a round trip through the
    normalised frame, which is off by an ulp)."""
    vertices, faces = bumpy_grid()
    result = lodkit.simplify(lodkit.Mesh(vertices, faces), target_ratio=0.2, placement="endpoint",
                             record=True)
    rec = result.collapses
    np.testing.assert_array_equal(rec["position"], vertices[rec["kept"]])


def test_boundary_lock_keeps_border_bitwise():
    rng = np.random.default_rng(5)
    vertices, faces = grid_mesh(12, 9, z=lambda x, y: 0.3 * np.sin(x / 2) * np.cos(y / 3))
    vertices[:, 2] += rng.normal(0.0, 0.02, len(vertices))
    vertices[:, :2] += rng.normal(0.0, 0.05, (len(vertices), 2))
    border = np.flatnonzero((vertices[:, 0] < 0.5) | (vertices[:, 0] > 11.5)
                            | (vertices[:, 1] < 0.5) | (vertices[:, 1] > 8.5))
    for placement in ("optimal", "endpoint"):
        result = lodkit.simplify(lodkit.Mesh(vertices, faces), target_ratio=0.05, boundary="lock",
                                 placement=placement)
        kept = np.isin(result.vertex_map, border)
        assert kept.sum() == len(border)
        np.testing.assert_array_equal(result.mesh.vertices[kept], vertices[result.vertex_map[kept]])


@pytest.mark.parametrize("as_mask", [True, False])
def test_locked_vertices_stay(as_mask):
    vertices, faces = uv_sphere(16, 10)
    chosen = np.random.default_rng(2).choice(len(vertices), 20, replace=False)
    locked = np.zeros(len(vertices), bool)
    locked[chosen] = True
    result = lodkit.simplify(lodkit.Mesh(vertices, faces), target_faces=40,
                             locked=locked if as_mask else chosen)
    assert set(chosen.tolist()) <= set(result.vertex_map.tolist())
    rows = np.isin(result.vertex_map, chosen)
    np.testing.assert_array_equal(result.mesh.vertices[rows], vertices[result.vertex_map[rows]])
    assert result.mesh.n_faces >= 36        # 20 fixed vertices of a sphere need 36 faces


@pytest.mark.parametrize("absolute", [False, True])
@pytest.mark.parametrize("max_error", [1e-3, 1e-2, 5e-2])
def test_max_error_stops_in_time(max_error, absolute):
    vertices, faces = uv_sphere(24, 14)
    vertices = vertices * 3.0                         # bbox diagonal ~ 10.4
    limit = max_error * (10 if absolute else 1)
    result = lodkit.simplify(lodkit.Mesh(vertices, faces), max_error=limit, absolute=absolute,
                             record=True)
    assert result.stop_reason == "max_error"
    assert 0 < result.error <= limit
    assert result.collapses["error"].max() == result.error
    tighter = lodkit.simplify(lodkit.Mesh(vertices, faces), max_error=limit / 4, absolute=absolute)
    assert tighter.mesh.n_faces >= result.mesh.n_faces
    assert tighter.error <= limit / 4


@pytest.mark.parametrize("name, mesh", list(sample_meshes()))
def test_target_faces_reached(name, mesh):
    vertices, faces = mesh
    m = len(faces)
    for target in sorted({0, 1, 2, 5, 8, 13, m // 4, m // 2 + 1, m - 1, m}):
        result = lodkit.simplify(lodkit.Mesh(vertices, faces), target_faces=target)
        got = result.mesh.n_faces
        assert got >= target - 1, (target, got)     # a collapse removes at most two faces
        if result.stop_reason == "target_faces":
            assert got in (target, target - 1), (target, got)
        else:
            assert result.stop_reason == "no_valid_collapse" and got > target


def test_target_ratio_rounds_to_a_face_count():
    vertices, faces = uv_sphere(16, 10)
    assert len(faces) == 288
    result = lodkit.simplify(lodkit.Mesh(vertices, faces), target_ratio=0.25)
    assert result.report["target_faces"] == 72
    assert result.mesh.n_faces in (71, 72)
    result = lodkit.simplify(lodkit.Mesh(vertices, faces), target_ratio=0.1)   # 28.8 -> 29
    assert result.report["target_faces"] == 29
    assert result.mesh.n_faces in (28, 29)


# ---------------------------------------------------------------------- greedy order
def fresh_first_cost(hm, collapser, options):
    """Cost of the collapse a brand-new collapser over the current state would do first."""
    live = np.flatnonzero(hm.alive_vertices)
    remap = np.full(hm.n_vertices, -1)
    remap[live] = np.arange(live.size)
    hm2 = build(remap[hm.faces()].astype(np.int32), live.size)
    fresh = EdgeCollapser(hm2, collapser.positions[live].copy(), collapser.quadrics[live].copy(),
                          None, np.zeros(live.size, np.uint8), record=True, **options)
    fresh.run(0, 1)
    cost = fresh.records()["cost"]
    return cost[0] if len(cost) else None


@pytest.mark.parametrize("name, mesh", list(sample_meshes()))
@pytest.mark.parametrize("placement, policy", [(OPTIMAL, PRESERVE), (ENDPOINT, PRESERVE), (OPTIMAL, FREE)])
def test_each_collapse_is_the_cheapest_legal_one(name, mesh, placement, policy):
    """The incremental heap upkeep must agree, step by step, with a full rescan: the
    collapse done is never dearer than the first one a fresh collapser would pick.
    (Normal checks off: they depend on the input normals, which a fresh collapser lacks.)"""
    vertices, faces = mesh
    options = dict(placement=placement, boundary=policy, max_normal_angle=180.0)
    weight = 0.0 if policy == FREE else 10.0
    hm, _, collapser = mesh_setup(vertices, faces, weight, None, placement, policy,
                                  max_normal_angle=180.0, record=True)
    target = len(faces) // 5
    while hm.n_alive_faces > target:
        want = fresh_first_cost(hm, collapser, options)
        before = collapser.n_collapses
        collapser.run(target, 1)
        if collapser.n_collapses == before:
            assert want is None
            break
        done = collapser.records()["cost"][-1]
        assert want is not None and done <= want * (1 + 1e-9) + 1e-15, (hm.n_alive_faces, done, want)
    assert hm.check()


@pytest.mark.parametrize("placement", [OPTIMAL, ENDPOINT])
def test_running_in_chunks_changes_nothing(placement):
    """run(target, max_steps) stops after max_steps collapses and picks up where it left
    off (the progress bar runs the loop this way): same collapses, same order."""
    vertices, faces = uv_sphere(24, 14)
    target = len(faces) // 10
    _, _, whole = mesh_setup(vertices, faces, 10.0, None, placement, PRESERVE, record=True)
    assert whole.run(target) == 0
    hm, _, chunked = mesh_setup(vertices, faces, 10.0, None, placement, PRESERVE, record=True)
    statuses = []
    while True:
        before = chunked.n_collapses
        statuses.append(chunked.run(target, 7))
        assert chunked.n_collapses - before <= 7
        if statuses[-1] != 1:
            break
    assert statuses[-1] == 0 and set(statuses[:-1]) == {1}
    a, b = whole.records(), chunked.records()
    for key in a:
        np.testing.assert_array_equal(a[key], b[key])
    np.testing.assert_array_equal(whole.positions, chunked.positions)
    assert hm.check()


def test_collapser_rejects_bad_arguments():
    vertices, faces = grid_mesh(2, 2)
    hm = build(faces.astype(np.int32), 9)
    q = vertex_quadrics(hm, vertices)
    fixed = np.zeros(9, np.uint8)
    with pytest.raises(ValueError, match="positions"):
        EdgeCollapser(hm, vertices[:8], q, None, fixed)
    with pytest.raises(ValueError, match="quadrics"):
        EdgeCollapser(hm, vertices, q[:, :10], None, fixed)
    with pytest.raises(ValueError, match="attributes"):
        EdgeCollapser(hm, vertices, q, np.zeros((8, 2)), fixed)
    with pytest.raises(ValueError, match="fixed"):
        EdgeCollapser(hm, vertices, q, None, fixed[:8])
    with pytest.raises(ValueError, match="placement"):
        EdgeCollapser(hm, vertices, q, None, fixed, placement=5)
    with pytest.raises(ValueError, match="boundary"):
        EdgeCollapser(hm, vertices, q, None, fixed, boundary=7)
    with pytest.raises(ValueError, match="max_normal_angle"):
        EdgeCollapser(hm, vertices, q, None, fixed, max_normal_angle=0.0)
    with pytest.raises(ValueError, match="positions"):
        vertex_quadrics(hm, vertices[:, :2])
    collapser = EdgeCollapser(hm, vertices, q, None, fixed)
    with pytest.raises(RuntimeError, match="record"):
        collapser.records()


# ---------------------------------------------------------------- the truncated solve
def _quadric_row(A, b, c=0.0):
    return np.array([A[0, 0], A[0, 1], A[0, 2], A[1, 1], A[1, 2], A[2, 2], b[0], b[1], b[2], c, 1.0])


def _reference_truncated(A, b, x0, eps=1e-3):
    """Lindstrom's pseudo-inverse step about x0 by numpy's eigen-decomposition."""
    w, V = np.linalg.eigh(A)
    r = -(A @ x0 + b)
    p = np.array(x0, dtype=float)
    if w.max() <= 0.0:
        return p
    for j in range(3):
        if w[j] > eps * w.max():
            p += (V[:, j] @ r) / w[j] * V[:, j]
    return p


@pytest.mark.parametrize("rank", [1, 2, 3])
def test_truncated_solve_closed_form_matches_eigh(rank):
    """The closed-form truncated solve the planners use gives numpy's eigen-decomposition
    answer (and the Jacobi reference's) on random plane sums of rank 1 (flat), 2 (crease)
    and 3 (corner), with a little noise in the weak directions."""
    from lodkit._core.quadric import truncated_solve
    rng = np.random.default_rng(rank)
    for _ in range(300):
        A = np.zeros((3, 3))
        b = np.zeros(3)
        normals = rng.normal(size=(rank, 3))
        for n in normals:
            n /= np.linalg.norm(n)
            d, w = rng.normal(), rng.uniform(0.1, 2.0)
            A += w * np.outer(n, n)
            b += w * d * n
        m = rng.normal(size=(3, 3))
        A += 1e-9 * (m @ m.T)
        x0 = rng.normal(size=3)
        want = _reference_truncated(A, b, x0)
        scale = 1.0 + np.linalg.norm(want - x0)
        for method in ("closed", "jacobi"):
            got = truncated_solve(_quadric_row(A, b), x0, method)
            assert np.linalg.norm(got - want) <= 1e-6 * scale, (method, got, want)


def _rotation(rng):
    Q, R = np.linalg.qr(rng.normal(size=(3, 3)))
    return Q * np.sign(np.diag(R))


@pytest.mark.parametrize("rank", [1, 2, 3])
def test_truncated_solve_near_rank_deficient_matches_eigh(rank):
    """Near-rank-1/2/3 blocks with spread strong eigenvalues and weak ones from 1e-12 to
    1e-5 of the largest (well clear of the 1e-3 cut): the closed form (Newton on the
    characteristic cubic from its upper bound, the trigonometric solution where Newton would
    be slow) keeps the same directions as numpy's eigh and the Jacobi reference, and lands
    on the same point, with b both consistent (planes through a common point) and not."""
    rng = np.random.default_rng(10 + rank)
    for trial in range(400):
        strong = rng.uniform(0.02, 1.0, size=rank) * 10.0 ** rng.uniform(-6, 6)
        weak = strong.max() * 10.0 ** rng.uniform(-12, -5, size=3 - rank)
        R = _rotation(rng)
        A = R @ np.diag(np.concatenate([strong, weak])) @ R.T
        A = 0.5 * (A + A.T)
        b = rng.normal(size=3) * strong.max() if trial % 2 else -A @ rng.normal(size=3)
        _check_truncated(A, b, rng.normal(size=3), rank, trial)


def _check_truncated(A, b, x0, want_k, case):
    """The closed-form and Jacobi truncated solves of (A, b) about x0: ``want_k`` strong
    directions and numpy eigh's point."""
    from lodkit._core.quadric import truncated_solve_rank
    want = _reference_truncated(A, b, x0)
    scale = 1.0 + np.linalg.norm(want - x0)
    for method in ("closed", "jacobi"):
        got, k = truncated_solve_rank(_quadric_row(A, b), x0, method)
        assert k == want_k, (method, case, k)
        assert np.linalg.norm(got - want) <= 1e-7 * scale, (method, case, got, want)


@pytest.mark.parametrize("eig", [
    (1.0, 1.0, 1.0),            # triple root: s = 0 up to rounding
    (2.0, 2.0, 0.5),            # double top root: Newton's slow case, the trigonometric path
    (2.0, 2.0, 1e-9),           # a crease of equal strengths (h = -1)
    (2.0, 0.5, 0.5),            # double bottom root
    (3.0, 1e-9, 1e-9),          # flat, equal weak directions
    (3.0, 0.0, 0.0),            # exactly rank 1 (h = 1: the root 2 at once)
    (1.0, 0.999, 0.998),        # nearly isotropic
])
def test_truncated_solve_repeated_eigenvalues(eig):
    """Double and triple roots of the characteristic cubic, rotated off the axes: the same
    directions and point as numpy's eigh."""
    rng = np.random.default_rng(7)
    want_k = sum(e > 1e-3 * max(eig) for e in eig)
    for _ in range(50):
        R = _rotation(rng)
        A = R @ np.diag(eig) @ R.T
        A = 0.5 * (A + A.T)
        _check_truncated(A, rng.normal(size=3), rng.normal(size=3), want_k, eig)


def test_truncated_solve_flat_and_diagonal_cases():
    """A flat quadric (one plane) moves x0 onto the plane along its normal only; an
    axis-aligned crease moves it onto the crease line; a zero quadric leaves it."""
    from lodkit._core.quadric import truncated_solve
    x0 = np.array([0.3, -0.2, 0.7])
    plane = _quadric_row(np.diag([0.0, 0.0, 2.0]), np.array([0.0, 0.0, -2.0 * 0.5]))   # z = 0.5
    assert np.allclose(truncated_solve(plane, x0), [0.3, -0.2, 0.5], atol=1e-12)
    n = np.array([1.0, 1.0, 1.0]) / np.sqrt(3.0)                                       # n.x = 1
    tilted = _quadric_row(np.outer(n, n), -n)
    got = truncated_solve(tilted, x0)
    assert abs(got @ n - 1.0) <= 1e-12
    assert np.allclose(np.cross(got - x0, n), 0.0, atol=1e-12)
    crease = _quadric_row(np.diag([1.0, 1.0, 0.0]), np.array([-0.1, -0.4, 0.0]))       # x=.1, y=.4
    assert np.allclose(truncated_solve(crease, x0), [0.1, 0.4, 0.7], atol=1e-12)
    assert np.allclose(truncated_solve(np.zeros(11), x0), x0)
