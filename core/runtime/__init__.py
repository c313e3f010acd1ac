"""One run of a tree on a rig: the tick loop and its collaborators (clock pacing,
interrupts, run log, watchdog, halting, the result).

Layer 7 of 8 (docs/architecture.md): imports only the loader and the layers below.
"""
