"""See the robot think: the live monitor page, replay of recorded runs, MCAP recordings,
hot reload of the tree file.

* :mod:`.model`: the tree as the page draws it, and statuses as one letter per node;
* :mod:`.observer`: what one tick changed, sampled on the run's thread;
* :mod:`.taps`: the frames, detections and plans the skills got from the rig;
* :mod:`.scene`: the arm, the objects, the camera's view and the planned path in numbers;
* :mod:`.recording` and :mod:`.schemas`: ``run.mcap`` with Foxglove's schemas;
* :mod:`.server`: the page and its websocket (aiohttp, on a thread of its own);
* :mod:`.live` and :mod:`.replay`: what feeds the page, from a run or from a recording;
* :mod:`.watch`: ``--watch``, swapping in a changed tree at a safe point;
* :mod:`.plugin`: the hooks that tie them to a run, and ``armtree replay``.
"""
