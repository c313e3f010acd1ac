"""Arms built from serial bus servos: the SO-101 (Feetech STS3215) and the Koch (Dynamixel).

Modules: :mod:`.bus` (what both protocols share), :mod:`.feetech` and
:mod:`.dynamixel` (the two protocols), :mod:`.tables` (servo models and their
control tables), :mod:`.servo` (one simulated servo), :mod:`.emulator` (the bus
behind a pseudo-terminal).
"""
