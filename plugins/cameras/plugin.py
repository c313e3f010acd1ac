"""Registration of the built-in cameras plugin (filled in as the components land)."""
