"""Registration of the built-in dh plugin (filled in as the components land)."""
