"""Reports: every method simulated alike (compare), the time/error trade-off, the value of advice, and plots.
Imports everything below it (layer 7); only the advice pipeline, the CLI, the batch and the designer import it."""
