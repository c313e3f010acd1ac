"""The command lines in-process: exit codes, messages, no tracebacks unless --debug."""

import importlib.metadata
import json
import re
import textwrap

import pytest

from armtree.cli.commandline import main, run_tree_main
from armtree.runtime.runlog import read_log

PLUGIN = '''
import threading
import armtree
from py_trees.common import Status


class LoseLink(armtree.Behaviour):
    """Raises a hardware fault on its second tick."""

    def initialise(self):
        self.n = 0

    def update(self):
        self.n += 1
        if self.n >= 2:
            raise armtree.HardwareFault("no status frame for 1 s", "/dev/ttyUSB0")
        return Status.RUNNING


class Divide(armtree.Behaviour):
    """Divides by zero."""

    def update(self):
        return 1 / 0


class Hello:
    help = "say hello"

    def configure(self, parser):
        parser.add_argument("who")
        parser.add_argument("--fail", action="store_true")

    def run(self, args):
        if args.fail:
            raise RuntimeError("the hello machine broke")
        print(f"hello {args.who}")
        return 0 if args.who != "nobody" else 1


@armtree.hookimpl
def armtree_behaviours():
    return {"lose_link": LoseLink, "divide": Divide}


@armtree.hookimpl
def armtree_commands():
    return {"hello": Hello()}
'''


#: Only the core plugins: these tests are about the command line, not about arms or skills.
ISOLATE = [
    arg
    for ep in importlib.metadata.entry_points(group="armtree")
    if ep.name not in ("core_behaviours", "core_commands")
    for arg in ("-p", f"no:{ep.name}")
]


def run_tree(args):
    return run_tree_main([*args, *ISOLATE])


def armtree(args):
    return main([*ISOLATE, *args])


def write(path, text):
    path.write_text(textwrap.dedent(text))
    return path


