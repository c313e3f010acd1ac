"""Built-in plugin: every py_trees behaviour, composite and decorator under its snake_case name."""
