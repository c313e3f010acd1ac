"""Registration of the built-in sim plugin (filled in as the components land)."""
