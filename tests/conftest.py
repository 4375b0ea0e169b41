"""Test-session settings that must precede the first import of torch."""

import os

# As ``import inpaint360gs`` does (see its __init__): idle OpenMP threads of torch and numba sleep
# instead of spinning, or they steal the 2 CPU cores from each other. A test module that imports
# torch before the package would otherwise come too late.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