@pytest.fixture
def work(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    write(tmp_path / "ok.yaml", "tree: ok\nroot:\n  sequence: [{success: {}}, {success: {}}]\n")
    write(
        tmp_path / "spin.yaml",
        """\
        tree: spin
        tick_hz: 10
        root:
          sequence:
            name: Root
            children:
              - success: {name: Ready}
              - running: {name: Wait}
        """,
    )
    write(tmp_path / "plug.py", PLUGIN)
    return tmp_path


def test_success_exits_0_and_writes_the_log_under_runs(work, capsys):
    assert run_tree(["ok.yaml", "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "result: SUCCESS" in out
    logs = list((work / "runs").glob("ok-*/run.jsonl"))
    assert len(logs) == 1 and read_log(logs[0])[-1]["status"] == "SUCCESS"


def test_timeout_and_max_ticks_exit_1_with_a_message(work, capsys):
    assert run_tree(["spin.yaml", "--timeout", "2", "--record", "r1"]) == 1
    out = capsys.readouterr().out
    assert "timeout: 2 s" in out and "ticks: 20" in out
    assert run_tree(["spin.yaml", "--max-ticks", "3", "--quiet", "--record", "r2"]) == 1
    assert "max ticks: 3" in capsys.readouterr().out
    assert read_log(work / "r2" / "run.jsonl")[-1]["ticks"] == 3


def test_plain_status_lines_when_stdout_is_not_a_terminal(work, capsys):
    run_tree(["spin.yaml", "--max-ticks", "2", "--record", "r"])
    out = capsys.readouterr().out
    assert "tick 1 t=0.000s Root/Wait: INVALID -> RUNNING" in out
    assert "Root/Wait: RUNNING -> INVALID" in out


def test_invalid_tree_prints_every_error_with_position_and_exits_2(work, capsys):
    write(
        work / "bad.yaml",
        """\
        tree: bad
        root:
          sequence:
            - sucess: {}
            - running: {colour: red}
        """,
    )
    assert run_tree(["bad.yaml"]) == 2
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line]
    assert len(lines) >= 2
    for line in lines:
        assert re.match(r".*bad\.yaml:\d+:\d+: ", line), line
    assert "Traceback" not in err
    assert not (work / "runs").exists()


def test_missing_tree_and_bad_options_exit_2(work, capsys):
    assert run_tree(["nothing_here.yaml"]) == 2
    assert "nothing_here" in capsys.readouterr().err
    assert run_tree(["ok.yaml", "-p", "yes:foo"]) == 2
    assert "-p no:NAME" in capsys.readouterr().err
    assert run_tree(["ok.yaml", "--timeout", "-1"]) == 2
    with pytest.raises(SystemExit) as exc:
        run_tree(["ok.yaml", "--max-ticks", "many"])
    assert exc.value.code == 2


def test_hardware_fault_in_a_behaviour_exits_3(work, capsys):
    write(work / "link.yaml", "tree: link\nroot:\n  lose_link: {name: Move}\n")
    assert run_tree(["link.yaml", "--plugin", "plug.py", "--quiet", "--record", "r"]) == 3
    captured = capsys.readouterr()
    assert "/dev/ttyUSB0" in captured.out + captured.err
    assert "Traceback" not in captured.out + captured.err


def test_exception_in_a_behaviour_names_node_and_line_traceback_only_with_debug(work, capsys):
    write(
        work / "div.yaml",
        """\
        tree: div
        root:
          sequence:
            name: Maths
            children:
              - success: {}
              - divide: {name: Divide}
        """,
    )
    assert run_tree(["div.yaml", "--plugin", "plug.py", "--quiet", "--record", "r"]) == 1
    captured = capsys.readouterr()
    assert "ZeroDivisionError" in captured.out
    assert "Maths/Divide" in captured.out and "div.yaml:7" in captured.out
    assert "Traceback" not in captured.out + captured.err
    assert "--debug" in captured.err
    args = ["div.yaml", "--plugin", "plug.py", "--quiet", "--record", "r2", "--debug"]
    assert run_tree(args) == 1
    assert "Traceback" in capsys.readouterr().err
    events = [e for e in read_log(work / "r2" / "run.jsonl") if e.get("event") == "exception"]
    assert events and events[0]["node"] == "Maths/Divide"


def test_armtree_dispatches_plugin_commands_and_its_own(work, capsys):
    assert armtree(["--plugin", "plug.py", "hello", "world"]) == 0
    assert "hello world" in capsys.readouterr().out
    assert armtree(["hello", "nobody", "--plugin", "plug.py"]) == 1
    assert armtree(["run", "ok.yaml", "--quiet", "--record", "r"]) == 0
    assert json.loads((work / "r" / "run.jsonl").read_text().splitlines()[-1])["status"] == (
        "SUCCESS"
    )


def test_unexpected_errors_are_one_line_with_a_debug_hint(work, capsys):
    assert armtree(["--plugin", "plug.py", "hello", "x", "--fail"]) == 1
    err = capsys.readouterr().err
    assert err.strip() == (
        "error: RuntimeError: the hello machine broke (run again with --debug for the traceback)"
    )
    assert armtree(["--plugin", "plug.py", "--debug", "hello", "x", "--fail"]) == 1
    assert "Traceback" in capsys.readouterr().err


def test_a_plugin_that_fails_to_import_exits_2(work, capsys):
    write(work / "broken.py", "import does_not_exist\n")
    assert armtree(["--plugin", "broken.py", "bench", "--list"]) == 2
    err = capsys.readouterr().err
    assert "broken" in err and "Traceback" not in err


def test_bench_lists_the_builtin_and_script_benchmarks(work, capsys):
    (work / "benchmarks").mkdir()
    write(work / "benchmarks" / "bench_demo.py", "print('figure: 42')\n")
    assert armtree(["bench", "--list"]) == 0
    out = capsys.readouterr().out
    assert "runtime\tbuilt in" in out and "demo" in out
    assert armtree(["bench", "demo"]) == 0
    assert "figure: 42" in capsys.readouterr().out
    assert armtree(["bench", "nope"]) == 2


def test_a_plugin_command_may_not_take_the_name_run(work, capsys):
    write(
        work / "clash.py",
        """\
        import armtree


        class Run:
            help = "not the real run"

            def configure(self, parser):
                pass

            def run(self, args):
                return 0


        @armtree.hookimpl
        def armtree_commands():
            return {"run": Run()}
        """,
    )
    assert armtree(["--plugin", "clash.py", "run", "ok.yaml"]) == 2
    err = capsys.readouterr().err
    assert "clashes with armtree's own 'run'" in err and "-p no:clash" in err


def test_set_overrides_reach_the_run_and_its_log(work):
    write(
        work / "keys.yaml",
        "tree: keys\nblackboard: {speed: 1, home: [0, 0]}\nroot: {success: {}}\n",
    )
    args = ["keys.yaml", "--quiet", "--record", "r", "--set", "speed=3", "--set", "home=[1, 2]"]
    assert run_tree(args) == 0
    start = read_log(work / "r" / "run.jsonl")[0]
    assert start["blackboard"] == {"speed": 3, "home": [1, 2]}
    assert start["clock"] == "virtual" and start["seed"] == 0


def test_version_of_both_commands_even_with_a_broken_plugin(work, capsys):
    version = importlib.metadata.version("armtree")
    assert armtree(["--version"]) == 0
    assert capsys.readouterr().out == f"armtree {version}\n"
    assert run_tree(["--version"]) == 0
    assert capsys.readouterr().out == f"run-tree {version}\n"
    (work / "broken.py").write_text("raise ImportError('nope')\n")
    assert run_tree(["ok.yaml", "--plugin", "broken.py", "--version"]) == 0
    assert capsys.readouterr().out == f"run-tree {version}\n"
    # after a subcommand, --version is that command's unknown option: a usage error
    with pytest.raises(SystemExit) as exit_:
        armtree(["check", "--version"])
    assert exit_.value.code == 2
