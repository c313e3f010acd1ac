"""armtree sweep: seeds in parallel, each in its own process, on this machine or a Dask cluster."""

from __future__ import annotations

import contextlib
import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from armtree import ConfigError
from armtree.cli.commandline import main
from armtree.cli.sweep.cluster import check_tree_on_worker
from armtree.cli.sweep.options import check_address, parse_seeds
from armtree.cli.sweep.report import markdown, summarise, wilson
from armtree.cli.sweep.task import RunTask

NODES = '''
import os
import signal
import time
from pathlib import Path

import armtree
from py_trees.common import Status


class SeedSays(armtree.Behaviour):
    """Ends as the seed says: a multiple of 3 fails, 4 dies once, 5 hangs, 7 runs long."""

    def initialise(self):
        here = Path(os.environ.get("SWEEP_MARKS", "."))
        with open(here / "pids.txt", "a") as fh:
            fh.write(f"{self.runtime.seed} {os.getpid()}\\n")
        import cv2

        with open(here / "opencv_threads.txt", "a") as fh:
            fh.write(f"{cv2.getNumThreads()}\\n")

    def update(self):
        seed = self.runtime.seed
        here = Path(os.environ.get("SWEEP_MARKS", "."))
        if seed == 4 and not (here / "died-once").exists():
            (here / "died-once").write_text("")
            os.kill(os.getpid(), signal.SIGKILL)
        if seed == 5:
            time.sleep(3600)
        if seed == 7:
            return Status.RUNNING
        if seed % 3 == 0:
            self.feedback_message = f"seed {seed} is a multiple of 3"
            return Status.FAILURE
        return Status.SUCCESS


@armtree.hookimpl
def armtree_behaviours():
    return {"seed_says": SeedSays}
'''

TREE = """\
tree: seeds
plugins: [sweep_nodes.py]
root:
  sequence:
    name: Task
    children:
      - seed_says: {name: Judge}
"""


@pytest.fixture
def work(tmp_path, monkeypatch):
    (tmp_path / "sweep_nodes.py").write_text(NODES)
    (tmp_path / "seeds.yaml").write_text(TREE)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("SWEEP_MARKS", str(tmp_path))
    return tmp_path


def pids(work):
    return [line.split() for line in (work / "pids.txt").read_text().splitlines()]


# -- options and bad input ------------------------------------------------------------


def test_seed_ranges():
    assert parse_seeds("1-1000") == range(1, 1001)
    assert parse_seeds(" 7 ") == range(7, 8)
    assert len(parse_seeds("10-1000009")) == 1_000_000
    for text, message in [
        ("5-1", "write 1-5"),
        ("x", "range A-B"),
        ("-3", "range A-B"),
        ("1-", "range A-B"),
        ("0-1000000", "1000001 runs; one sweep takes at most 1,000,000"),
    ]:
        with pytest.raises(ConfigError, match=message) as info:
            parse_seeds(text)
        assert info.value.file == f"--seeds {text}"


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--seeds", "5-1"], "--seeds 5-1: the range ends before it starts; write 1-5"),
        (["--seeds", "x"], "--seeds x: give a range A-B"),
        (
            ["--seeds", "1-2", "--scheduler", "localhost:8786"],
            "give the scheduler's address as tcp://HOST:PORT",
        ),
        (["--seeds", "1-2", "--workers", "0"], "--workers 0: give at least 1"),
        (["--seeds", "1-2", "--run-timeout", "0"], "give a positive number of seconds"),
        (["--seeds", "1-2", "--out", "seeds.yaml/x"], "--out seeds.yaml/x: cannot write there"),
    ],
)
def test_bad_options_exit_2_before_anything_runs(work, capsys, args, message):
    assert main(["sweep", "seeds.yaml", *args]) == 2
    err = capsys.readouterr().err
    assert message in err
    assert ": --" not in err  # the option is named once: "--seeds 5-1: ...", not "--seeds: --seeds"
    assert not (work / "sweeps").exists()


def test_a_folder_holding_a_sweep_is_refused_without_overwrite(work, capsys):
    (work / "old").mkdir()
    (work / "old" / "sweep.json").write_text("{}")
    assert main(["sweep", "seeds.yaml", "--seeds", "1", "--out", "old"]) == 2
    assert (
        "--out old: already holds a sweep (sweep.json); give another folder, or --overwrite"
        in capsys.readouterr().err
    )
    assert (work / "old" / "sweep.json").read_text() == "{}"


