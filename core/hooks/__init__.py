"""The plugin contract and its manager: hook specifications, finding, loading and
checking plugins, calling hooks, and the built-in py_trees behaviours plugin.

Layer 5 of 8 (docs/architecture.md): imports only the api and the layers below.
"""
