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
own markers (:func:`table_markers`), and so the key tables of a section a plugin
registers with its declaration (:func:`declared_tables`: the sim's ``world:``); a
test fails while the file and the declarations disagree.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from armtree.config.params import REQUIRED, Param
from armtree.config.profile_sections import COMPONENT_SECTIONS
from armtree.config.profile_spec import KEY_TABLES
from armtree.config.spec import Either, Items, MapOf, OneOf, Record, Spec, key_table
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


def nested_records(spec: Spec, name: str) -> dict[str, Record]:
    """Every record in ``spec`` by the dotted name its table goes under: ``spec`` itself,
    a record's records (``world.table``), the entries of a mapping and the items of a
    list under the mapping's or list's name (``world.objects``), a shape under its own
    (``survey.ring``)."""
    inner: list[tuple[Spec, str]] = []
    if isinstance(spec, Record):
        inner = [(item, f"{name}.{key}") for key, item in spec.fields.items()]
    elif isinstance(spec, (MapOf, Items)):
        inner = [(spec.value if isinstance(spec, MapOf) else spec.item, name)]
    elif isinstance(spec, Either):
        inner = [(option, name) for option in spec.options]
    elif isinstance(spec, OneOf):
        inner = [(shape, f"{name}.{key}") for key, shape in spec.shapes.items()]
    out = {name: spec} if isinstance(spec, Record) else {}
    for item, path in inner:
        out |= {k: v for k, v in nested_records(item, path).items() if k not in out}
    return out


def declared_tables(registry: Registry) -> dict[str, tuple[Record, dict[str, str]]]:
    """The key tables of the sections plugins register with their declaration
    (``ProfileSection.spec``): the section's and each record's in it, by dotted
    name. A key that is a record of its own defaults to its keys' defaults."""
    out: dict[str, tuple[Record, dict[str, str]]] = {}
    for section in registry.names("profile_section"):
        spec = registry.get("profile_section", section).factory.spec
        if spec is None:
            continue
        for name, record in nested_records(spec, section).items():
            own = {
                k: v.absent or "its keys' defaults"
                for k, v in record.fields.items()
                if isinstance(v, Record)
            }
            out[name] = (record, own)
    return out


def replace_reference(text: str, where: str = "the document") -> str:
    """``text`` with the part between :data:`BEGIN` and :data:`END` regenerated, and the
    key table of each declared section (and plugin section's record) whose markers it has."""
    registry = get_plugin_manager(autoload=False).registry
    reference = component_reference(registry)
    text = replace_generated(text, BEGIN, END, reference, where, "component reference")
    for section, (spec, needed) in {**KEY_TABLES, **declared_tables(registry)}.items():
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
