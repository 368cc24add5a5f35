"""The ``schroeder`` metric (Schroeder, Zarge & Lorensen 1992): vertex classification,
decimation criterion and hole filling of its kernel on hand-made stars, then whole runs."""
import math

import numpy as np
import pytest

import lodkit
from conftest import shared_mesh
from lodkit._core.schroeder_kernel import (
    BOUNDARY,
    COMPLEX,
    CORNER,
    INTERIOR_EDGE,
    SIMPLE,
    SchroederKernel,
    evaluate_star,
)
from lodkit.errors import OptionError
from lodkit.metrics.schroeder import Schroeder
from test_qem import grid_mesh, subdivided_cube
from test_simplify import check_real_result


def hexagon_star(h=0.0):
    """Vertex 0 at height h over the centre of a unit regular hexagon (vertices 1..6)."""
    a = np.arange(6) * np.pi / 3
    return np.vstack([[0.0, 0.0, h], np.c_[np.cos(a), np.sin(a), np.zeros(6)]])


def roof_star(h=0.0, slope=0.6):
    """Vertex 0 at height h over the middle of a ridge along x (link 1 and 4 on the ridge,
    2, 3 down one side, 5, 6 down the other; the sides fall by ``slope`` per unit)."""
    return np.array([[0, 0, h], [1, 0, 0], [0.5, 1, -slope], [-0.5, 1, -slope], [-1, 0, 0],
                     [-0.5, -1, -slope], [0.5, -1, -slope]], dtype=np.float64)


def cube_corner_star():
    """The corner (0,0,0) of the cube [0,1]^3, each of its three faces split in two; link
    in the order that makes the faces point out of the cube."""
    link = np.array([[1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 1, 1], [0, 0, 1], [1, 0, 1]])[::-1]
    return np.vstack([[0.0, 0.0, 0.0], link]).astype(np.float64)


LINK6 = [1, 2, 3, 4, 5, 6]


# ---- classification ------------------------------------------------------------------

def test_simple_vertex():
    r = evaluate_star(hexagon_star(0.1), 0, LINK6, True)
    assert (r["cls"], r["name"], r["features"], r["vetoed"]) == (SIMPLE, "simple", None, False)


def test_boundary_vertex():
    # half of the hexagon: link 1..4 (angles 0..180 degrees) is an open chain
    r = evaluate_star(hexagon_star(0.1), 0, [1, 2, 3, 4], False)
    assert (r["cls"], r["name"], r["features"]) == (BOUNDARY, "boundary", (0, 3))


def test_interior_edge_vertex():
    # the two roof sides meet at 2 atan(0.6) = 61.9 degrees > 30: the ridge edges (0, 1) and
    # (0, 4) are the only feature edges
    r = evaluate_star(roof_star(0.05), 0, LINK6, True)
    assert (r["cls"], r["name"], r["features"]) == (INTERIOR_EDGE, "interior_edge", (0, 3))
    # v on the ridge: the sides' normals (0, +-0.6, 1) differ by 61.93 degrees; with a
    # feature angle above that the ridge is no feature and the vertex is simple
    assert evaluate_star(roof_star(0.0), 0, LINK6, True, feature_angle=62.0)["cls"] == SIMPLE
    assert evaluate_star(roof_star(0.0), 0, LINK6, True, feature_angle=61.9)["cls"] == INTERIOR_EDGE


