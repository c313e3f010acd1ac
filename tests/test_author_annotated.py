"""Plain py_trees behaviours declare tag roles and places with typing.Annotated, and
`armtree check` resolves them against the profile as it does armtree's own skills (issue 29)."""

from __future__ import annotations

from typing import Annotated

import pytest
from plugin_author import armtree, write

from armtree import Place, Position, TagRole
from armtree.config.constructor_params import param_kind, yaml_type
from armtree.config.params import ParamKind

SKILLS = """
    from typing import Annotated

    import py_trees
    from py_trees.common import Status

    import armtree
    from armtree import Place, TagRole


    class Point(py_trees.behaviour.Behaviour):
        \"\"\"Points at a tag from a place.\"\"\"

        def __init__(
            self,
            name: str,
            tag: Annotated[str, TagRole],
            at: Annotated[str | list[float], Place] = "home",
        ):
            super().__init__(name=name)
            self.tag, self.at = tag, at

        def update(self):
            return Status.SUCCESS


    @armtree.hookimpl
    def armtree_behaviours():
        return {"point": Point}
"""


def tree(tag: str, at: str) -> str:
    return f"""
        plugins: [my_skills.py]
        rig: sim_dobot
        root:
          sequence:
            - success: {{}}
            - point: {{tag: {tag}, at: {at}}}
    """


def test_check_resolves_annotated_tag_roles_and_places_against_the_profile(tmp_path):
    folder = write(tmp_path, {"my_skills.py": SKILLS, "t.yaml": tree("duck", "[900, 0, 50]")})
    done = armtree(folder, "check", "t.yaml")
    assert done.returncode == 2, done.stdout
    assert done.stderr.splitlines() == [
        f"{folder / 't.yaml'}:6:20: point.tag: unknown tag role 'duck' in the profile "
        "sim_dobot; did you mean 'ducky'?",
        f"{folder / 't.yaml'}:6:30: point.at: [900.0, 0.0, 50.0] mm is out of the reach of "
        "the profile's arm (dobot_v1)",
    ]
    folder = write(tmp_path, {"t.yaml": tree("ducky", "garbage_bin")})
    done = armtree(folder, "check", "t.yaml")
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith("ok: t: 3 nodes")


@pytest.mark.parametrize(
    ("annotation", "kind", "type_name"),
    [
        (Annotated[str, TagRole], "tag_role", "str"),
        (Annotated[str, Place], "place", "str"),
        (Annotated[list[float], Position], "position", "vector"),
        (Annotated[str, TagRole] | None, "tag_role", "str"),
        (Annotated[str | None, Place], "place", "str"),
        (Annotated[str, "a note"], "", "str"),
        (str, "", "str"),
    ],
)
def test_the_kind_and_type_of_an_annotated_parameter(annotation, kind, type_name):
    assert param_kind(annotation) == kind
    assert yaml_type(annotation)[0] == type_name


def test_a_param_kind_names_a_kind_armtree_resolves():
    with pytest.raises(ValueError, match="kind must be one of 'place', 'tag_role', 'position'"):
        ParamKind("colour")
