"""Tree files to validated py_trees trees, every error with its file, line and
column before anything runs; and the JSON Schema of what it accepts.

Layer 6 of 8 (docs/architecture.md): imports only hooks and the layers below.
"""
