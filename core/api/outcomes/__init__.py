"""Knowing whether a run really succeeded: declared outcomes, ground truth, failure chains.

* :mod:`.truth`: :class:`WorldTruth`, the world as a plugin that knows it (the
  simulation) reports it;
* :mod:`.predicates`: the vocabulary of ``expect:`` (``on``, ``in``, ``at``,
  ``held``, ``collisions``, ``missed_steps``) and the :class:`Predicate` base
  class plugins extend;
* :mod:`.expect`: reading a tree's ``expect:`` list, judging it, the run's verdict;
* :mod:`.failures`: the chain of reasons from the root to the leaf that failed.
"""

from __future__ import annotations

from .expect import (
    FAIL,
    NOT_CHECKED,
    PASS,
    Expectation,
    ExpectationResult,
    judge,
    parse_expectations,
    predicates_for,
    verdict,
)
from .failures import FailureLog, NodeFailure, chain_text, reason_key
from .predicates import BUILTIN_PREDICATES, Judgement, Predicate
from .truth import WorldObject, WorldTruth

__all__ = [
    "BUILTIN_PREDICATES",
    "FAIL",
    "NOT_CHECKED",
    "PASS",
    "Expectation",
    "ExpectationResult",
    "FailureLog",
    "Judgement",
    "NodeFailure",
    "Predicate",
    "WorldObject",
    "WorldTruth",
    "chain_text",
    "judge",
    "parse_expectations",
    "predicates_for",
    "reason_key",
    "verdict",
]