def test_a_scheduler_that_does_not_answer_exits_3_naming_it(work, capsys):
    started = time.monotonic()
    assert main(["sweep", "seeds.yaml", "--seeds", "1", "--scheduler", "tcp://127.0.0.1:9"]) == 3
    assert time.monotonic() - started < 20
    assert "no Dask scheduler answers at tcp://127.0.0.1:9" in capsys.readouterr().out


def test_something_that_answers_but_is_not_a_scheduler_exits_3_naming_it(work, capsys):
    """A web server where the scheduler should be (the dashboard's port, a proxy)."""
    server = socket.create_server(("127.0.0.1", 0))
    port = server.getsockname()[1]

    def answer_http():
        with contextlib.suppress(OSError):
            while True:
                conn, _ = server.accept()
                with conn:
                    conn.recv(1024)
                    conn.sendall(b"HTTP/1.1 400 Bad Request\r\ncontent-length: 0\r\n\r\n")

    threading.Thread(target=answer_http, daemon=True).start()
    try:
        started = time.monotonic()
        args = ["sweep", "seeds.yaml", "--seeds", "1", "--scheduler", f"tcp://127.0.0.1:{port}"]
        assert main(args) == 3
        assert time.monotonic() - started < 20
    finally:
        server.close()
    out = capsys.readouterr()
    assert f"something answers at tcp://127.0.0.1:{port} but it is not a Dask scheduler" in out.out
    assert "Traceback" not in out.out + out.err


def test_check_address():
    assert check_address("tcp://10.0.0.5:8786") == "tcp://10.0.0.5:8786"
    assert check_address("tls://[::1]:8786") == "tls://[::1]:8786"
    for bad in ("10.0.0.5:8786", "tcp://host", "tcp://host:0", "http://host:80", ""):
        with pytest.raises(ConfigError):
            check_address(bad)


def test_a_worker_that_cannot_load_the_tree_says_why(work):
    task = RunTask(
        tree=str(work / "seeds.yaml"),
        seed=1,
        run_dir=str(work / "r"),
        plugins=("no_such_plugin_xyz",),
    )
    assert "no_such_plugin_xyz" in check_tree_on_worker(task)
    assert check_tree_on_worker(RunTask(tree=str(work / "seeds.yaml"), seed=1, run_dir="r")) == "ok"


# -- the report ------------------------------------------------------------------------------


def outcome(seed, verdict, reason="", expectations=(), status=None, seconds=1.0):
    return {
        "seed": seed,
        "attempt": 1,
        "status": status or ("SUCCESS" if verdict in ("success", "false success") else "FAILURE"),
        "verdict": verdict,
        "exit_code": 0,
        "ticks": 10,
        "seconds": seconds,
        "wall_seconds": seconds / 10,
        "reason": reason,
        "message": reason,
        "expectations": [{"expect": e, "status": s, "measured": None} for e, s in expectations],
        "events": {},
        "log": None,
    }


def test_runs_get_one_opencv_thread_only_when_every_core_has_a_run(monkeypatch):
    from armtree.cli.sweep.pool import run_environment

    monkeypatch.delenv("OPENCV_FOR_THREADS_NUM", raising=False)
    assert run_environment(2, cores=2) == {"OPENCV_FOR_THREADS_NUM": "1"}
    assert run_environment(3, cores=2) == {"OPENCV_FOR_THREADS_NUM": "1"}
    assert run_environment(1, cores=2) == {}
    monkeypatch.setenv("OPENCV_FOR_THREADS_NUM", "2")
    assert run_environment(2, cores=2) == {}, "the user's own setting is kept"


def test_wilson_interval():
    low, high = wilson(93, 100)
    assert low == pytest.approx(0.8626, abs=1e-4) and high == pytest.approx(0.9657, abs=1e-4)
    assert wilson(0, 10)[0] == pytest.approx(0.0, abs=1e-12) and wilson(0, 10)[1] == pytest.approx(
        0.2775, abs=1e-4
    )
    assert wilson(10, 10)[1] == pytest.approx(1.0, abs=1e-12)
    assert wilson(0, 0) == (0.0, 1.0)


