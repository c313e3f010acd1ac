"""armtree trees as BehaviorTree.CPP v4 XML: BT.CPP itself loads and ticks every shipped
tree's export, and export then import gives the same tree (shipped trees and generated ones)."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import behaviortreepy as bt
import pytest
import yaml
from btcpp_shapes import shape
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import armtree
from armtree.cli.commandline import main as armtree_main
from armtree.config.resolve import shipped_dir
from armtree.hooks.plugin_manager import get_plugin_manager
from armtree.plugins.btcpp.writer import export_tree

SHIPPED = sorted(p.stem for p in shipped_dir("tree").glob("*.yaml"))
#: Values a shipped tree needs to be checked (search.yaml's tag has no default).
NEEDS = {"search": ["tag=duckybot"]}
#: Every registered behaviour's name: the nodes of armtree's palette.
PALETTE = sorted(get_plugin_manager().registry.names("behaviour"))


@pytest.fixture(scope="module")
def manager():
    return get_plugin_manager()


def exported(name: str, manager) -> str:
    return export_tree(name, manager, overrides=NEEDS.get(name, ()))


def btcpp_tree(text: str, ticked: list[str]) -> bt.Tree:
    """The exported XML loaded by BehaviorTree.CPP, its custom leaves as stubs.

    Every behaviour of armtree's palette is registered as a node first, as a BT.CPP
    user who loaded the palette has them, so BT.CPP refuses a ``<BehaviorTree>`` or
    ``<SubTree>`` ID that is a node's name, as it would in a C++ program.
    behaviortreepy 0.1.4 registers Python nodes without ports (its
    ``register_simple_action`` takes none), and BT.CPP refuses a port its node does
    not declare; so each leaf the ``<TreeNodesModel>`` declares stands in as a
    ``<SubTree ID="stub.LEAF">`` (which takes any port as a remapping) whose tree is
    one stub action that records the leaf and succeeds (fails under an Inverter). The
    stubs' IDs are none of the file's, so no stub replaces a real tree (asserted).
    Everything else is the XML as exported: BT.CPP's built-ins with their ports, the
    subtrees with their remaps. The file is loaded as docs/tree_files.md says: every
    tree registered, the first one created by its ID. The main tree's parameters go on
    the root blackboard, from their model defaults.
    """
    root = ET.fromstring(text)
    models = root.find("TreeNodesModel")
    leaves = {m.get("ID") for m in models if m.tag in ("Action", "Condition")}
    others = [m.get("ID") for m in models if m.tag in ("Control", "Decorator")]
    assert not others, f"custom composites or decorators in a shipped tree: {others}"
    trees = [t.get("ID") for t in root.findall("BehaviorTree")]
    # A leaf under an Inverter is a check the tree wants false (sort's "Nothing left in
    # hand"): its stub fails, so the inverted check passes as in a run that went well.
    inverted = {child.tag for parent in root.iter("Inverter") for child in parent}
    for element in root.iter():
        if element.tag in leaves:
            element.attrib = {"ID": f"stub.{element.tag}", **element.attrib}
            element.tag = "SubTree"
    factory = bt.BehaviorTreeFactory()
    for node_id in PALETTE:
        factory.register_simple_action(node_id, lambda node: bt.NodeStatus.FAILURE)
    for leaf in sorted(leaves):
        stub = ET.SubElement(root, "BehaviorTree", ID=f"stub.{leaf}")
        ET.SubElement(stub, f"stub_{leaf}")

        def tick(node, leaf=leaf):
            ticked.append(leaf)
            return bt.NodeStatus.FAILURE if leaf in inverted else bt.NodeStatus.SUCCESS

        factory.register_simple_action(f"stub_{leaf}", tick)
    factory.register_behavior_tree_from_text(ET.tostring(root, encoding="unicode"))
    registered = factory.registered_behavior_trees()
    assert sorted(registered) == sorted(trees + [f"stub.{leaf}" for leaf in leaves])
    blackboard = bt.Blackboard.create()
    model = models.find(f"SubTree[@ID='{trees[0]}']")
    for port in model if model is not None else ():
        if port.get("default") is not None:
            blackboard.set_string(port.get("name"), port.get("default"))
    return factory.create_tree(trees[0], blackboard)


@pytest.mark.parametrize("name", SHIPPED)
def test_every_shipped_tree_loads_and_ticks_in_behaviortree_cpp(name, manager):
    text = exported(name, manager)
    ticked: list[str] = []
    tree = btcpp_tree(text, ticked)
    assert tree.tick_while_running() == bt.NodeStatus.SUCCESS
    assert ticked, "no stub leaf was ticked"


def test_load_ducky_ticks_in_behaviortree_cpp_in_armtree_order(manager):
    ticked: list[str] = []
    tree = btcpp_tree(exported("load_ducky", manager), ticked)
    assert tree.tick_while_running() == bt.NodeStatus.SUCCESS
    # the search's reactive fallback: clean-up (its trash carried, then ForceFailure),
    # then the tag in view; then track, pick (look, grasp), holding, put, home
    assert ticked == [
        "check_blackboard_variable_value",
        "tag_visible",
        "pick",
        "place",
        "tag_visible",
        "track",
        "look",
        "grasp",
        "holding",
        "look",
        "release",
        "home",
    ]


# the search's reactive fallback: the clean-up check, the trash carried (then
# ForceFailure), the tag in view
SEARCH = ["check_blackboard_variable_value", "tag_visible", "pick", "place", "tag_visible"]


@pytest.mark.parametrize(
    ("name", "leaves"),
    [
        ("track", [*SEARCH, "track"]),
        ("search", SEARCH),
        ("clean_up", ["tag_visible", "pick", "place", "sweep", "home"]),
    ],
)
def test_a_tree_named_like_a_node_loads_as_itself_in_behaviortree_cpp(name, leaves, manager):
    # track.yaml is the tree "track" with the skill "track" in it: BT.CPP refuses a tree
    # with a registered node's name, so its ID is "track_tree", its name in _tree
    text = exported(name, manager)
    main = ET.fromstring(text).find("BehaviorTree")
    assert (main.get("ID"), main.get("_tree")) == (f"{name}_tree", name)
    ticked: list[str] = []
    assert btcpp_tree(text, ticked).tick_while_running() == bt.NodeStatus.SUCCESS
    assert ticked == leaves


def test_export_maps_to_btcpp_built_ins_and_keeps_the_rest_as_models(manager):
    root = ET.fromstring(exported("load_ducky", manager))
    trees = [t.get("ID") for t in root.findall("BehaviorTree")]
    assert trees == ["load_ducky", "search_tree", "clear_trash"]
    main = root.find("BehaviorTree")
    assert main.get("_rig") == "sim_dobot" and main.get("_tick_hz") == "20"
    sequence = main[0]
    assert (sequence.tag, sequence.get("name")) == ("Sequence", "Load a ducky")
    retry = sequence[0]
    assert (retry.tag, retry.get("num_attempts")) == ("RetryUntilSuccessful", "3")
    subtree = retry[0][0]
    assert subtree.attrib == {"ID": "search_tree", "tag": "duckybot", "_autoremap": "true"}
    timeout = retry[0][1]
    assert (timeout.tag, timeout.get("msec")) == ("Timeout", "120000")
    assert timeout[0].attrib["pose"] == "{duckybot_pose}"
    search = root.find("BehaviorTree[@ID='search_tree']")
    assert search.get("_tree") == "search"
    assert search[0][0].tag == "ReactiveFallback"  # selector: re-checked every tick
    model = root.find("TreeNodesModel")
    kinds = {m.get("ID"): m.tag for m in model}
    assert kinds["holding"] == "Condition" and kinds["grasp"] == "Action"
    assert kinds["search_tree"] == "SubTree" and "Sequence" not in kinds
    look = model.find("Action[@ID='look']")
    ports = {p.get("name"): (p.tag, p.get("type"), p.get("default")) for p in look}
    assert ports["pose"] == ("output_port", None, None)
    assert ports["tag"] == ("input_port", "std::string", None)
    assert ports["speed"] == ("input_port", "double", "1.0")
    assert look.find("input_port[@name='settle_s']").text.endswith("[s]")


@pytest.mark.parametrize("name", SHIPPED)
def test_export_then_import_gives_the_same_tree(name, manager, tmp_path):
    path = tmp_path / f"{name}.xml"
    path.write_text(exported(name, manager))
    original = armtree.load_tree(name, manager=manager, overrides=NEEDS.get(name, ()))
    again = armtree.load_tree(path, manager=manager, overrides=NEEDS.get(name, ()))
    assert shape(again) == shape(original)


def test_the_export_command_writes_a_file_and_the_palette(tmp_path, capsys):
    out = tmp_path / "t.xml"
    assert armtree_main(["export", "touch_tag", "--format", "btcpp", "-o", str(out)]) == 0
    assert ET.parse(out).getroot().find("BehaviorTree").get("ID") == "touch_tag"
    assert armtree_main(["export", "--palette"]) == 0
    palette = ET.fromstring(capsys.readouterr().out)
    models = {m.get("ID"): m.tag for m in palette.find("TreeNodesModel")}
    registered = get_plugin_manager().registry.names("behaviour")
    assert set(models) == set(registered)
    assert models["tag_visible"] == "Condition" and models["visual_servo"] == "Action"
    assert models["sequence"] == "Control" and models["retry"] == "Decorator"


def test_an_invalid_tree_is_not_exported(tmp_path, capsys):
    bad = tmp_path / "bad.yaml"
    bad.write_text("root: {sequence: [{sucess: {}}]}\n")
    out = tmp_path / "bad.xml"
    assert armtree_main(["export", str(bad), "-o", str(out)]) == 2
    assert f"{bad}:1:20: unknown node type 'sucess'" in capsys.readouterr().err
    assert not out.exists()


# ---------------------------------------------------------------------------
# Generated trees
# ---------------------------------------------------------------------------

_names = st.text(
    alphabet=st.characters(
        codec="utf-8", exclude_categories=("Cc", "Cs"), exclude_characters="/{}"
    ),
    min_size=1,
    max_size=12,
).filter(lambda s: s.strip() == s and s)
_values = st.one_of(
    st.integers(-5, 5),
    st.floats(-1e3, 1e3, allow_nan=False).map(lambda f: round(f, 3)),
    st.booleans(),
    st.none(),
    st.sampled_from(["3", "true", "on", "no", "[1, 2]", "a: b", "x", "", " spaced ", "{k}"]),
    st.lists(st.integers(0, 9), max_size=3),
)


def _leaf() -> st.SearchStrategy:
    return st.one_of(
        st.just({"success": {}}),
        st.just({"failure": {}}),
        st.builds(lambda d: {"tick_counter": {"duration": d}}, st.integers(0, 3)),
        st.builds(lambda s: {"wait": {"seconds": s}}, st.sampled_from([0.0, 0.25, 1.0, 0.0005])),
        # skills with text and vector parameters (a tag role of sim_dobot's, an offset)
        st.builds(lambda t: {"look": {"tag": t}}, st.sampled_from(["ducky", "duckybot"])),
        st.builds(
            lambda t, o: {"visual_servo": {"tag": t, "offset": o}},
            st.sampled_from(["ducky", "duckybot"]),
            st.lists(st.floats(-30, 30).map(lambda f: round(f, 2)), min_size=3, max_size=3),
        ),
        st.builds(
            lambda v: {"set_blackboard_variable": {"variable_name": "k", "variable_value": v}},
            _values,
        ),
        st.builds(
            lambda v, op: {
                "check_blackboard_variable_value": {
                    "variable_name": "k",
                    "value": v,
                    "operator": op,
                }
            },
            _values,
            st.sampled_from(["eq", "ne"]),
        ),
    )


def _decorated(child: st.SearchStrategy) -> st.SearchStrategy:
    options = st.sampled_from(
        [
            ("inverter", {}),
            ("failure_is_success", {}),
            ("success_is_failure", {}),
            ("pass_through", {}),
            ("running_is_failure", {}),
            ("retry", {"num_failures": 2}),
            ("retry", {"num_failures": 0}),
            ("repeat", {"num_success": 2}),
            ("timeout", {"duration": 1.5}),
            ("timeout", {"duration": 0.0004}),
            ("one_shot", {}),
            ("one_shot", {"policy": "on_successful_completion"}),
        ]
    )
    return st.builds(lambda o, c: {o[0]: {**o[1], "child": c}}, options, child)


def _composite(children: st.SearchStrategy) -> st.SearchStrategy:
    options = st.sampled_from(
        [
            ("sequence", {}),
            ("sequence", {"memory": False}),
            ("selector", {}),
            ("selector", {"memory": True}),
            ("parallel", {}),
            ("parallel", {"policy": "success_on_one"}),
            ("parallel", {"synchronise": False}),
        ]
    )
    return st.builds(
        lambda o, c: {o[0]: {**o[1], "children": c}},
        options,
        st.lists(children, min_size=1, max_size=3),
    )


def _named(node: dict, name: str | None) -> dict:
    if name is not None:
        next(iter(node.values()))["name"] = name
    return node


_trees = st.recursive(
    _leaf(),
    lambda inner: st.builds(
        _named, st.one_of(_decorated(inner), _composite(inner)), st.none() | _names
    ),
    max_leaves=8,
)


@settings(
    max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    root=_trees,
    tick_hz=st.sampled_from([10, 20.0, 12.5]),
    blackboard=st.dictionaries(st.sampled_from(["k", "a", "b"]), _values, max_size=2),
    # tree names that are node names too (armtree's, BT.CPP's) travel as NAME_tree
    name=st.sampled_from(["gen", "track", "look", "Sequence", "SubTree", "gen_tree"]),
)
def test_generated_trees_survive_export_and_import(
    root, tick_hz, blackboard, name, tmp_path_factory
):
    folder = tmp_path_factory.mktemp("gen")
    source = folder / "gen.yaml"
    data = {
        "tree": name,
        "rig": "sim_dobot",
        "tick_hz": tick_hz,
        "blackboard": {"k": 0, **blackboard},
        "root": root,
    }
    source.write_text(yaml.safe_dump(data, allow_unicode=True))
    manager = get_plugin_manager()
    try:
        original = armtree.load_tree(source, manager=manager)
    except armtree.ConfigError:
        return  # a generated combination armtree refuses is not exported either
    target = folder / "gen.xml"
    target.write_text(export_tree(source, manager))
    assert shape(armtree.load_tree(target, manager=manager)) == shape(original)


def test_a_tree_of_skills_named_like_a_node_survives_export_and_import(tmp_path):
    # what the generator draws, written out once: armtree accepts it, so the round trip
    # above is not vacuous for skills with text and vector parameters
    source = tmp_path / "gen.yaml"
    source.write_text(
        "tree: look\nrig: sim_dobot\nroot:\n  sequence:\n    children:\n"
        "      - look: {tag: ducky}\n"
        "      - visual_servo: {tag: duckybot, offset: [0.5, -2, 20]}\n"
    )
    manager = get_plugin_manager()
    original = armtree.load_tree(source, manager=manager)
    target = tmp_path / "gen.xml"
    target.write_text(export_tree(source, manager))
    assert 'offset="0.5;-2;20"' in target.read_text()
    assert shape(armtree.load_tree(target, manager=manager)) == shape(original)
