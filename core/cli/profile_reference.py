"""The component reference of docs/profiles.md, generated from the plugin registry.

For each component section of a profile (``arm``, ``camera``, ``tracker``,
``planner``): every registered ``type``, what it is (the factory's first
docstring line) and its keys (the factory's ``PARAMS``: value type, unit,
default, allowed range, meaning), as Markdown tables. The reference covers the
plugins of the armtree distribution only, so it reads the same on every machine.
Then the sections plugins register (``armtree_profile_sections``) and their plugin.
``python -m armtree.cli.profile_reference --update docs/profiles.md`` rewrites the
part of that file between :data:`BEGIN` and :data:`END`, and each key table of a
section declared in :data:`armtree.config.profile_spec.KEY_TABLES` between its
own markers (:func:`table_markers`); a test fails while the file and the
declarations disagree.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from armtree.config.params import REQUIRED, Param
from armtree.config.profile_sections import COMPONENT_SECTIONS
from armtree.config.profile_spec import KEY_TABLES
from armtree.config.spec import key_table
from armtree.errors import ConfigError
from armtree.hooks.plugin_manager import Registry, get_plugin_manager

from .docgen import replace_generated

BEGIN = (
    "<!-- component reference: generated from the registered plugins by "
    "`python -m armtree.cli.profile_reference --update docs/profiles.md`; "
    "edit the factories' PARAMS, not this part -->"
)
END = "<!-- end of the component reference -->"


def component_reference(registry: Registry | None = None) -> str:
    """The reference as Markdown (no markers), for ``registry`` (the built-in plugins by default)."""
    if registry is None:
        registry = get_plugin_manager(autoload=False).registry
    out: list[str] = []
    for section, kind in COMPONENT_SECTIONS.items():
        out.append(f"### `{section}:` types\n")
        for name in registry.names(kind):
            factory = registry.get(kind, name).factory
            doc = (factory.__doc__ or "").strip().splitlines()
            out.append(f"#### `{section}: {{type: {name}}}`\n")
            if doc:
                out.append(_cell(doc[0]) + "\n")
            params = tuple(getattr(factory, "PARAMS", ()))
            if not params:
                out.append("No keys besides `type`.\n")
                continue
            out.append("| key | value | default | meaning |\n| --- | --- | --- | --- |")
            out.extend(_row(p) for p in params)
            out.append("")
    sections = registry.names("profile_section")
    if sections:
        out.append("### Sections plugins register\n")
        out.append("| section | plugin | what it is |\n| --- | --- | --- |")
        for name in sections:
            component = registry.get("profile_section", name)
            out.append(f"| `{name}` | {component.plugin} | {_cell(component.summary)} |")
        out.append("")
    return "\n".join(out).rstrip() + "\n"


def _row(param: Param) -> str:
    value = param.type + (f", {param.unit}" if param.unit else "")
    if param.bounded:
        value += f" {param.range_text()}"
    if param.choices:
        value += ": " + " / ".join(f"`{c}`" for c in param.choices)
    default = "required" if param.default is REQUIRED else f"`{param.default!r}`"
    return f"| `{param.name}` | {_cell(value)} | {_cell(default)} | {_cell(param.doc)} |"


def _cell(text: str) -> str:
    return str(text).replace("|", "\\|").replace("``", "`").replace("\n", " ")


def table_markers(section: str) -> tuple[str, str]:
    """The comment lines around the generated key table of ``section``."""
    return (
        f"<!-- keys of {section}: generated from its declaration by "
        "`python -m armtree.cli.profile_reference --update docs/profiles.md` -->",
        f"<!-- end of the keys of {section} -->",
    )


def replace_reference(text: str, where: str = "the document") -> str:
    """``text`` with the part between :data:`BEGIN` and :data:`END` regenerated, and the
    key table of each declared section whose markers it has."""
    text = replace_generated(text, BEGIN, END, component_reference(), where, "component reference")
    for section, (spec, needed) in KEY_TABLES.items():
        begin, end = table_markers(section)
        if begin in text:
            text = replace_generated(text, begin, end, key_table(spec, needed), where, "key table")
    return text


def main(argv: list[str] | None = None) -> int:
    """Print the reference, or ``--update FILE`` to rewrite it there."""
    parser = argparse.ArgumentParser(prog="python -m armtree.cli.profile_reference")
    parser.add_argument("--update", metavar="FILE", help="rewrite the reference in FILE")
    args = parser.parse_args(argv)
    if not args.update:
        sys.stdout.write(component_reference())
        return 0
    path = Path(args.update)
    try:
        text = path.read_text(encoding="utf-8")
        new = replace_reference(text, str(path))
    except (OSError, ConfigError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    if new != text:
        path.write_text(new, encoding="utf-8")
    print(f"{'updated' if new != text else 'up to date'}: {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
