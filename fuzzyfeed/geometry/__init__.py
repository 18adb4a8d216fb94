"""Tool-path geometry: NURBS (seed 004's power basis), polylines and their fits, sampling, interpolation at Ts,
and their compiled kernels. Imports only :mod:`fuzzyfeed.base` and :mod:`fuzzyfeed.errors` (layer 2)."""