def test_corner_vertices():
    # three feature edges (the cube's edges) at 90 degrees
    r = evaluate_star(cube_corner_star(), 0, LINK6, True, remove_corners=False)
    assert (r["cls"], r["name"], r["vetoed"], r["triangles"]) == (CORNER, "corner", True, None)
    # the paper's rule keeps corners too; lodkit's default lets them go at their real cost
    assert evaluate_star(cube_corner_star(), 0, LINK6, True, accumulate="off")["vetoed"]
    r = evaluate_star(cube_corner_star(), 0, LINK6, True)
    assert not r["vetoed"] and r["error"] > 0.1
    # a boundary vertex with one feature edge: faces 1, 2 lie in z = 0, face 0 stands up at
    # 90 degrees along edge (0, 2)
    P = np.array([[0, 0, 0], [0, 0, -1], [1, 0, 0], [0, 1, 0], [-1, 0, 0]], dtype=np.float64)
    r = evaluate_star(P, 0, [1, 2, 3, 4], False, remove_corners=False)
    assert (r["cls"], r["vetoed"]) == (CORNER, True)
    # a closed star folded up and down around the rim (a saddle-like zigzag): rim points 2
    # and 5 up, 3 and 6 down; more than two edges are feature edges -> corner
    Q = hexagon_star(0.0)
    Q[[2, 3, 5, 6], 2] = [0.8, -0.8, 0.8, -0.8]
    assert evaluate_star(Q, 0, LINK6, True)["cls"] == CORNER
    # a closed star with exactly one feature edge: rim heights 1, .5, .5, 0, .5, .5 give
    # dihedral angles 0, 52.2, 0, 60.0, 0, 52.2 degrees at the edges to link 1..6; with a
    # 55-degree feature angle only the edge to link 4 is a feature edge -> corner; with 50,
    # three -> corner; with 61, none -> simple
    K = hexagon_star(0.0)
    K[1:, 2] = [1.0, 0.5, 0.5, 0.0, 0.5, 0.5]
    assert evaluate_star(K, 0, LINK6, True, feature_angle=55.0)["cls"] == CORNER
    assert evaluate_star(K, 0, LINK6, True, feature_angle=50.0)["cls"] == CORNER
    assert evaluate_star(K, 0, LINK6, True, feature_angle=61.0)["cls"] == SIMPLE


def test_complex_vertices():
    P = hexagon_star(0.1)
    assert evaluate_star(P, 0, [1, 2, 3, 1, 5, 6], True)["cls"] == COMPLEX   # repeated link
    r = evaluate_star(P, 0, [1, 2], False)                                     # one face
    assert (r["cls"], r["vetoed"]) == (COMPLEX, True)
    Z = np.zeros((7, 3))                                                       # no area
    assert evaluate_star(Z, 0, LINK6, True)["cls"] == COMPLEX
    # a degenerate face (zero area) makes no feature edge; the rest of the star decides
    D = hexagon_star(0.0)
    D[2] = D[1]
    r = evaluate_star(D, 0, LINK6, True)
    assert r["cls"] == SIMPLE


# ---- the decimation criterion, by hand ---------------------------------------------------

def test_read_only_positions():
    P = hexagon_star(0.1)
    P.setflags(write=False)
    assert evaluate_star(P, 0, np.array(LINK6), True, accumulate="off")["error"] == pytest.approx(0.2 / 3)


def test_distance_to_average_plane():
    # six equal faces, symmetric: N = z; the area-weighted centre is the mean of the face
    # centroids, height h/3 (each has v at height h and two rim points at 0), so d = 2h/3
    # (the paper's criterion: accumulate="off"; the default's is tested below)
    for h in (0.0, 0.1, 0.3):
        r = evaluate_star(hexagon_star(h), 0, LINK6, True, accumulate="off")
        assert r["error"] == pytest.approx(2 * h / 3, abs=1e-15)
        assert r["cost"] == r["error"]


def test_default_error_is_the_larger_of_d_and_the_distance_to_the_new_patch():
    # lodkit's default (accumulate="points"; nothing carried in a lone star): the error is
    # the larger of the paper's d and v's distance to the triangles that fill the hole.  The
    # hexagon's apex at height h: d = 2h/3 (the average plane), the patch is the flat
    # hexagon at height 0, so the error is h
    for h in (0.1, 0.3):
        r = evaluate_star(hexagon_star(h), 0, LINK6, True)
        assert r["error"] == pytest.approx(h, rel=1e-12)
        assert r["cost"] == r["error"]
        assert r["triangles"].tolist() == evaluate_star(hexagon_star(h), 0, LINK6, True,
                                                        accumulate="off")["triangles"].tolist()
    # on a ridge the patch keeps the ridge line: both are the distance to it
    r = evaluate_star(roof_star(0.05), 0, LINK6, True)
    assert r["error"] == pytest.approx(0.05, rel=1e-12)


