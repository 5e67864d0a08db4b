"""Numerical building blocks shared by every plant: the one RK4, the one Dormand-Prince 5(4),
the zero-order-hold discretisation, the time grid, and the signatures plant functions are
compiled with."""
