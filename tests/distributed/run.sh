#!/usr/bin/env bash
# The distributed tests: PETSc, SLEPc and MPI from Debian's packages (for Debian's own
# /usr/bin/python3), tetlap installed into a venv that sees them, checks with 1-3 ranks.
# Usage (from the repository root): bash tests/distributed/run.sh
set -euo pipefail
cd "$(dirname "$0")/../.."

export PETSC_DIR="${PETSC_DIR:-$(ls -d /usr/lib/petscdir/petsc*/x86_64-linux-gnu-real | tail -n 1)}"
export SLEPC_DIR="${SLEPC_DIR:-$(ls -d /usr/lib/slepcdir/slepc*/x86_64-linux-gnu-real | tail -n 1)}"
venv="${TETLAP_MPI_VENV:-$PWD/.venv-mpi}"
if [ ! -x "$venv/bin/python" ]; then
    /usr/bin/python3 -m venv --system-site-packages "$venv"
fi
# Keep Debian's NumPy (petsc4py is built against it): pin it so pip never replaces it.
numpy_version=$(/usr/bin/python3 -c "import numpy; print(numpy.__version__)")
echo "numpy==$numpy_version" > "$venv/constraints.txt"
"$venv/bin/python" -m pip install --quiet --upgrade "pip>=23"
"$venv/bin/python" -m pip install --quiet -c "$venv/constraints.txt" .
"$venv/bin/python" -c "import numpy; assert numpy.__version__ == '$numpy_version', numpy.__version__"

failed=0
for n in 1 2 3; do
    mpirun --allow-run-as-root --oversubscribe -n "$n" "$venv/bin/python" tests/distributed/check.py || failed=1
done
exit "$failed"
