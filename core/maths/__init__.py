"""The shared maths: motion (transforms, kinematic models, collision, workspace,
trajectories) and perception (marker frames, hand-eye calibration, pose filters).

Layer 2 of 8 (docs/architecture.md): imports only :mod:`armtree.errors`.
"""
