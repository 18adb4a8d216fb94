"""The machine: its limits, a feed profile along a path, the axis servo, the simulator and the controller model.
Imports :mod:`fuzzyfeed.geometry` and below (layer 3); never a planner, a program or a file format."""
