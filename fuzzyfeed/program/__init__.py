"""G-code programs: the program model, its reader, cuts on their exact geometry, advised feeds, the program
written back and programs written from shapes. Imports the planners and below (layer 5), never :mod:`fuzzyfeed.io`."""
