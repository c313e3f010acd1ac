"""BehaviorTree.CPP v4 XML as armtree tree files: a tree drawn in Groot2 from armtree's
palette runs on the simulation; bad XML is a clear error at its file, line and column."""

from __future__ import annotations

import textwrap
import xml.etree.ElementTree as ET

import pytest

import armtree
from armtree.cli.commandline import main as armtree_main
from armtree.cli.commandline import run_tree_main
from armtree.hooks.plugin_manager import get_plugin_manager
from armtree.plugins.btcpp.writer import export_tree, palette
from armtree.runtime.runlog import read_log


def write(path, text):
    path.write_text(textwrap.dedent(text).lstrip("\n"))
    return path


def models(*ids: str) -> str:
    """The palette's entries for ``ids``, as Groot2 saves the models a file uses."""
    root = ET.fromstring(palette(get_plugin_manager().registry))
    kept = [m for m in root.find("TreeNodesModel") if m.get("ID") in ids]
    return "\n".join(ET.tostring(m, encoding="unicode") for m in kept)


def test_a_tree_drawn_from_the_palette_runs_on_the_simulation(tmp_path, capsys):
    # Compact and explicit forms, BT.CPP's own nodes, a SubTree in its own blackboard
    # (no _autoremap) with its ports, and the models Groot2 saves; _expect is armtree's.
    drawn = textwrap.dedent(
        """
        <?xml version="1.0" encoding="UTF-8"?>
        <root BTCPP_format="4" main_tree_to_execute="DuckyToBin">
          <BehaviorTree ID="FindAndGrasp">
            <Sequence name="Look, then grasp">
              <look tag="{what}" near="{where}" pose="{object_pose}" marker="{object_marker}"/>
              <Action ID="grasp" at="{object_pose}" tag="{what}" marker="{object_marker}"
                      rehome_on_failure="true"/>
            </Sequence>
          </BehaviorTree>
          <BehaviorTree ID="DuckyToBin"
                        _expect="[{object: ducky, at: garbage_bin, within_mm: 40}, {held: nothing}, {collisions: 0}]">
            <Sequence name="Ducky to the bin">
              <RetryUntilSuccessful num_attempts="3">
                <SubTree ID="FindAndGrasp" what="ducky" where="ducky_pickup"/>
              </RetryUntilSuccessful>
              <Condition ID="holding" name="Holding it?" tag="ducky"/>
              <place name="Into the bin" at="garbage_bin" object="ducky"/>
              <home/>
            </Sequence>
          </BehaviorTree>
          <TreeNodesModel>
            MODELS
            <SubTree ID="FindAndGrasp">
              <input_port name="what">tag role of the object</input_port>
              <input_port name="where">place to look around</input_port>
            </SubTree>
          </TreeNodesModel>
        </root>
        """
    ).lstrip()
    path = tmp_path / "drawn.xml"
    path.write_text(drawn.replace("MODELS", models("look", "grasp", "holding", "place", "home")))
    record = tmp_path / "run"
    code = run_tree_main([str(path), "--rig", "sim_dobot", "--quiet", "--record", str(record)])
    captured = capsys.readouterr()
    assert code == 0, captured.out + captured.err
    result = read_log(record / "run.jsonl")[-1]
    assert result["status"] == "SUCCESS" and result["verdict"] == "success"
    assert [e["status"] for e in result["expectations"]] == ["pass", "pass", "pass"]
    statuses = {r["node"] for r in read_log(record / "run.jsonl") if r["kind"] == "status"}
    assert "Ducky to the bin/retry/Look, then grasp/grasp" in statuses


def check(path, capsys) -> list[str]:
    """``armtree check PATH``: exit 2, the error lines."""
    assert armtree_main(["check", str(path)]) == 2
    return capsys.readouterr().err.strip().splitlines()


def tree(body: str, extra: str = "") -> str:
    return (
        '<root BTCPP_format="4">\n'
        f'  <BehaviorTree ID="main">\n{body}\n  </BehaviorTree>\n{extra}</root>\n'
    )


def test_malformed_xml_is_an_error_at_its_position(tmp_path, capsys):
    path = write(tmp_path / "t.xml", tree("    <Sequence>\n      <home/>\n    </Sequense>"))
    assert check(path, capsys) == [f"{path}:5:7: invalid XML: mismatched tag"]


