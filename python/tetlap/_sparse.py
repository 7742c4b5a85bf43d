"""SciPy arrays around the core's CSR triples, without copying the values."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp


def csr(arrays, n: int) -> sp.csr_array:
    """A canonical ``(n, n)`` csr_array from the core's ``(data, uint32 indices, indptr)``.

    The uint32 indices (all below 2^31) are viewed as int32 when ``indptr`` is int32, so
    nothing is copied.
    """
    data, indices, indptr = arrays
    indices = indices.view(np.int32) if indptr.dtype == np.int32 else indices.astype(np.int64)
    A = sp.csr_array((data, indices, indptr), shape=(n, n), copy=False)
    A.has_sorted_indices = True
    A.has_canonical_format = True
    return A


def mass(result, n: int) -> sp.csr_array:
    """A mass matrix from the core's ``("lumped", diagonal)`` or ``("csr", triple)``."""
    form, arrays = result
    if form == "lumped":
        return sp.diags_array(arrays, format="csr")
    return csr(arrays, n)


def arrays(A: sp.csr_array):
    """``(data float64, indices int64, indptr int64)`` of a CSR matrix, as the core reads a
    sparse input (``_core``'s one CSR reader)."""
    return (np.ascontiguousarray(A.data, dtype=np.float64), A.indices.astype(np.int64),
            A.indptr.astype(np.int64))
