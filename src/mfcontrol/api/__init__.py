"""Controllers and plants as objects, configuration to arrays, runs, sweeps, results, figures."""
