"""Compiled closed-loop kernels."""