def test_an_unknown_node_id_is_named_with_a_suggestion(tmp_path, capsys):
    path = write(
        tmp_path / "t.xml",
        tree('    <Sequence>\n      <hom/>\n      <Action ID="lok"/>\n    </Sequence>'),
    )
    assert check(path, capsys) == [
        f"{path}:4:7: unknown node type 'hom'; did you mean 'home'?",
        f"{path}:5:7: unknown node type 'lok'; did you mean 'look'?",
    ]


def test_a_port_that_is_not_a_parameter_is_an_error_at_the_attribute(tmp_path, capsys):
    path = write(tmp_path / "t.xml", tree('    <home speeed="0.5"/>\n'))
    lines = check(path, capsys)
    assert lines[0].startswith(f"{path}:3:11: home has no parameter 'speeed'")
    assert "did you mean 'speed'" in lines[0]
    path = write(tmp_path / "t.xml", tree('    <Timeout msecs="10"><home/></Timeout>\n'))
    lines = check(path, capsys)
    assert lines[0] == f"{path}:3:14: Timeout has no port 'msecs' (it takes msec)"


def test_a_missing_subtree_is_named_with_the_trees_there_are(tmp_path, capsys):
    path = write(
        tmp_path / "t.xml",
        tree('    <SubTree ID="Serch"/>', '  <BehaviorTree ID="Search"><home/></BehaviorTree>\n'),
    )
    assert check(path, capsys) == [
        f"{path}:3:18: <SubTree ID='Serch'>: the file has no <BehaviorTree ID='Serch'> "
        "(it has 'main', 'Search')"
    ]


def test_recursive_subtrees_are_an_include_cycle(tmp_path, capsys):
    path = write(
        tmp_path / "t.xml",
        tree(
            '    <SubTree ID="A"/>',
            '  <BehaviorTree ID="A"><Sequence><home/><SubTree ID="B"/></Sequence></BehaviorTree>\n'
            '  <BehaviorTree ID="B"><SubTree ID="A"/></BehaviorTree>\n',
        ),
    )
    lines = check(path, capsys)
    assert len(lines) == 1
    assert lines[0].startswith(f"{path}:6:37: include cycle: t.xml#A -> t.xml#B -> t.xml#A")


def test_entity_expansion_is_refused_before_it_expands(tmp_path, capsys):
    laughs = "".join(f'  <!ENTITY lol{i} "{f"&lol{i - 1};" * 10}">\n' for i in range(1, 10))
    path = write(
        tmp_path / "t.xml",
        '<?xml version="1.0"?>\n<!DOCTYPE root [\n  <!ENTITY lol0 "lol">\n'
        + laughs
        + ']>\n<root BTCPP_format="4"><BehaviorTree ID="m"><home name="&lol9;"/></BehaviorTree></root>\n',
    )
    lines = check(path, capsys)
    assert lines[0].startswith(f"{path}:2:1: the XML declares a document type")
    assert "billion laughs" in lines[0]


@pytest.mark.parametrize(
    ("body", "message"),
    [
        (
            '    <Delay delay_msec="10"><home/></Delay>',
            "3:5: BehaviorTree.CPP's Delay has no armtree counterpart",
        ),
        (
            '    <home _skipIf="x > 3"/>',
            "3:11: _skipIf: BehaviorTree.CPP's scripts are not run by armtree",
        ),
        (
            '    <Parallel success_count="2"><home/><home/></Parallel>',
            "3:5: Parallel: Parallel success_count=2, failure_count=1 has no armtree counterpart",
        ),
        (
            "    <Inverter><home/><home/></Inverter>",
            "3:22: Inverter is a decorator: it takes one child node, not 2",
        ),
        ("    <Sequence><home/></Sequence>\n    <home/>", "2:3: <BehaviorTree ID='main'> holds"),
    ],
)
def test_btcpp_nodes_and_attributes_armtree_cannot_run_are_named(tmp_path, capsys, body, message):
    path = write(tmp_path / "t.xml", tree(body))
    lines = check(path, capsys)
    assert lines[0].startswith(f"{path}:{message}"), lines


