"""Registration of the built-in dobot_v1 plugin (filled in as the components land)."""