def test_distance_to_average_plane_tilted_and_uneven():
    # an uneven star (rim points at different radii, tilted): compare with the formula
    rng = np.random.default_rng(3)
    a = (np.arange(7) + rng.uniform(-0.3, 0.3, 7)) * 2 * np.pi / 7
    rim = np.c_[rng.uniform(0.5, 1.5, 7) * np.cos(a), rng.uniform(0.5, 1.5, 7) * np.sin(a),
                rng.uniform(-0.01, 0.01, 7)]
    P = np.vstack([[0.02, -0.01, 0.01], rim])
    link = list(range(1, 8))
    x = P[0]
    cr = [np.cross(P[link[i]] - x, P[link[(i + 1) % 7]] - x) for i in range(7)]
    areas = np.array([np.linalg.norm(c) / 2 for c in cr])
    N = np.sum(cr, axis=0)
    N /= np.linalg.norm(N)
    C = sum(areas[i] * (x + P[link[i]] + P[link[(i + 1) % 7]]) / 3 for i in range(7)) / areas.sum()
    r = evaluate_star(P, 0, link, True, min_aspect=0.0, accumulate="off")
    assert r["cls"] == SIMPLE
    assert r["error"] == pytest.approx(abs(np.dot(N, x - C)), rel=1e-12)


def test_distance_to_new_boundary_edge():
    # v at height 0.1 over the chord from link 1 (1, 0, 0) to link 4 (-1, 0, 0)
    assert evaluate_star(hexagon_star(0.1), 0, [1, 2, 3, 4], False)["error"] == pytest.approx(0.1)
    # v at the hexagon's centre, link 1, 2, 3 (0, 60, 120 degrees): the new boundary edge is
    # the chord over 120 degrees, cos 60 = 1/2 from the centre
    r = evaluate_star(hexagon_star(0.0), 0, [1, 2, 3], False)
    assert (r["cls"], r["triangles"].tolist()) == (BOUNDARY, [[0, 1, 2]])
    assert r["error"] == pytest.approx(0.5, rel=1e-12)


def test_distance_to_new_feature_edge():
    # v 0.05 above the ridge line through link 1 and 4
    r = evaluate_star(roof_star(0.05), 0, LINK6, True)
    assert r["error"] == pytest.approx(0.05, rel=1e-12)
    # moved along the ridge the distance stays; off to the side it grows
    P = roof_star(0.0)
    P[0] = [0.3, 0.0, 0.0]
    assert evaluate_star(P, 0, LINK6, True)["error"] == pytest.approx(0.0, abs=1e-15)


def test_corner_with_remove_corners_uses_the_average_plane():
    # N = -(1,1,1)/sqrt 3, the centroids average to (1/3, 1/3, 1/3): d = 1/sqrt 3
    r = evaluate_star(cube_corner_star(), 0, LINK6, True, remove_corners=True, accumulate="off")
    assert (r["cls"], r["vetoed"]) == (CORNER, False)
    assert r["error"] == pytest.approx(1 / math.sqrt(3), rel=1e-12)
    assert r["triangles"].shape == (4, 3)


# ---- the hole -----------------------------------------------------------------------------