def test_the_report_counts_false_outcomes_apart_and_groups_reasons():
    on = ("ducky on duckybot", "pass")
    off = ("ducky on duckybot", "fail")
    runs = [
        outcome(1, "success", expectations=[on]),
        outcome(2, "false success", "false success: ducky on duckybot", [off]),
        outcome(3, "failure", "Load > Pick: no ducky seen after 3 looks", [off]),
        outcome(4, "failure", "Load > Pick: no ducky seen after 12 looks", [off]),
        outcome(5, "false failure", "Load > Home: arm busy", [on]),
        outcome(6, "success", expectations=[on]),
    ]
    sweep = {
        "tree": "load_ducky.yaml",
        "rig": "sim_dobot",
        "overrides": ["clean_up=false"],
        "seeds": [1, 6],
        "requested": 6,
        "scheduler": None,
        "workers": 2,
        "command": "armtree sweep ...",
        "wall_seconds": 9.0,
    }
    report = summarise(sweep, runs)
    s = report["summary"]
    assert (
        s["runs"],
        s["successes"],
        s["false_successes"],
        s["false_failures"],
        s["failures"],
    ) == (6, 2, 1, 1, 2)
    assert s["success_rate"] == pytest.approx(2 / 6)
    assert report["reasons"][0] == {
        "reason": "Load > Pick: no ducky seen after N looks",
        "runs": 2,
        "share": pytest.approx(2 / 6),
        "example": "Load > Pick: no ducky seen after 3 looks",
        "seeds": [3, 4],
    }
    assert report["expectations"] == [
        {"expect": "ducky on duckybot", "pass": 3, "fail": 3, "not_checked": 0, "pass_rate": 0.5}
    ]
    assert report["replay"][0] == {
        "seed": 2,
        "command": "run-tree load_ducky.yaml --rig sim_dobot --set clean_up=false --seed 2 --record replay-2",
    }
    text = markdown(report)
    assert "**success rate: 33.3 %** (2 of 6), 95 % Wilson interval 9.7 % to 70.0 %" in text
    assert "**false successes: 1**" in text and "false failures: 1" in text
    assert "| 2 | 33.3 % | Load > Pick: no ducky seen after 3 looks | 3, 4 |" in text


# -- real sweeps -----------------------------------------------------------------------------


@pytest.mark.slow
def test_a_local_sweep_runs_each_seed_in_its_own_process_and_reports(work, capsys, monkeypatch):
    import armtree.cli.sweep.command as command
    import armtree.cli.sweep.pool as pool

    written = []
    monkeypatch.setattr(command, "CHECKPOINT_S", 0.0)
    monkeypatch.setattr(pool.os, "cpu_count", lambda: 2)  # two workers fill two cores
    monkeypatch.delenv(
        "OPENCV_FOR_THREADS_NUM", raising=False
    )  # a report after every run, as it goes
    real_write = command.write_report
    monkeypatch.setattr(
        command,
        "write_report",
        lambda out, report: (written.append(report["summary"]["runs"]), real_write(out, report)),
    )
    code = main(
        [
            "sweep",
            "seeds.yaml",
            "--seeds",
            "1-6",
            "--workers",
            "2",
            "--run-timeout",
            "5",  # seed 5 hangs; the one-tick runs need well under this on a loaded machine
            "--out",
            "out",
        ]
    )
    printed = capsys.readouterr().out
    assert code == 1, printed
    report = json.loads((work / "out" / "sweep.json").read_text())
    assert "in_progress" not in report["sweep"]
    assert written == [1, 2, 3, 4, 5, 6, 6], "a report while it ran, then the final one"
    s = report["summary"]
    assert (s["runs"], s["successes"], s["failures"], s["timeouts"], s["retried"]) == (
        6,
        3,
        3,
        1,
        1,
    )
    by_seed = {o["seed"]: o for o in report["runs"]}
    assert by_seed[4]["attempt"] == 2 and by_seed[4]["verdict"] == "success"
    assert (
        by_seed[5]["status"] == "TIMEOUT"
        and by_seed[5]["reason"] == "run timeout: killed after 5 s of wall time"
    )
    assert by_seed[3]["reason"] == "Task > Judge: seed 3 is a multiple of 3"
    assert [r["seeds"] for r in report["reasons"]] == [[3, 6], [5]]
    assert (
        "seed 4: the run's process died (signal 9)" in printed and "running it once more" in printed
    )
    seen = pids(work)
    assert len({pid for _, pid in seen}) == len(seen) == 7, (
        "every run (and the retry) had its own process"
    )
    assert os.getpid() not in {int(pid) for _, pid in seen}
    threads = (work / "opencv_threads.txt").read_text().split()
    assert threads == ["1"] * 7, "with a run on every core, each run's OpenCV has one thread"
    out = work / "out"
    assert (out / "report.md").read_text().startswith("# Sweep of ")
    for png in ("sim_time.png", "wall_time.png"):
        assert (out / png).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    log = Path(by_seed[3]["log"])
    assert log.is_file() and log.is_relative_to(out / "runs" / "seed-3")
    assert (
        "run-tree" in report["replay"][0]["command"]
        and "--seed 3" in report["replay"][0]["command"]
    )
    assert main(["sweep", "seeds.yaml", "--seeds", "1", "--out", "out", "--overwrite"]) == 0
    assert json.loads((out / "sweep.json").read_text())["summary"]["runs"] == 1


