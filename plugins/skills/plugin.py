"""Registration of the built-in skills plugin (filled in as the components land)."""
