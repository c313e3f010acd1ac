"""The monitor page in a real browser (headless Chromium): a live simulated run, and a replay."""

import time

from monitor_helpers import ARMTREE, RUN_TREE, Proc, chromium, needs_browser

from armtree.runtime.runlog import read_log

pytestmark = needs_browser

LETTER = {"INVALID": "I", "RUNNING": "R", "SUCCESS": "S", "FAILURE": "F"}


def shown_statuses(page):
    """``{node path: status letter}`` as the page draws the tree."""
    return page.evaluate(
        """() => Object.fromEntries([...document.querySelectorAll('#tree .node')].map(
            (g) => [g.dataset.path, (g.getAttribute('class').match(/s-([RSFI])/) || [])[1]]))"""
    )


def wait_until(page, script, timeout=60.0):
    page.wait_for_function(script, timeout=timeout * 1000)


def test_a_live_run_shows_its_tree_statuses_and_camera_and_obeys_pause_step_stop(tmp_path):
    with chromium() as browser:
        proc = Proc(
            [RUN_TREE, "pick_and_place.yaml", "--monitor", "0", "--record", "rec"],
            tmp_path,
        )
        try:
            url = proc.url()
            page = browser.new_page(viewport={"width": 1400, "height": 900}, bypass_csp=True)
            errors = []
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.goto(url)
            page.select_option("#speed", "4")  # four run seconds per wall second
            # The tree renders: one box per node, the root among them.
            nodes = "document.querySelectorAll('#tree .node')"
            wait_until(page, f"{nodes}.length > 5")
            assert "Pick and place" in page.inner_text("#tree-wrap")
            assert "Look for the ducky" in page.inner_text("#tree-wrap")
            # Statuses change over ticks, and camera frames arrive as the pick looks.
            wait_until(page, "window.armtree.log.statusChanges >= 2")
            wait_until(page, "Number(document.querySelector('#camera').dataset.frames || 0) >= 2")
            assert shown_statuses(page)["Pick and place"] == "R"
            page.click("#btn-pause")
            wait_until(page, "document.body.dataset.state === 'paused'")
            held = int(page.evaluate("document.body.dataset.tick"))
            time.sleep(0.5)
            assert int(page.evaluate("document.body.dataset.tick")) == held
            page.click("#btn-step")
            wait_until(page, f"Number(document.body.dataset.tick) === {held + 1}")
            wait_until(page, "document.body.dataset.state === 'paused'")
            page.click("#btn-stop")
            wait_until(page, "document.body.dataset.state === 'ended-INTERRUPTED'")
            code, err = proc.finish(timeout=20)
            assert not errors, errors
        finally:
            proc.kill()
    assert code == 130, err
    assert "interrupted by stop from the monitor page" in err
    log = read_log(tmp_path / "rec" / "run.jsonl")
    assert [r["tick"] for r in log if r.get("event") == "step"] == [held]
    assert log[-1]["status"] == "INTERRUPTED"


def test_replay_scrubbed_to_a_tick_shows_the_statuses_of_run_jsonl(recorded_run):
    log = read_log(recorded_run / "run.jsonl")
    tree = next(r for r in log if r["kind"] == "tree")
    with chromium() as browser:
        proc = Proc([ARMTREE, "replay", recorded_run, "--port", "0"], recorded_run)
        try:
            url = proc.url()
            page = browser.new_page(viewport={"width": 1400, "height": 900}, bypass_csp=True)
            errors = []
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.goto(url)
            wait_until(page, "document.querySelectorAll('#tree .node').length > 0")
            ticks = log[-1]["ticks"]
            for tick in (ticks // 4, ticks // 2, ticks):
                page.locator("#tl-slider").fill(str(tick))
                wait_until(page, f"document.body.dataset.tick === '{tick}'")
                current = {n["path"]: "I" for n in tree["nodes"]}
                for r in log:
                    if r["kind"] == "status" and r["tick"] <= tick:
                        current[r["node"]] = LETTER[r["to"]]
                assert shown_statuses(page) == current, tick
            # the run's verdict (its status judged on the world) heads the outcome
            assert page.inner_text("#outcome").startswith("success · ")
            wait_until(page, "Number(document.querySelector('#camera').dataset.frames || 0) >= 1")
            assert not errors, errors
            code, _ = proc.interrupt()
            assert code == 130
        finally:
            proc.kill()
