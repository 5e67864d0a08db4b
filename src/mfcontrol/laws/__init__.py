"""Control laws as pure step functions over float64 columns (numba-compiled): the laws,
their estimator of F and gain adaptation, and the reference they track."""
