"""What behaviours and components program against: the rig and its component
interfaces, the clock, the behaviour base class and the skills' base (``skill``), the emulator and measuring-device
contracts, camera intrinsics, and the world as a run's outcomes are judged on it.

Layer 4 of 8 (docs/architecture.md): imports only config, maths and errors.
"""
