"""Which blackboard keys a tree reads and writes, and what a load refuses because of them."""

from __future__ import annotations

from typing import Any

from armtree.config.yamlio import error_at
from armtree.errors import ConfigError, Mark, did_you_mean, shown

from .profile import Override


def root_key(key: str) -> str:
    """The blackboard key a bound name lives under (``/pose.x`` -> ``pose``)."""
    return key.lstrip("/").split(".")[0]


class BlackboardUse:
    """The blackboard keys one tree load has seen read, written, and given by ``--set``."""

    def __init__(self) -> None:
        #: (key, where it is read, the include it came through) for every input binding.
        self.reads: list[tuple[str, Mark | None, Mark | None]] = []
        self.writes: set[str] = set()
        #: Keys named literally by nodes that read them (py_trees' blackboard behaviours).
        self.literal_reads: set[str] = set()
        #: Blackboard keys given by --set, with the override that gave each.
        self.set_keys: dict[str, Override] = {}

    def read(self, key: str, mark: Mark | None, included_from: Mark | None) -> None:
        """A node reads ``key`` (bound at ``mark``)."""
        self.reads.append((root_key(key), mark, included_from))

    def write(self, key: str) -> None:
        """Something writes ``key``: an output binding, a blackboard writer, ``blackboard:``."""
        self.writes.add(root_key(key))

    def read_named(self, value: Any) -> None:
        """A node reads the keys its parameter names: a key, or the ``variable_name`` of
        each mapping in a list (py_trees' blackboard behaviours)."""
        if isinstance(value, str):
            self.literal_reads.add(root_key(value))
        elif isinstance(value, list):
            self.literal_reads.update(
                root_key(item["variable_name"])
                for item in value
                if isinstance(item, dict) and isinstance(item.get("variable_name"), str)
            )

    def given(self, key: str, override: Override) -> None:
        """``--set`` gives ``key`` (the first override for a key is the one reported)."""
        self.set_keys.setdefault(root_key(key), override)

    def unread_set_keys(
        self, declared: dict[str, Any] | None, sections: frozenset[str] = frozenset()
    ) -> list[ConfigError]:
        """A --set blackboard key that no node reads (nor the tree declares) is a typo;
        ``sections`` (the profile's, which --set may also address) feed the did-you-mean."""
        used = self.writes | self.literal_reads | {key for key, _, _ in self.reads}
        errors = []
        for key, override in self.set_keys.items():
            if key in used:
                continue
            options = sorted(used | set(declared or {}) | set(sections) | {"tick_hz"})
            hint = did_you_mean(key, options)
            errors.append(
                error_at(
                    f"no node of this tree reads blackboard key {shown(key)}{hint} (--set takes "
                    "a key the tree reads or declares in blackboard:, a declared parameter, "
                    "tick_hz or a profile section such as arm.port)",
                    override.mark,
                )
            )
        return errors

    def unwritten_reads(self) -> list[ConfigError]:
        """Every read of a key that nothing writes and no --set gives."""
        errors = []
        for key, mark, included_from in self.reads:
            if key not in self.writes and key not in self.set_keys:
                message = (
                    f"blackboard key {shown(key)} is read here but nothing writes it: bind an output "
                    f'parameter to "{{{key}}}", give it in blackboard:, or --set {key}=VALUE'
                )
                if included_from is not None:
                    message += f" (included from {included_from})"
                errors.append(error_at(message, mark))
        return errors