@pytest.mark.slow
def test_ctrl_c_halts_the_runs_and_writes_a_partial_report(work):
    sweep = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "armtree.cli",
            "sweep",
            "seeds.yaml",
            "--seeds",
            "6-7",
            "--workers",
            "2",
            "--out",
            "out",
            "--timeout",  # seed 7 runs until stopped (else 600 s of its virtual clock)
            "inf",
        ],
        cwd=work,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    deadline = time.monotonic() + 90
    while not (work / "out" / "runs" / "seed-6" / "outcome.json").exists():
        assert time.monotonic() < deadline and sweep.poll() is None
        time.sleep(0.2)
    while len(pids(work)) < 2:  # seed 7 is under way (it never ends by itself)
        time.sleep(0.2)
    time.sleep(0.5)
    sweep.send_signal(signal.SIGINT)
    output, _ = sweep.communicate(timeout=60)
    assert sweep.returncode == 130, output
    assert "interrupted: halting the runs under way" in output
    report = json.loads((work / "out" / "sweep.json").read_text())
    assert report["sweep"]["interrupted"] is True
    assert [o["seed"] for o in report["runs"]] == [6]
    for _, pid in pids(work):
        with pytest.raises(ProcessLookupError):
            os.kill(int(pid), 0)
    assert "interrupted: partial report" in (work / "out" / "report.md").read_text()


@pytest.mark.slow
def test_a_sweep_on_a_local_dask_cluster_of_two_worker_processes(work, capsys):
    from distributed import LocalCluster

    with LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    ) as cluster:
        code = main(
            [
                "sweep",
                "seeds.yaml",
                "--seeds",
                "1-3",
                "--scheduler",
                cluster.scheduler_address,
                "--out",
                "out",
            ]
        )
    printed = capsys.readouterr().out
    assert code == 1, printed
    report = json.loads((work / "out" / "sweep.json").read_text())
    assert report["summary"]["runs"] == 3 and report["summary"]["successes"] == 2
    assert report["sweep"]["where"].startswith(
        f"Dask scheduler {cluster.scheduler_address} (2 worker(s))"
    )
    assert {o["worker"].split()[0] for o in report["runs"]} == {"worker"}
    assert len({pid for _, pid in pids(work)}) == 3


def _start(command, work, env=None):
    return subprocess.Popen(
        command, cwd=work, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, env=env
    )


@pytest.mark.slow
def test_a_sweep_on_dask_processes_reports_a_worker_without_armtree_once(work, capsys):
    scheduler_file = work / "scheduler.json"
    dask = [sys.executable, "-m", "distributed.cli.dask_scheduler"]
    scheduler = _start(
        [*dask, "--port", "0", "--no-dashboard", "--scheduler-file", str(scheduler_file)], work
    )
    processes = [scheduler]
    try:
        deadline = time.monotonic() + 60
        while not scheduler_file.exists():
            assert time.monotonic() < deadline and scheduler.poll() is None
            time.sleep(0.2)
        address = json.loads(scheduler_file.read_text())["address"]
        worker = [
            sys.executable,
            "-m",
            "distributed.cli.dask_worker",
            address,
            "--nworkers",
            "1",
            "--nthreads",
            "1",
            "--no-dashboard",
        ]
        processes.append(_start(worker, work))
        # A worker whose Python cannot import armtree (as on a machine without it).
        blocked = "import sys; sys.modules['armtree'] = None; from distributed.cli.dask_worker import main; sys.argv[0] = 'dask worker'; main()"
        # --no-nanny: the worker runs in this very process, where armtree is blocked.
        processes.append(_start([sys.executable, "-c", blocked, *worker[3:], "--no-nanny"], work))
        from distributed import Client

        with Client(address, timeout=30) as client:
            client.wait_for_workers(2, timeout=60)
        code = main(
            ["sweep", "seeds.yaml", "--seeds", "1-2", "--scheduler", address, "--out", "out"]
        )
    finally:
        for process in reversed(processes):
            process.terminate()
        for process in processes:
            try:
                process.wait(timeout=15)
            except subprocess.TimeoutExpired:  # a worker still closing its connections
                process.kill()
                process.wait(timeout=15)
    printed = capsys.readouterr().out
    assert code == 0, printed
    assert printed.count("cannot import armtree") == 1
    report = json.loads((work / "out" / "sweep.json").read_text())
    assert report["summary"]["successes"] == 2
    (bad,) = report["sweep"]["bad_workers"].values()
    assert bad.startswith("cannot import armtree")
