"""The command lines: the console scripts (Ctrl-C held from the first import),
options and exit codes, the core subcommands, sweeps, benchmarks, the
new-plugin scaffold and the generated parts of the docs.

Layer 8 of 8 (docs/architecture.md), the top of core: plugins may import it.
"""
