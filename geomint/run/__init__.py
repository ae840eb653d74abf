"""How a run is driven (Python side), in dependency order: ``status`` (``Status``), ``arguments`` (the checks
every entry point shares), ``controller`` (step-size settings), ``chunks`` (the compiled loop in timed chunks,
Ctrl-C), ``checkpoint``, ``events``, ``solve``, ``ensemble`` (``solve_ensemble``, ``sweep``)."""
