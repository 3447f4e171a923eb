"""Reports: figures (matplotlib) and a self-contained HTML page."""
