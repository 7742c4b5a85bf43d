#!/usr/bin/env bash
# The distributed tests: PETSc, SLEPc and MPI from Debian's packages (for Debian's own
# /usr/bin/python3), tetlap installed into a venv that sees them, checks with 1-3 ranks.
# Usage (from the repository root): bash tests/distributed/run.sh
# PETSC_DIR / SLEPC_DIR need not be set: tetlap.distributed finds Debian's prefixes itself,
# and they are unset here to keep it that way.
set -euo pipefail
cd "$(dirname "$0")/../.."
unset PETSC_DIR SLEPC_DIR
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

# Debian's petsc4py is not importable by itself in this venv; tetlap finds it.
"$venv/bin/python" - <<'EOF'
import importlib.util
assert importlib.util.find_spec("petsc4py") is None, "petsc4py is importable without tetlap"
from tetlap import distributed
PETSc, SLEPc = distributed._petsc(), distributed._slepc()
print("tetlap.distributed found PETSc", ".".join(map(str, PETSc.Sys.getVersion())),
      "and SLEPc", ".".join(map(str, SLEPc.Sys.getVersion())), "without PETSC_DIR")
EOF

failed=0
for n in 1 2 3; do
    mpirun --allow-run-as-root --oversubscribe -n "$n" "$venv/bin/python" tests/distributed/check.py || failed=1
done
exit "$failed"
