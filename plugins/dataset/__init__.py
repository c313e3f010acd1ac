"""Runs as training data: each run appended as an episode to a LeRobotDataset v3.0 folder.

* :mod:`.layout`: the folder's paths, defaults, features and rollover rule (LeRobot's v3.0);
* :mod:`.deps`: pyarrow and PyAV, imported on first use with an error naming the extra;
* :mod:`.recorder`: one run sampled at the dataset's fps through the rig's public parts
  (joint readings, commanded joints, the tool, the camera frames the run read);
* :mod:`.video`: the camera's frames as h264 (PyAV), and MP4 files joined without re-encoding;
* :mod:`.episode`: a recorded episode staged in a folder of its own until it is appended;
* :mod:`.stats`: per-episode statistics and their aggregate (``meta/stats.json``);
* :mod:`.transaction`: several files replaced as one, so a dataset is never half-written;
* :mod:`.lock`: one writer per dataset folder;
* :mod:`.store`: reading a dataset's metadata and data back (pyarrow);
* :mod:`.writer`: appending staged episodes: data, videos, episodes, tasks, stats, info;
* :mod:`.check`: the checks LeRobot's loader makes, for ``armtree dataset check``;
* :mod:`.session`: what ``run-tree --dataset`` and ``armtree sweep --dataset`` keep;
* :mod:`.commands`: ``armtree dataset info|check``;
* :mod:`.plugin`: the hooks that tie them to runs and sweeps.
"""
