"""JSON Schema of tree files and hardware profiles, built from the plugin registry.

An editor with YAML language support (``# yaml-language-server: $schema=...``)
completes and checks node types, their parameters and component types as a
file is typed. One document covers both formats: a file with a ``profile:`` or
``arm:`` key is checked as a profile, anything else as a tree. ``{param}``
strings are accepted for every parameter, since they are blackboard bindings or
subtree parameters that the loader resolves.
"""

from __future__ import annotations

from typing import Any

from armtree.api.factories import COMPOSITE, DECORATOR, node_kind
from armtree.api.outcomes.predicates import BUILTIN_PREDICATES, Predicate
from armtree.config.constructor_params import declared_params
from armtree.config.params import Param
from armtree.config.profile_sections import COMPONENT_SECTIONS
from armtree.config.profile_spec import SECTION_SPECS
from armtree.hooks.plugin_manager import Registry

from .subtree_include import SUBTREE_KEYS

DRAFT = "http://json-schema.org/draft-07/schema#"
NODE_REF = {"$ref": "#/definitions/node"}
NAME = {"type": "string", "description": "the node's name in views and logs (default: its type)"}
PLACEHOLDER = {"type": "string", "pattern": r"\{[A-Za-z_]\w*\}"}


def param_schema(param: Param) -> dict[str, Any]:
    """A parameter's schema: its value, a binding or placeholder, or null when that is the default."""
    schema = param.json_schema()
    if not schema:
        return {"description": param.doc} if param.doc else {}
    if param.type == "vector" and "anyOf" in schema and "items" in schema["anyOf"][0]:
        # a subtree parameter may stand for one coordinate: offset: [0, 0, "{hover_mm}"]
        schema["anyOf"][0]["items"] = {"anyOf": [{"type": "number"}, PLACEHOLDER]}
    options = [schema]
    options.append(PLACEHOLDER)
    if not param.required and param.default is None:
        options.append({"type": "null"})
    return {"anyOf": options} if len(options) > 1 else options[0]


def _params_object(params: tuple[Param, ...], extra: dict[str, Any]) -> dict[str, Any]:
    properties: dict[str, Any] = {"name": NAME, **extra}
    for param in params:
        properties[param.name] = param_schema(param)
    required = [p.name for p in params if p.required] + [k for k in extra if k in ("child",)]
    schema: dict[str, Any] = {
        "type": "object",
        "properties": properties,
        "additionalProperties": False,
    }
    if required:
        schema["required"] = required
    return schema


def node_type_schema(name: str, factory: Any) -> dict[str, Any]:
    """The schema of a one-key mapping ``{name: spec}`` for one node type."""
    params = declared_params(factory)
    kind = node_kind(factory)
    doc = (getattr(factory, "__doc__", None) or "").strip().splitlines()
    if kind == COMPOSITE:
        children = {"type": "array", "items": NODE_REF}
        spec: dict[str, Any] = {
            "anyOf": [children, _params_object(params, {"children": children})],
        }
        spec["anyOf"][1]["required"] = ["children", *spec["anyOf"][1].get("required", [])]
    elif kind == DECORATOR:
        spec = _params_object(params, {"child": NODE_REF})
    else:
        spec = _params_object(params, {})
        if "required" not in spec:
            spec = {"anyOf": [spec, {"type": "null"}]}
    if doc:
        spec["description"] = doc[0]
    return {
        "type": "object",
        "properties": {name: spec},
        "required": [name],
        "additionalProperties": False,
    }


def tree_definitions(registry: Registry) -> dict[str, Any]:
    """``definitions`` for a tree file: ``node`` and ``tree``."""
    # The include's own keys, kept apart so the check below can read them as a dict.
    include_keys = {
        "file": {"type": "string", "description": "tree file, relative to this one"},
        "with": {"type": "object", "description": "parameter values"},
        "name": NAME,
        "namespace": {
            "type": "string",
            "description": "prefix for the blackboard keys this instance keeps to itself",
        },
    }
    assert set(include_keys) == set(SUBTREE_KEYS)
    subtree = {
        "type": "object",
        "properties": {
            "subtree": {
                "type": "object",
                "description": "include another tree file, substituting its {param} references",
                "properties": include_keys,
                "required": ["file"],
                "additionalProperties": False,
            }
        },
        "required": ["subtree"],
        "additionalProperties": False,
    }
    nodes = [node_type_schema(c.name, c.factory) for c in registry.all() if c.kind == "behaviour"]
    params_decl = {
        "anyOf": [
            {"type": "array", "items": {"type": "string"}},
            {
                "type": "object",
                "additionalProperties": {
                    "anyOf": [
                        {"type": "null"},
                        {
                            "type": "object",
                            "properties": {"default": {}, "doc": {"type": "string"}},
                            "additionalProperties": False,
                        },
                    ]
                },
            },
        ],
        "description": "parameters this tree takes (with: in a subtree, --set at the top)",
    }
    tree = {
        "type": "object",
        "properties": {
            "tree": {"type": "string", "description": "the tree's name"},
            "description": {"type": "string"},
            "task": {
                "type": "string",
                "description": "the instruction a dataset episode of this tree is labelled with "
                "(LeRobot's task; default: the tree's name)",
            },
            "rig": {"type": "string", "description": "default hardware profile"},
            "tick_hz": {"type": "number", "exclusiveMinimum": 0, "description": "ticks per second"},
            "plugins": {"type": "array", "items": {"type": "string"}},
            "params": params_decl,
            "blackboard": {"type": "object", "description": "initial blackboard values"},
            "expect": expect_schema(_predicates(registry)),
            "root": NODE_REF,
        },
        "required": ["root"],
        "additionalProperties": False,
    }
    return {"node": {"anyOf": [*nodes, subtree]}, "tree": tree}


