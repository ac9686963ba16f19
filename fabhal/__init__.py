"""FabHaL: a solver-aided language for fixture hacks."""

import os
import sys

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

if "numpy" in sys.modules:
    # loaded before FabHaL (a script, pytest): its BLAS read the variables already and
    # runs threaded, so a solve of a large model differed from the command line's (the
    # hoop on twelve chains: by 144 degrees in one turn, solved in one, not the other);
    # the limit is set where the library runs instead
    from threadpoolctl import threadpool_limits

    threadpool_limits(1)

__version__ = "0.1.0"
