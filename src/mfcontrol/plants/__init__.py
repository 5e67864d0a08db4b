"""Plant models as pure step functions over float64 columns (numba-compiled)."""
