"""Compilation settings shared by every compiled function of the package.

``error_model='numpy'`` lets a division by zero give inf/NaN instead of raising, which
keeps the kernels branch-free (so they vectorise) and turns a blow-up into data that the
engine flags. No fastmath: the published results are reproduced bit for bit, and LLVM
must not fuse multiply-adds or reorder sums behind our back.
"""

from numba import njit

#: Small step functions: inlined into every kernel that calls them.
step_jit = njit(inline="always", error_model="numpy", cache=True)
#: Kernels: compiled once, cached on disk next to the package.
kernel_jit = njit(error_model="numpy", cache=True)
