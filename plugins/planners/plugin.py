"""Registration of the built-in planners plugin (filled in as the components land)."""
