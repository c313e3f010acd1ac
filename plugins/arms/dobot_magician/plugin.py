"""Registration of the built-in dobot_magician plugin (filled in as the components land)."""
