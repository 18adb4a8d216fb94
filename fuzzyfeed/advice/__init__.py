"""One advice pipeline (issue 39): a program, a drawing or a shape advised with one typed options
value, and its result written, plotted or shown (layer 8).

Imports the report layer and everything below it, never the batch, the designer or the command
line: ``fuzzyfeed advise`` turns its flags into :class:`~fuzzyfeed.advice.options.AdviceOptions`
once and calls :func:`~fuzzyfeed.advice.pipeline.advise_file`; the batch sends the same options
value to its workers and the designer advises its path through :func:`~fuzzyfeed.advice.pipeline.
advise_path`. ``options`` is the value, ``pipeline`` the computation (the program, drawing and
shape helpers it calls keep their own modules: :mod:`fuzzyfeed.program.feeds`,
:mod:`fuzzyfeed.report.value`, :mod:`fuzzyfeed.fuzzy.advisor`), ``result`` what it returns,
``program`` and ``shape`` the results of each kind of file, ``gcode`` a shape's program export.
"""
