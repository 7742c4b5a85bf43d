"""Table 1 in the metric: check / info / diagnostics with coefficient=, and the CLI's
--coefficient."""

import json
import subprocess
import sys

import numpy as np
import pytest

import tetlap
from tetlap import diagnostics

REGULAR = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], dtype=float)
A = np.diag([1.0, 1.0, 3.0])              # the stretch; K = A^2 maps it back


def _rotation(seed=0):
    q, _ = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    return q * np.sign(np.linalg.det(q))


def _report(V, T, K, kind="primal"):
    return tetlap.check(tetlap.laplacian(V, T, kind, coefficient=K), V, T, coefficient=K)


def test_acute_in_the_metric_but_obtuse_in_euclidean_space():
    Q = _rotation()
    S = Q @ A @ Q.T                                  # symmetric, a stretch in a tilted axis
    V, T = REGULAR @ S, [[0, 1, 2, 3]]               # rows x -> S x
    K = S @ S                                        # K^-1/2 = S^-1 maps it back: regular
    assert diagnostics.dihedral_angles(V, T).max() > 90
    assert np.allclose(diagnostics.dihedral_angles(V, T, coefficient=K), np.degrees(np.arccos(1 / 3)))
    assert _report(V, T, np.eye(3)).n_obtuse_tets_metric == 1
    assert _report(V, T, K).n_obtuse_tets_metric == 0


def test_obtuse_in_the_metric_but_acute_in_euclidean_space():
    Q = _rotation(1)
    S = Q @ A @ Q.T
    V, T = REGULAR, [[0, 1, 2, 3]]
    K = S @ S                                        # maps the regular tet to REGULAR S^-1
    assert diagnostics.dihedral_angles(V, T).max() < 90
    metric = diagnostics.dihedral_angles(V, T, coefficient=K)
    assert np.allclose(metric, diagnostics.dihedral_angles(REGULAR @ np.linalg.inv(S), T))
    assert metric.max() > 90
    r = _report(V, T, K)
    assert (r.n_obtuse_tets_metric, r.obtuse_tets_metric) == (1, [0])
    assert "obtuse" in str(r)


def test_angles_in_the_metric_ignore_scalars_and_the_scale_of_K():
    V, T = tetlap.meshes.cube(2, jitter=0.2)
    plain = diagnostics.dihedral_angles(V, T)
    c = np.random.default_rng(0).uniform(0.1, 10, len(T))
    assert np.array_equal(diagnostics.dihedral_angles(V, T, coefficient=c), plain)
    K = np.array([[2.0, 0.5, 0.0], [0.5, 1.0, 0.3], [0.0, 0.3, 0.5]])
    angles = diagnostics.dihedral_angles(V, T, coefficient=K)
    for k in (-500, 500):
        assert np.array_equal(diagnostics.dihedral_angles(V, T, coefficient=np.ldexp(K, k)), angles)
        assert np.array_equal(diagnostics.non_delaunay_faces(V, T, coefficient=np.ldexp(K, k)),
                              diagnostics.non_delaunay_faces(V, T, coefficient=K))
    assert not np.allclose(angles, plain)


def test_linear_precision_for_a_constant_K_only():
    V, T = tetlap.meshes.cube(3, jitter=0.1)
    K = np.array([[1.0, 0.5, 0.0], [0.5, 1.0, 0.5], [0.0, 0.5, 1.0]])
    for kind in ("primal", "dual"):
        for constant in (K, np.broadcast_to(K, (len(T), 3, 3)), np.full(len(T), 2.0)):
            r = _report(V, T, constant, kind)
            assert (r.coefficient, r.linear_precision_ok, r.nsd) == ("constant", True, True)
        c = np.random.default_rng(1).uniform(1, 2, len(T))
        for varying in (c, c[:, None, None] * K):
            r = _report(V, T, varying, kind)
            assert r.coefficient == "varying"
            assert r.linear_precision_ok is None and r.linear_precision_residual is None
            assert any("varies between elements: linear functions are not solutions" in n
                       for n in r.notes)
            assert r.nsd and "with the coefficient" in r.nsd_method


def test_delaunay_in_the_metric_is_that_of_the_mapped_mesh():
    V, T = tetlap.meshes.ball(600, seed=3)
    K = np.array([[2.0, 0.5, 0.0], [0.5, 1.0, 0.3], [0.0, 0.3, 0.5]])
    lam, Q = np.linalg.eigh(K)
    mapped = V @ (Q / np.sqrt(lam)) @ Q.T
    expected = diagnostics.non_delaunay_faces(mapped, T)
    assert expected.sum() > 0
    assert np.array_equal(diagnostics.non_delaunay_faces(V, T, coefficient=K), expected)
    r = _report(V, T, K, "dual")
    assert r.n_non_delaunay_faces_metric == expected.sum()
    # a Delaunay mesh in the metric: the dual in the metric has no negative interior weight
    # where the mapped mesh's plain dual has none
    V2 = tetlap.meshes.ball(600, seed=3)[0] @ np.linalg.inv((Q / np.sqrt(lam)) @ Q.T)
    r2 = _report(V2, T, K, "dual")
    plain = tetlap.check(tetlap.laplacian(V, T, "dual"), V, T)
    assert r2.n_non_delaunay_faces_metric == 0
    assert r2.n_negative_interior == plain.n_negative_interior


