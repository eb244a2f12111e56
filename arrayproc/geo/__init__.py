"""Geometry and motion: angle conventions, piecewise trajectories, the ownship navigation track,
array element geometry, and TDOA geometry."""
