"""What a run gives back: ``Solution``, its dense output, saving and loading."""
