"""What a solve did: :class:`SolveInfo`, returned by every function of :mod:`tetlap.solve`
with ``return_info=True``."""

from __future__ import annotations

import contextlib
import dataclasses
import time
from .._names import public_dir

__all__ = ["SolveInfo"]
__dir__ = public_dir(globals())


@dataclasses.dataclass
class SolveInfo:
    """How one solve went.

    Attributes
    ----------
    solver : str
        The solver that produced the answer: ``"amg"`` (pyamg's CG preconditioned by its
        smoothed aggregation), ``"cholesky"`` (the core's sparse
        ``LL^T`` / ``LDL^T``, faer) or ``"lu"`` (SciPy's SuperLU).
    method : str
        Details: ``"cg + smoothed aggregation"``, ``"LL^T"``, ``"LDL^T"``, ``"SuperLU"``,
        ``"shift-invert Lanczos (ARPACK)"`` ...
    ordering : str or None
        The fill-reducing (direct solvers) or memory (AMG) ordering: ``"nested dissection
        (METIS)"``, ``"amd"``, ``"reverse Cuthill-McKee"``, ``"colamd"``.
    iterations : int or None
        CG iterations (AMG), shift-invert solves (eigs) or proximal steps
        (neumann_primal_kkt); None for a direct solve.
    residual : float
        The largest relative residual of what is returned (:data:`tetlap.solve.RESIDUAL_TOL`
        bounds it): ``|A x - b|_inf / (|A|_inf |x|_inf + |b|_inf)``, or for eigenpairs
        ``|A v - lambda B v|_inf / ((|A|_inf + |lambda| |B|_inf) |v|_inf)``.
    phases : dict of str to float
        Wall-clock seconds per phase (``"setup"``, ``"ordering"``, ``"factorization"``,
        ``"solve"``, ``"check"``, ...).
    fallbacks : list of str
        Why a solver was left for the next one (``"auto"``: amg -> cholesky -> lu).
    certified : bool or None
        Whether the system was certified positive definite before CG (diagonal dominance),
        None where no certificate was sought.
    verification : str or None
        For eigs: how the k returned values were shown to be the k smallest (Sylvester
        inertia at a shift).
    """

    solver: str = ""
    method: str = ""
    ordering: str | None = None
    iterations: int | None = None
    residual: float = 0.0
    phases: dict = dataclasses.field(default_factory=dict)
    fallbacks: list = dataclasses.field(default_factory=list)
    certified: bool | None = None
    verification: str | None = None

    @contextlib.contextmanager
    def phase(self, name: str):
        """Adds the wall-clock time of the ``with`` block to ``phases[name]``."""
        start = time.perf_counter()
        try:
            yield
        finally:
            self.phases[name] = self.phases.get(name, 0.0) + time.perf_counter() - start

    def to_dict(self) -> dict:
        """The attributes as plain Python values (JSON-ready)."""
        return dataclasses.asdict(self)
