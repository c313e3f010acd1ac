"""Configuration: YAML with positions, parameter declarations, hardware profiles and
their sections (workcell, calibration, components), files found by name.

Layer 3 of 8 (docs/architecture.md): imports only the maths and the errors.
"""
