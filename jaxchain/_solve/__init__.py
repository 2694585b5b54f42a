"""Solving: options, the one solve loop, simulate, ensembles, processes, result codes."""
