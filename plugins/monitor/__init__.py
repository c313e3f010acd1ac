"""See the robot think: the live monitor page, replay of recorded runs, MCAP recordings,
hot reload of the tree file.

* :mod:`.model`: the tree as the page draws it, and statuses as one letter per node;
* :mod:`.observer`: what one tick changed, sampled on the run's thread;
* :mod:`.taps`: the frames, detections and plans the skills got from the rig;
* :mod:`.scene`: the arm, the objects, the camera's view and the planned path in numbers;
* :mod:`.recording` and :mod:`.schemas`: ``run.mcap`` with Foxglove's schemas;
* :mod:`.server`: the page and its websocket (aiohttp, on a thread of its own);
* :mod:`.session`: what the monitor keeps for one run, and hands to the page and the recording;
* :mod:`.live`, :mod:`.recorded` and :mod:`.replay`: what feeds the page, from a run or
  from a recording read back;
* :mod:`.watch`: ``--watch``, swapping in a changed tree at a safe point;
* :mod:`.chromium`: Debian's chromium as the browser tests and benchmarks start it;
* :mod:`.plugin`: the hooks that tie them to a run, and ``armtree replay``.
"""
