"""Registration of the built-in vicra plugin (filled in as the components land)."""