def test_holes_exact():
    # the flat hexagon: as tests/test_retriangulate.py's regular hexagon
    r = evaluate_star(hexagon_star(0.0), 0, LINK6, True)
    assert r["triangles"].tolist() == [[0, 1, 2], [0, 2, 3], [3, 4, 5], [0, 3, 5]]
    # the roof: first split forced along the ridge (link 0 - link 3); each side a symmetric
    # trapezoid whose diagonals tie: the first, (0, 2) and (3, 5)
    r = evaluate_star(roof_star(0.05), 0, LINK6, True)
    assert r["triangles"].tolist() == [[0, 1, 2], [0, 2, 3], [3, 4, 5], [0, 3, 5]]
    # the half hexagon: the new boundary edge (3 -> 0), then the trapezoid's first diagonal
    r = evaluate_star(hexagon_star(0.1), 0, [1, 2, 3, 4], False)
    assert r["triangles"].tolist() == [[0, 1, 2], [0, 2, 3]]


def test_ridge_survives_when_a_plain_split_would_cut_it():
    # a long ridge (link 0 at x = 3, link 3 at x = -3) over narrow sides: the ridge split has
    # aspect 1/6 (the side vertices are 1 from it), the split (1, 5) across the ridge 1/2
    # (vertices 2, 4 are 1 from the line x = 0.5).  As a simple vertex (feature_angle 90) the
    # hole is cut across the ridge; as an interior-edge vertex the ridge stays an edge.
    P = roof_star(0.0)
    P[1, 0], P[4, 0] = 3.0, -3.0

    def edges(tris):
        return {tuple(sorted((t[a], t[b]))) for t in tris for a, b in ((0, 1), (1, 2), (0, 2))}

    plain = evaluate_star(P, 0, LINK6, True, feature_angle=90.0, triangulation="split")
    assert plain["cls"] == SIMPLE and (1, 5) in edges(plain["triangles"])
    assert (0, 3) not in edges(plain["triangles"])
    r = evaluate_star(P, 0, LINK6, True)
    assert r["cls"] == INTERIOR_EDGE and (0, 3) in edges(r["triangles"])
    # lodkit's default triangulation for a simple vertex: the patch nearest v, which here
    # keeps the ridge (v lies on it: distance 0) where the aspect-ratio split cuts it (the
    # error is still the larger of that and the paper's d, the distance to the average plane)
    r = evaluate_star(P, 0, LINK6, True, feature_angle=90.0)
    assert r["cls"] == SIMPLE and (0, 3) in edges(r["triangles"])


def test_boundary_vertex_with_a_link_across_the_new_edge_stays():
    # a convex boundary corner whose middle link vertex lies on v's side of the new edge:
    # removing v would fold the surface over; split_loop refuses, the vertex stays
    P = np.array([[0, 0, 0], [1, 0, 0], [0.3, 0.3, 0], [0, 1, 0]], dtype=np.float64)
    r = evaluate_star(P, 0, [1, 2, 3], False)
    assert (r["cls"], r["vetoed"]) == (BOUNDARY, True)


# ---- options and the metric class --------------------------------------------------------

def test_options():
    m = Schroeder()
    assert m.params["feature_angle"] == 30.0 and m.params["min_aspect"] == 0.04   # exact: the defaults as written
    # None: False under the paper's rule (accumulate="off"), True under lodkit's default
    assert m.params["remove_corners"] is None and m.kind == "removal"
    assert m.kernel is SchroederKernel
    with pytest.raises(OptionError):
        Schroeder(feature_angle=200.0)
    with pytest.raises(OptionError):
        Schroeder(min_aspect=-0.1)
    with pytest.raises(OptionError):
        Schroeder(remove_corners="yes")
    k = SchroederKernel()
    k.prepare(None, {"feature_angle": 45.0, "min_aspect": 0.1, "remove_corners": True})
    assert (k.feature_angle, k.min_aspect, k.remove_corners) == (45.0, 0.1, True)   # exact: the options as given
    assert k.cos_feature == pytest.approx(math.cos(math.radians(45.0)))
    with pytest.raises(ValueError):
        k.prepare(None, {"feature_angle": -1.0})
    with pytest.raises(ValueError):
        k.evaluate_star(np.zeros((3, 2)), 0, [1, 2], True)
    with pytest.raises(ValueError):
        k.evaluate_star(np.zeros((3, 3)), 0, [1, 7], True)


