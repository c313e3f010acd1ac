"""Built-in marker trackers (aruco, hamming) and the vision commands (detect, markers, calibrate)."""
