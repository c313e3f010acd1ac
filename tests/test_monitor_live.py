"""run-tree --monitor: the page's websocket, controls from two pages, tokens, bad input."""

import asyncio
import socket
import urllib.error
import urllib.request

import pytest
from monitor_helpers import COUNT_TREE, ONLY_MONITOR, Page, run_tree

from armtree.cli.commandline import run_tree_main
from armtree.runtime.runlog import read_log


@pytest.fixture
def count_tree(tmp_path):
    (tmp_path / "count.yaml").write_text(COUNT_TREE)
    return tmp_path


def test_two_pages_see_the_run_controls_act_once_and_a_paused_run_outlives_its_pages(count_tree):
    proc = run_tree("count.yaml", "--monitor", "0", "--record", "rec", cwd=count_tree)
    try:
        url = proc.url()

        async def scenario():
            a, b = await Page.open(url), await Page.open(url)
            for page in (a, b):
                await page.next("hello")
                state = await page.next("state")
                assert [n["path"] for n in state["tree"]["nodes"]] == [
                    "Root/Count",
                    "Root/Wait",
                    "Root",
                ]
            # Statuses change over ticks: Count runs, then Wait.
            await a.next("tick", lambda m: m["letters"] == "RIR")
            await a.next("tick", lambda m: m["letters"] == "SRR")
            await a.send(type="control", action="pause")
            for page in (a, b):
                await page.next("control", lambda m: m["state"] == "paused")
            await asyncio.sleep(0.4)
            tick_a = a.messages[-1]["tick"]
            # Both pages are told once; one step from page A is one tick for everyone.
            await a.send(type="control", action="step")
            stepped = await b.next("tick", lambda m: m["tick"] > tick_a)
            assert stepped["tick"] == tick_a + 1
            await b.next("control", lambda m: m["state"] == "paused")
            await asyncio.sleep(0.3)
            later = [m["tick"] for m in a.messages + b.messages if m.get("type") == "tick"]
            assert max(later) == tick_a + 1
            await b.send(type="control", action="resume")
            await a.next("tick", lambda m: m["tick"] > tick_a + 3)
            # Paused again, then every page closes: the run stays paused, nothing ticks.
            await b.send(type="control", action="pause")
            paused = await a.next("control", lambda m: m["state"] == "paused")
            await a.close()
            await b.close()
            await asyncio.sleep(0.6)
            again = await Page.open(url)
            state = await again.next("state")
            await again.close()
            return paused, state

        paused, state = asyncio.run(scenario())
        assert state["control"] == "paused"
        assert state["tick"] == paused["tick"]
        code, err = proc.interrupt()  # Ctrl-C still stops it
    finally:
        proc.kill()
    assert code == 130, err
    assert "the last page closed while the run is paused" in err
    assert "interrupted by SIGINT" in err
    log = read_log(count_tree / "rec" / "run.jsonl")
    events = [r["event"] for r in log if r["kind"] == "event"]
    assert events[:5] == ["paused", "step", "paused", "resumed", "paused"]
    assert log[-1]["status"] == "INTERRUPTED"


def test_a_monitor_host_that_is_not_this_machines_is_exit_2(count_tree, capsys, monkeypatch):
    monkeypatch.chdir(count_tree)
    code = run_tree_main(
        ["count.yaml", "--monitor", "0", "--monitor-host", "192.0.2.1", *ONLY_MONITOR]
    )
    err = capsys.readouterr().err
    assert code == 2
    assert (
        "--monitor-host: cannot listen on 192.0.2.1:0: 192.0.2.1 is not an address of this machine"
        in err
    )


def test_a_port_in_use_is_exit_2_before_anything_runs(count_tree, capsys, monkeypatch):
    monkeypatch.chdir(count_tree)
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        code = run_tree_main(
            ["count.yaml", "--monitor", str(port), "--record", "rec", *ONLY_MONITOR]
        )
    err = capsys.readouterr().err
    assert code == 2
    assert f"--monitor: port {port} on 127.0.0.1 is already in use" in err
    assert "Traceback" not in err
    assert not (count_tree / "rec").exists()


def test_a_tree_name_in_place_of_the_port_says_how_to_write_it(count_tree, capsys):
    with pytest.raises(SystemExit) as exited:
        run_tree_main(["--monitor", "count.yaml", *ONLY_MONITOR])
    assert exited.value.code == 2
    err = capsys.readouterr().err
    assert "is not a port number; write the tree first: run-tree TREE --monitor [PORT]" in err


def test_off_loopback_the_page_and_its_websocket_need_the_printed_token(count_tree):
    proc = run_tree(
        "count.yaml",
        "--monitor",
        "0",
        "--monitor-host",
        "0.0.0.0",
        "--record",
        "rec",
        cwd=count_tree,
    )
    try:
        url = proc.url()
        assert "?token=" in url
        base = url.split("?")[0].replace("0.0.0.0", "127.0.0.1")
        with pytest.raises(urllib.error.HTTPError) as refused:
            urllib.request.urlopen(base, timeout=10)
        assert refused.value.code == 403
        assert "token" in refused.value.read().decode()
        with pytest.raises(urllib.error.HTTPError):
            urllib.request.urlopen(base + "ws", timeout=10)
        good = url.replace("0.0.0.0", "127.0.0.1")
        page = urllib.request.urlopen(good, timeout=10).read().decode()
        assert "armtree monitor" in page and "/static/app.js" in page

        async def connect():
            page = await Page.open(good)
            state = await page.next("state")
            await page.close()
            return state

        assert asyncio.run(connect())["tree"]["name"] == "count"
        code, _ = proc.interrupt()
    finally:
        proc.kill()
    assert code == 130