# ---- whole runs through lodkit.simplify ----------------------------------------------------


def cube_edges_kept(V, F, out, vertex_map):
    """Every output vertex is an input vertex; on each of the cube's 12 edge lines, the
    output vertices on it are joined by output edges one after the other (the line is still
    an edge chain of the mesh)."""
    W = out.vertices
    assert np.array_equal(W, V[vertex_map])
    E = {tuple(sorted(e)) for f in out.faces.tolist() for e in ((f[0], f[1]), (f[1], f[2]), (f[0], f[2]))}
    n_lines = 0
    for axis in range(3):
        for a in (0.0, 1.0):
            for b in (0.0, 1.0):
                others = [c for c in range(3) if c != axis]
                on = np.where((W[:, others[0]] == a) & (W[:, others[1]] == b))[0]
                on = on[np.argsort(W[on, axis])]
                assert W[on[0], axis] == 0.0 and W[on[-1], axis] == 1.0     # both corners
                for p, q in zip(on[:-1], on[1:]):
                    assert tuple(sorted((int(p), int(q)))) in E
                n_lines += 1
    assert n_lines == 12


def test_cube_keeps_corners_and_edges():
    V, F = subdivided_cube(4)
    mesh = lodkit.Mesh(V, F)
    r = lodkit.simplify(mesh, target_ratio=0.25, metric="schroeder")
    assert r.mesh.n_faces in (48, 47)
    cube_edges_kept(V, F, r.mesh, r.vertex_map)
    # run to the end: the flat faces go down to two triangles each, the edge lines to the
    # corners: exactly the 8-vertex, 12-face cube, with error 0 (every removal was flat or
    # on a straight edge)
    r = lodkit.simplify(mesh, target_faces=4, metric=("schroeder", {"remove_corners": False}))
    assert (r.mesh.n_vertices, r.mesh.n_faces) == (8, 12)
    assert np.array_equal(np.sort(r.mesh.vertices, axis=0), np.sort(
        np.array([[x, y, z] for x in (0., 1.) for y in (0., 1.) for z in (0., 1.)]), axis=0))
    cube_edges_kept(V, F, r.mesh, r.vertex_map)
    assert r.error < 1e-12           # 0 up to rounding of the normalised positions
    assert lodkit.topology(r.mesh).genus == 0
    # lodkit's default lets corners go once nothing cheaper is left: the target is reached
    # (a tetrahedron of four cube corners), the closed surface kept
    r = lodkit.simplify(mesh, target_faces=4, metric="schroeder")
    assert r.mesh.n_faces == 4 and lodkit.topology(r.mesh).genus == 0
    assert np.all(np.isin(r.mesh.vertices, [0.0, 1.0]))


def test_cube_feature_angle_off_cuts_the_corners():
    # with features off (180 degrees) a cube corner is a simple vertex, 1/sqrt(3) from its
    # average plane on a 1 x 1 star: corners go once nothing flatter is left, with error > 0
    V, F = subdivided_cube(3)
    r = lodkit.simplify(lodkit.Mesh(V, F), target_faces=4, metric=("schroeder", {"feature_angle": 180.0}))
    assert r.mesh.n_vertices < 8 and r.error > 0.0


def test_flat_grid_goes_down_to_its_corners():
    V, F = grid_mesh(6, 5)
    r = lodkit.simplify(lodkit.Mesh(V, F), max_error=1e-9, metric="schroeder")
    # interior vertices are at distance 0 from their average plane, boundary vertices on a
    # side at 0 from their new boundary edge; the four corners are 0.38 / 0.46 (normalised)
    # from theirs and stay
    assert r.mesh.n_faces == 2
    assert sorted(map(tuple, r.mesh.vertices[:, :2].tolist())) == [(0, 0), (0, 5), (6, 0), (6, 5)]
    assert r.error < 1e-12


