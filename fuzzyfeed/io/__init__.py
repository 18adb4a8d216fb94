"""File formats at the edge: shapes, point lists, DXF drawings, CSV, a program's cuts as shapes.
Imports :mod:`fuzzyfeed.program` and below (layer 6); nothing below the report layer imports this package."""