def _circumcentre(P):
    return np.linalg.solve(2 * (P[1:] - P[0]), (P[1:] ** 2).sum(1) - (P[0] ** 2).sum())


def test_face_weights_with_two_tensors_by_hand():
    """Each tet's contribution is the signed volume of the pyramid on the face whose apex is
    its circumcentre in its own metric; the face is Delaunay in the metric iff their sum
    >= 0. Checked against circumcentres computed here."""
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [0.9, 0.8, 0.7]], float)
    T = np.array([[0, 1, 2, 3], [1, 2, 3, 4]])
    rng = np.random.default_rng(5)
    for _ in range(20):
        B = rng.normal(size=(2, 3, 3))
        K = B @ B.transpose(0, 2, 1) + 0.3 * np.eye(3)
        by_hand = []
        for t, apex in ((0, 0), (1, 4)):
            lam, Q = np.linalg.eigh(K[t])
            R = (Q / np.sqrt(lam)) @ Q.T                 # K^-1/2
            centre = _circumcentre(V[T[t]] @ R) @ np.linalg.inv(R)   # pulled back
            face = V[[1, 2, 3]]
            normal = np.cross(face[1] - face[0], face[2] - face[0])
            side = np.sign(normal @ (V[apex] - face[0]))
            by_hand.append(side * normal @ (centre - face[0]) / 6)
        expected = sum(by_hand) < 0
        assert diagnostics.non_delaunay_faces(V, T, coefficient=K).tolist() == [expected]
        r = _report(V, T, K, "dual")
        assert r.n_non_delaunay_faces_metric == int(expected)
        assert r.non_delaunay_faces_metric == ([[0, 1]] if expected else [])


def test_bad_coefficient_is_named():
    V, T = tetlap.meshes.cube(1)
    c = np.ones(len(T))
    c[3] = -1.0
    with pytest.raises(tetlap.CoefficientError, match=r"tet 3"):
        tetlap.check(tetlap.laplacian(V, T), V, T, coefficient=c)
    with pytest.raises(tetlap.ShapeError, match="coefficient"):
        tetlap.info.report(V, T, coefficient=np.ones(len(T) + 1))
    with pytest.raises(tetlap.ShapeError):
        diagnostics.dihedral_angles(V, T, coefficient=np.ones((2, 2)))
    with pytest.raises(tetlap.OptionError, match="kind=.cell."):
        tetlap.check(tetlap.laplacian(V, T), V, T, kind="cell", coefficient=np.ones(len(T)))


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "tetlap", *args], capture_output=True,
                          text=True, timeout=120)


@pytest.fixture
def files(tmp_path):
    meshio = pytest.importorskip("meshio")
    V, T = tetlap.meshes.cube(2, jitter=0.1)
    K = np.array([[1.0, 0.5, 0.0], [0.5, 1.0, 0.5], [0.0, 0.5, 1.0]])
    path = tmp_path / "m.vtu"
    meshio.write(path, meshio.Mesh(V, [("tetra", T)],
                                   cell_data={"cond": [np.tile(K.ravel(), (len(T), 1))]}))
    np.save(tmp_path / "K.npy", K)
    bad = np.ones(len(T))
    bad[5] = 0.0
    np.save(tmp_path / "bad.npy", bad)
    return V, T, K, path, tmp_path


def test_cli_info_with_npy_and_cell_data(files):
    V, T, K, path, tmp = files
    expected = tetlap.info.report(V, T, coefficient=K, regular=False)
    for x in (str(tmp / "K.npy"), "cond"):
        run = _cli("info", str(path), "--coefficient", x, "--json", "--no-regular")
        assert run.returncode == 0, run.stderr
        out = json.loads(run.stdout)
        assert out["coefficient"] == {"kind": "tensor", "constant": True}
        for kind in ("primal", "dual"):
            for key in ("n_obtuse_tets_metric", "n_non_delaunay_faces_metric",
                        "n_negative_interior", "linear_precision_ok"):
                assert out[kind][key] == expected[kind][key]
    text = _cli("info", str(path), "--coefficient", "cond", "--no-regular").stdout
    assert "tets obtuse in the metric" in text and "faces not Delaunay in the metric" in text


def test_cli_assemble_with_coefficient(files):
    import scipy.sparse as sp

    V, T, K, path, tmp = files
    run = _cli("assemble", str(path), "-o", str(tmp / "out.npz"), "--coefficient", "cond")
    assert run.returncode == 0, run.stderr
    L = sp.load_npz(tmp / "out.npz")
    assert abs(L - tetlap.laplacian(V, T, coefficient=K)).max() < 1e-15


def test_cli_bad_coefficient_is_one_line(files):
    V, T, K, path, tmp = files
    for x, words in ((str(tmp / "missing.npy"), "cannot read"),
                     ("nope", "neither a .npy file nor a cell-data field"),
                     (str(tmp / "bad.npy"), "tet 5")):
        run = _cli("info", str(path), "--coefficient", x, "--no-regular")
        assert run.returncode == 2
        errors = [line for line in run.stderr.splitlines() if line.startswith("tetlap: error")]
        assert len(errors) == 1 and words in errors[0] and "--coefficient" in errors[0]
        assert "Traceback" not in run.stderr