def feature_edges(mesh, angle=30.0):
    """(n, 2) sorted vertex pairs of the interior edges whose two faces' normals differ by
    more than ``angle`` degrees (numpy)."""
    F = mesh.faces
    N = mesh.face_normals()
    N = N / np.maximum(np.linalg.norm(N, axis=1), 1e-300)[:, None]
    e = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    fid = np.tile(np.arange(len(F)), 3)
    order = np.lexsort((e[:, 1], e[:, 0]))
    e, fid = e[order], fid[order]
    i = np.where(np.all(e[1:] == e[:-1], axis=1))[0]
    cosang = np.einsum("ij,ij->i", N[fid[i]], N[fid[i + 1]])
    return e[i][cosang < np.cos(np.radians(angle))]


def feature_corners(mesh, angle=30.0):
    """Input vertices with a closed star and 1 or >= 3 feature edges (numpy)."""
    count = np.bincount(feature_edges(mesh, angle).ravel(), minlength=mesh.n_vertices)
    return np.where((count == 1) | (count >= 3))[0]


def feature_edge_points(mesh, angle=30.0):
    """Ends and midpoints of the edges whose faces' normals differ by more than ``angle``."""
    fe = feature_edges(mesh, angle)
    a, b = mesh.vertices[fe[:, 0]], mesh.vertices[fe[:, 1]]
    return np.concatenate([a, b, (a + b) / 2])


