"""``armtree sweep``: a tree over many seeds, each run in a fresh process, and the report.

* :mod:`.options`: ``--seeds A-B`` and ``--scheduler tcp://HOST:PORT``;
* :mod:`.task`: one run as a child process gets it, and the outcome it sends back;
* :mod:`.forker`: a process that loaded armtree once and forks a fresh child per run;
* :mod:`.pool`: the local pool (``--workers N``);
* :mod:`.cluster`: a Dask cluster (``--scheduler tcp://HOST:PORT``);
* :mod:`.report`: ``report.md``, ``sweep.json`` and the histograms;
* :mod:`.command`: the command line, the progress bar, Ctrl-C.
"""
