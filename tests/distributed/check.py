"""Distributed assembly and solves against the serial ones: run under mpirun.

    mpirun -n 2 python tests/distributed/check.py

Prints one line per check on rank 0 and a closing "distributed: N passed, M failed"; the
exit code is the number of failures (on every rank).
"""

from __future__ import annotations

import os
import sys
import tempfile

import numpy as np
from mpi4py import MPI

import tetlap
from tetlap import distributed

comm = MPI.COMM_WORLD
rank, size = comm.Get_rank(), comm.Get_size()
results = []


def check(name, ok, detail=""):
    results.append(bool(ok))
    if rank == 0:
        print(f"{'PASS' if ok else 'FAIL'} [{size} ranks] {name} {detail}", flush=True)


folder = comm.bcast(tempfile.mkdtemp(prefix="tetlap-mpi-") if rank == 0 else None)
points_path, tets_path = os.path.join(folder, "points.npy"), os.path.join(folder, "tets.npy")
if rank == 0:
    V, T = tetlap.meshes.ball(3000, seed=4)
    np.save(points_path, V)
    np.save(tets_path, T.astype(np.int32))
comm.Barrier()
V = np.load(points_path)
T = np.load(tets_path).astype(np.int64)

for kind, mass in (("primal", "barycentric"), ("dual", "circumcentric"), (0.5, "fem")):
    L, M = distributed.assemble(points_path, tets_path, kind, mass)
    Ls, Ms = distributed.to_scipy(L), distributed.to_scipy(M)
    if rank == 0:
        L0, M0 = tetlap.operators(V, T, kind, mass)
        s = abs(L0).max()
        check(f"L {kind} equals the serial one", abs(Ls - L0).max() <= 1e-12 * s,
              f"max diff {abs(Ls - L0).max():.1e}")
        ref = M0.diagonal() if mass != "fem" else M0
        diff = np.abs(Ms - ref).max() if mass != "fem" else abs(Ms - ref).max()
        check(f"M {mass} equals the serial one", diff <= 1e-12 * abs(M0).max(), f"max diff {diff:.1e}")
    else:
        results += [True, True]

# a coefficient and a density per tet, from arrays and from .npy files ((m, 9) rows)
rng = np.random.default_rng(3)
A = rng.normal(size=(len(T), 3, 3))
K = np.einsum("mij,mkj->mik", A, A) + np.eye(3)
rho = rng.uniform(0.5, 2.0, len(T))
K_path, rho_path = os.path.join(folder, "K.npy"), os.path.join(folder, "rho.npy")
if rank == 0:
    np.save(K_path, K.reshape(-1, 9))
    np.save(rho_path, rho)
comm.Barrier()
for label, coefficient, density in (("arrays", K, rho), ("files", K_path, rho_path),
                                    ("one tensor", K[0], None)):
    L, M = distributed.assemble(points_path, tets_path, "primal", "fem",
                                coefficient=coefficient, density=density)
    Ls, Ms = distributed.to_scipy(L), distributed.to_scipy(M)
    if rank == 0:
        L0, M0 = tetlap.operators(V, T, "primal", "fem",
                                  coefficient=K if label != "one tensor" else K[0],
                                  density=rho if density is not None else None)
        dl, dm = abs(Ls - L0).max(), abs(Ms - M0).max()
        check(f"coefficient and density ({label}) equal the serial ones",
              dl <= 1e-12 * abs(L0).max() and dm <= 1e-12 * abs(M0).max(),
              f"max diff {dl:.1e}, {dm:.1e}")
    else:
        results.append(True)

# Dirichlet: a linear function from its boundary values, and the serial solution
boundary = tetlap.diagnostics.boundary_vertices(T, len(V))
fixed = np.flatnonzero(boundary)
u = V @ np.array([1.0, -2.0, 0.5])
L, M = distributed.assemble(points_path, tets_path, "dual", "circumcentric")
x = distributed.to_scipy(distributed.dirichlet(L, fixed, u[fixed]))
if rank == 0:
    check("Dirichlet reproduces a linear function", np.abs(x - u).max() < 1e-7,
          f"max error {np.abs(x - u).max():.1e}")
rhs = np.sin(3 * V[:, 0]) * tetlap.mass(V, T, "circumcentric").diagonal()
x = distributed.to_scipy(distributed.dirichlet(L, fixed, 0.0, rhs))
if rank == 0:
    serial = tetlap.solve.dirichlet(tetlap.laplacian(V, T, "dual"), boundary, 0.0, rhs)
    check("Dirichlet equals the serial solve", np.abs(x - serial).max() < 1e-7 * np.abs(serial).max(),
          f"max diff {np.abs(x - serial).max():.1e}")

# eigenvalues of Eq. 30
lam = distributed.eigs(L, M, 6, fixed)
if rank == 0:
    ref, _ = tetlap.solve.eigs(tetlap.laplacian(V, T, "dual"), tetlap.mass(V, T, "circumcentric"), 6, boundary)
    check("eigenvalues equal the serial ones", np.allclose(lam, ref, rtol=1e-7),
          f"{np.round(lam, 4)} vs {np.round(ref, 4)}")

result = distributed.info(points_path, tets_path)
if rank == 0:
    check("info: counts", result["n_tets"] == len(T) and result["n_boundary_vertices"] == boundary.sum())
    check("info: symmetric, zero row sums, linear precision",
          all(result[k]["symmetry_error"] < 1e-12 and result[k]["max_row_sum"] < 1e-10
              and result[k]["linear_precision_residual"] < 1e-12 for k in ("primal", "dual")),
          str({k: round(result[k]["negative_weight_fraction"], 4) for k in ("primal", "dual")}))
    serial = tetlap.check(tetlap.laplacian(V, T, "dual"), V, T, nsd=False)
    check("info: negative-weight fraction equals the serial one",
          abs(result["dual"]["negative_weight_fraction"] - serial.negative_fraction) < 1e-12)

# linear precision measured where the mesh lies: the same operator 1e6 away says yes too
far_path = os.path.join(folder, "far.npy")
if rank == 0:
    np.save(far_path, V + 1e6)
comm.Barrier()
far = distributed.info(far_path, tets_path)
if rank == 0:
    check("info: linear precision far from the origin",
          all(far[k]["linear_precision_residual"] < 1e-12 for k in ("primal", "dual")),
          str({k: far[k]["linear_precision_residual"] for k in ("primal", "dual")}))

passed = comm.allreduce(sum(results) if rank == 0 else 0)
failed = comm.allreduce(len(results) - sum(results) if rank == 0 else 0)
if rank == 0:
    print(f"distributed: {passed} passed, {failed} failed", flush=True)
sys.exit(min(failed, 100))