def _predicates(registry: Registry) -> dict[str, Predicate]:
    # A plugin's clash with a built-in key is reported when a tree loads, not here.
    return {**registry.instances("predicate"), **BUILTIN_PREDICATES}


def expect_schema(predicates: dict[str, Predicate]) -> dict[str, Any]:
    """The schema of ``expect:``: a list of entries, each naming one predicate."""
    subject = {
        "anyOf": [{"type": "string"}, {"type": "array", "items": {"type": "string"}}],
        "description": "a body's name or tag role, or a list of them",
    }
    entries = []
    for key, predicate in sorted(predicates.items()):
        properties: dict[str, Any] = {key: dict(predicate.VALUE) or {}}
        doc = (type(predicate).__doc__ or "").strip().splitlines()
        if doc:
            properties[key]["description"] = doc[0]
        if predicate.SUBJECT != "none":
            properties["object"] = {**subject, "description": "at least one of these bodies"}
            properties["objects"] = {**subject, "description": "every one of these bodies"}
        properties.update(predicate.OPTIONS)
        entry: dict[str, Any] = {
            "type": "object",
            "properties": properties,
            "required": [key],
            "additionalProperties": False,
        }
        if predicate.SUBJECT == "required":
            entry["oneOf"] = [{"required": ["object"]}, {"required": ["objects"]}]
        entries.append(entry)
    return {
        "type": "array",
        "items": {"anyOf": entries},
        "description": "what must be true of the world when the tree ends (judged in simulation)",
    }


def component_schema(registry: Registry, kind: str) -> dict[str, Any]:
    """A profile component section: one alternative per registered type."""
    options = []
    for name in registry.names(kind):
        component = registry.get(kind, name)
        properties: dict[str, Any] = {"type": {"const": name, "description": component.summary}}
        for param in component.params:
            properties[param.name] = param_schema(param)
        schema: dict[str, Any] = {
            "type": "object",
            "properties": properties,
            "required": ["type", *(p.name for p in component.params if p.required)],
        }
        if component.params:
            schema["additionalProperties"] = False
        options.append(schema)
    if not options:
        return {"type": "object", "required": ["type"], "properties": {"type": {"type": "string"}}}
    return {"anyOf": options}


def profile_definition(registry: Registry) -> dict[str, Any]:
    """The schema of a hardware profile."""
    properties: dict[str, Any] = {
        "profile": {"type": "string", "description": "the profile's name"},
        "description": {"type": "string"},
        **{
            section: component_schema(registry, kind)
            for section, kind in COMPONENT_SECTIONS.items()
        },
        "plugins": {"type": "array", "items": {"type": "string"}},
        "include": {
            "description": "files laid over this profile (calibration files), beside it or in the working directory",
            "anyOf": [{"type": "string"}, {"type": "array", "items": {"type": "string"}}],
        },
        **{name: spec.schema() for name, spec in SECTION_SPECS.items()},
    }
    for name in registry.names("profile_section"):
        properties.setdefault(name, dict(registry.get("profile_section", name).factory.schema))
    return {
        "type": "object",
        "properties": properties,
        "required": ["arm"],
        "additionalProperties": False,
    }


def build_schema(registry: Registry) -> dict[str, Any]:
    """The JSON Schema (draft 7) of tree files and hardware profiles for this registry."""
    definitions = tree_definitions(registry)
    definitions["profile"] = profile_definition(registry)
    return {
        "$schema": DRAFT,
        "title": "armtree tree file or hardware profile",
        "definitions": definitions,
        "if": {"anyOf": [{"required": ["profile"]}, {"required": ["arm"]}]},
        "then": {"$ref": "#/definitions/profile"},
        "else": {"$ref": "#/definitions/tree"},
    }
