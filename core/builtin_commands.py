"""Built-in plugin: the core ``armtree`` subcommands (check, show, plugins, schema)."""
