"""How a run is driven (Python side): ``solve``, events, ensembles and sweeps."""