def distance_to_edges(P, mesh):
    """Distance of each point of P to the nearest edge (segment) of ``mesh``."""
    F = mesh.faces
    e = np.unique(np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1), axis=0)
    A, B = mesh.vertices[e[:, 0]], mesh.vertices[e[:, 1]]
    d = B - A
    dd = np.maximum(np.einsum("ij,ij->i", d, d), 1e-300)
    out = []
    for chunk in np.array_split(P, max(1, len(P) // 256)):
        t = np.clip(((chunk[:, None, :] - A[None]) * d[None]).sum(-1) / dd[None], 0.0, 1.0)
        out.append(np.linalg.norm(chunk[:, None, :] - (A[None] + t[..., None] * d[None]), axis=2).min(axis=1))
    return np.concatenate(out)


def test_fandisk_keeps_its_corners_and_creases():
    mesh = lodkit.load(shared_mesh("fandisk.obj"))
    corners = feature_corners(mesh)
    assert len(corners) > 10
    target = int(round(mesh.n_faces * 0.1))
    r = lodkit.simplify(mesh, target_faces=target, metric=("schroeder", {"accumulate": "off"}))
    check_real_result(mesh, r, target, max_error=0.05)
    kept = set(r.vertex_map.tolist())
    assert all(int(c) in kept for c in corners)
    # lodkit's default (corners may go, at their carried cost): measured 22 of the 24 kept,
    # the creases within 0.00049 of the diagonal (the paper's rule: 0.00081)
    r = lodkit.simplify(mesh, target_faces=target, metric="schroeder")
    check_real_result(mesh, r, target, max_error=0.05)
    kept = set(r.vertex_map.tolist())
    assert sum(int(c) in kept for c in corners) >= 0.8 * len(corners)      # margin for any CPU
    # the creases stay edges: every point of an input feature edge lies on an output edge, up
    # to the chords of curved creases (measured: max 0.00049 of the diagonal, the run's
    # error 0.00050; the paper's rule 0.00081; accumulate="bound" 0.0025; QEM's: 0.00041)
    diag = np.linalg.norm(mesh.vertices.max(0) - mesh.vertices.min(0))
    d = distance_to_edges(feature_edge_points(mesh), r.mesh) / diag
    assert d.max() < 2e-3
    r = lodkit.simplify(mesh, target_faces=target, metric=("schroeder", {"accumulate": "off"}))
    d = distance_to_edges(feature_edge_points(mesh), r.mesh) / diag
    assert d.max() < 1e-3


def test_bunny_with_holes():
    mesh = lodkit.load(shared_mesh("bunny.ply"))
    target = int(round(mesh.n_faces * 0.1))
    r = lodkit.simplify(mesh, target_faces=target, metric="schroeder")
    check_real_result(mesh, r, target, max_error=0.05)     # its 5 holes stay 5 boundary loops
    # every output vertex is an input vertex, bit for bit
    assert np.array_equal(r.mesh.vertices, mesh.vertices[r.vertex_map])


def check_removal_result(mesh, r, target, before):
    """check_real_result without its face_map normal test: a new face of a vertex removal
    spanning a crease may stand for an input face on the crease's other side (turned by up
    to the crease angle).  Instead: every output face faces the same way as at least one
    input face at its corners (no face is inside out)."""
    after = lodkit.topology(r.mesh)
    assert r.stop_reason == "target_faces" and r.mesh.n_faces in (target, target - 1)
    for attr in ("genus", "is_manifold", "n_boundary_loops", "n_components", "n_nonmanifold_edges"):
        assert getattr(after, attr) == getattr(before, attr), attr
    assert np.array_equal(r.mesh.vertices, mesh.vertices[r.vertex_map])
    n_in = mesh.face_normals()
    n_in = n_in / np.linalg.norm(n_in, axis=1)[:, None]
    n_out = r.mesh.face_normals()
    corner_faces = [[] for _ in range(mesh.n_vertices)]
    for i, f in enumerate(mesh.faces.tolist()):
        for v in f:
            corner_faces[v].append(i)
    for f, n in zip(r.vertex_map[r.mesh.faces], n_out):
        around = sorted({i for v in f for i in corner_faces[v]})
        assert (n_in[around] @ n).max() > 0.0
    assert 0 < r.error < 0.05


def test_boot_genus_12_and_where_corners_stop_it():
    mesh = lodkit.load(shared_mesh("boot.obj"))
    before = lodkit.topology(mesh)
    target = int(round(mesh.n_faces * 0.25))
    r = lodkit.simplify(mesh, target_faces=target, metric="schroeder")
    check_removal_result(mesh, r, target, before)
    # at 10% the coarse tubes' dihedral angles pass 30 degrees: most vertices become corners,
    # which Schroeder never removes, and the run stops early (at 18.3%, docs/metrics/schroeder.md)
    r = lodkit.simplify(mesh, target_ratio=0.1, metric=("schroeder", {"accumulate": "off"}))
    assert r.stop_reason == "no_valid_collapse" and r.mesh.n_faces > 0.15 * mesh.n_faces
    after = lodkit.topology(r.mesh)
    assert (after.genus, after.is_manifold, after.n_components) == (12, True, 1)
    assert r.report["held_back"]["kernel"] > 0.8 * r.mesh.n_vertices
    # letting corners go reaches it (lodkit's default does)
    target = int(round(mesh.n_faces * 0.1))
    for spec in (("schroeder", {"remove_corners": True}), "schroeder"):
        r = lodkit.simplify(mesh, target_faces=target, metric=spec)
        check_removal_result(mesh, r, target, before)


def test_stub_names_every_python_visible_name():
    import importlib
    from pathlib import Path

    from test_metrics import _stub_names

    mod = importlib.import_module("lodkit._core.schroeder_kernel")
    stub = _stub_names(Path(__file__).resolve().parents[1] / "lodkit" / "_core" / "schroeder_kernel.pyi")
    public = {n for n, o in vars(mod).items() if not n.startswith("_") and n != "np"
              and getattr(o, "__module__", mod.__name__) == mod.__name__}
    assert public <= set(stub), sorted(public - set(stub))
    for name, members in stub.items():
        if name.startswith("_"):
            continue                                     # a stub-only helper type
        obj = getattr(mod, name)
        if isinstance(obj, type):
            visible = {n for n in vars(obj) if not n.startswith("__")}
            assert visible <= members, sorted(visible - members)
            assert all(hasattr(obj, m) for m in members)
