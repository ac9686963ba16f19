"""FabHaL: a solver-aided language for fixture hacks."""

import os

# One thread for the numeric libraries, set before numpy loads. FabHaL's matrices
# are small (tens to a few hundred DoFs): on 2 cores OpenBLAS's threads made
# mid-size calls 100-600x slower at times (an SVD at n = 65: 96 ms against
# 0.64 ms), and results changed with the thread count (summation order). One
# thread is faster and makes a result the same on every machine. Parallel work
# (`fabhal bench`'s processes) runs whole solves side by side instead.
for _variable in (
    "OPENBLAS_NUM_THREADS",
    "OMP_NUM_THREADS",
    "MKL_NUM_THREADS",
    "BLIS_NUM_THREADS",
    "VECLIB_MAXIMUM_THREADS",
    "NUMEXPR_NUM_THREADS",
):
    os.environ[_variable] = "1"

__version__ = "0.1.0"
