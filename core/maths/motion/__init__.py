"""The shared maths of motion: transforms, kinematic models, collision, triangle tests,
intervals, workspace covering, trajectories, the collision scene, meshes, motion
validation and kinematic calibration. Framework-free: nothing here imports the
runtime, the loader or a plugin."""
