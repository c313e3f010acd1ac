"""run-tree --monitor: the page's websocket, controls from two pages, tokens, bad input."""

import asyncio
import json
import socket
import time
import urllib.error
import urllib.request

import aiohttp
import pytest
from monitor_helpers import COUNT_TREE, ONLY_MONITOR, run_tree

from armtree.cli import run_tree_main
from armtree.runlog import read_log


class Page:
    """One open monitor page, seen through its websocket."""

    def __init__(self, ws, session):
        self.ws = ws
        self.session = session
        self.messages = []

    @classmethod
    async def open(cls, url):
        session = aiohttp.ClientSession()
        base, _, query = url.partition("?")
        ws = await session.ws_connect(base.rstrip("/") + "/ws" + (f"?{query}" if query else ""))
        return cls(ws, session)

    async def next(self, kind, check=lambda m: True, timeout=20.0):
        """The next message of ``kind`` for which ``check`` holds."""
        deadline = time.monotonic() + timeout
        while True:
            left = deadline - time.monotonic()
            assert left > 0, f"no {kind} message within {timeout} s"
            msg = await self.ws.receive(timeout=left)
            if msg.type == aiohttp.WSMsgType.BINARY:
                continue
            assert msg.type == aiohttp.WSMsgType.TEXT, msg
            data = json.loads(msg.data)
            self.messages.append(data)
            if data.get("type") == kind and check(data):
                return data

    async def send(self, **message):
        await self.ws.send_str(json.dumps(message))

    async def close(self):
        await self.ws.close()
        await self.session.close()


@pytest.fixture
def count_tree(tmp_path):
    (tmp_path / "count.yaml").write_text(COUNT_TREE)
    return tmp_path


def test_two_pages_see_the_run_and_controls_act_once_then_stop_exits_130(count_tree):
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
            await a.send(type="control", action="stop")
            end = await b.next("end")
            assert end["result"]["status"] == "INTERRUPTED"
            await a.close()
            await b.close()

        asyncio.run(scenario())
        code, err = proc.finish(timeout=20)
    finally:
        proc.kill()
    assert code == 130, err
    assert "interrupted by stop from the monitor page" in err
    log = read_log(count_tree / "rec" / "run.jsonl")
    events = [r["event"] for r in log if r["kind"] == "event"]
    assert events[:4] == ["paused", "step", "paused", "resumed"]
    assert log[-1]["status"] == "INTERRUPTED"


def test_closing_the_last_page_of_a_paused_run_leaves_it_paused_and_ctrl_c_still_stops_it(
    count_tree,
):
    proc = run_tree("count.yaml", "--monitor", "0", "--record", "rec", cwd=count_tree)
    try:
        url = proc.url()

        async def pause_and_leave():
            page = await Page.open(url)
            await page.next("tick", lambda m: m["letters"] == "SRR")
            await page.send(type="control", action="pause")
            paused = await page.next("control", lambda m: m["state"] == "paused")
            await page.close()
            await asyncio.sleep(0.6)
            again = await Page.open(url)
            state = await again.next("state")
            await again.close()
            return paused, state

        paused, state = asyncio.run(pause_and_leave())
        assert state["control"] == "paused"
        assert state["tick"] == paused["tick"]  # nothing ticked while no page was open
        code, err = proc.interrupt()
    finally:
        proc.kill()
    assert code == 130
    assert "the last page closed while the run is paused" in err
    assert "interrupted by SIGINT" in err


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
