"""What every layer may use: argument checks, the per-curve cache, shipped and user files, atomic outputs.
Imports only :mod:`fuzzyfeed.errors` (layer 1 of the flow documented in the README's *How it is built*)."""
