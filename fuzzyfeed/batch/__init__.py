"""Advise a whole library of programs and drawings on Dask, on one machine or a cluster (layer 9).

Imports the advice pipeline (:mod:`fuzzyfeed.advice`) and everything below it, never the command
line. ``library`` is the Python API, :func:`~fuzzyfeed.batch.library.advise_library` (also
``fuzzyfeed.advise_library``): the per-file work is :func:`~fuzzyfeed.advice.pipeline.advise_file`
with one options value sent to the workers as it is. ``discover`` finds the inputs, ``manifest``
keeps each file's key (input, options and version digests) and status, ``work`` runs a chunk of
files on a worker, ``cluster`` starts or reaches the Dask cluster, ``run`` drives a run,
``summary`` writes ``summary.csv`` and ``summary.html``.
"""
