"""Registration of the built-in trackers plugin (filled in as the components land)."""