def test_ports_are_typed_by_the_files_model_and_bindings_kept(tmp_path):
    path = write(
        tmp_path / "t.xml",
        tree(
            '    <set_blackboard_variable variable_name="k" variable_value="3"/>',
            '  <TreeNodesModel><Action ID="set_blackboard_variable">'
            '<input_port name="variable_value" type="std::string"/></Action></TreeNodesModel>\n',
        ),
    )
    loaded = armtree.load_tree(path, manager=get_plugin_manager())
    assert [i.params for i in loaded.nodes.values()][0]["variable_value"] == "3"
    path = write(
        tmp_path / "u.xml",
        tree('    <Sequence><look tag="ducky" pose="{@found}"/><home speed="{=}"/></Sequence>'),
    )
    loaded = armtree.load_tree(path, manager=get_plugin_manager(), overrides=["speed=0.5"])
    params = {i.type: i.params for i in loaded.nodes.values()}
    assert params["look"]["pose"] == armtree.Binding("/found")
    assert params["home"]["speed"] == armtree.Binding("speed")


def test_subtree_ports_are_parameters_and_autoremap_shares_the_blackboard(tmp_path):
    path = write(
        tmp_path / "t.xml",
        tree(
            '    <Sequence>\n      <SubTree ID="Find" what="ducky" _autoremap="true"/>\n'
            '      <SubTree ID="Find" name="again" what="trash" found="{=}"/>\n    </Sequence>',
            '  <BehaviorTree ID="Find"><look tag="{what}" pose="{found}"/></BehaviorTree>\n',
        ),
    )
    loaded = armtree.load_tree(path, manager=get_plugin_manager())
    looks = [i.params for i in loaded.nodes.values() if i.type == "look"]
    # shared: {found} is the tree's own key; isolated (no _autoremap): its own namespace,
    # except a port given with the SubTree ({=}: the same name in the including tree)
    assert [(p["tag"], p["pose"]) for p in looks] == [
        ("ducky", armtree.Binding("found")),
        ("trash", armtree.Binding("found")),
    ]
    path = write(
        tmp_path / "u.xml",
        tree(
            '    <SubTree ID="Find" what="ducky"/>',
            '  <BehaviorTree ID="Find"><look tag="{what}" pose="{found}"/></BehaviorTree>\n',
        ),
    )
    loaded = armtree.load_tree(path, manager=get_plugin_manager())
    look = next(i.params for i in loaded.nodes.values() if i.type == "look")
    assert look["pose"] == armtree.Binding("Find/found")


def test_an_exported_xml_exports_to_the_same_xml(tmp_path):
    manager = get_plugin_manager()
    first = tmp_path / "a.xml"
    first.write_text(export_tree("load_ducky", manager))
    assert export_tree(first, manager) == first.read_text()


def test_without_a_model_ports_take_the_registered_parameters_types(tmp_path):
    # a hand-written file with no <TreeNodesModel>: YAML would read "on" as true and
    # "0;0;20" as text; the registered skills say a tag is text and an offset a vector
    from armtree.plugins.btcpp.reader import read_tree

    path = write(
        tmp_path / "t.xml",
        tree(
            '    <Sequence><look tag="on"/><visual_servo tag="ducky" offset="0;0;20"/></Sequence>'
        ),
    )
    look, servo = read_tree(path)["root"]["sequence"]["children"]
    assert look["look"]["tag"] == "on"
    assert list(servo["visual_servo"]["offset"]) == [0, 0, 20]


def test_vectors_travel_as_btcpp_writes_them(tmp_path):
    text = export_tree("touch_tag", get_plugin_manager())
    root = ET.fromstring(text)
    assert root.get("main_tree_to_execute") == root.find("BehaviorTree").get("ID")
    offsets = [e.get("offset") for e in root.iter("visual_servo")]
    assert offsets and all(";" in o and "[" not in o for o in offsets), offsets


def test_a_node_described_twice_in_the_model_is_an_error_at_the_second(tmp_path, capsys):
    entry = '<Action ID="home"/>'
    path = write(
        tmp_path / "t.xml",
        tree("    <home/>", f"  <TreeNodesModel>\n    {entry}\n    {entry}\n  </TreeNodesModel>\n"),
    )
    lines = check(path, capsys)
    assert lines[0].startswith(f"{path}:7:17: <Action ID='home'> is described twice")
    assert "first at line 6" in lines[0]
