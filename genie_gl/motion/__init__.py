"""Motion: the free floor, routes on it, how a body follows them, trajectories, rigs of
sensors on a body, and registration error along a path."""
