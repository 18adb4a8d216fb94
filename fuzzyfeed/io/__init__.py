"""File formats at the edge: shapes, CSV, G-code, DXF. Nothing in the core imports this package."""
