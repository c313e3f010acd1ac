"""Knowing whether a run really succeeded: declared outcomes, ground truth, failure chains.

* :mod:`.truth`: :class:`WorldTruth`, the world as a plugin that knows it (the
  simulation) reports it;
* :mod:`.predicates`: the vocabulary of ``expect:`` (``on``, ``in``, ``at``,
  ``held``, ``collisions``, ``missed_steps``) and the :class:`Predicate` base
  class plugins extend;
* :mod:`.expect`: reading a tree's ``expect:`` list, judging it, the run's verdict;
* :mod:`.failures`: the chain of reasons from the root to the leaf that failed.
"""
