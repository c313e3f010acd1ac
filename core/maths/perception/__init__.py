"""The shared maths of perception: where a seen marker is in the arm's base frame
(camera-to-base transforms and the small calibrations behind them) and pose filters.
Framework-free: nothing here imports the runtime, the loader or a plugin."""
