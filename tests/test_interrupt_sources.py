"""Interrupt sources in-process: first request wins, signal handlers, the stop key on a pty."""

import os
import pty
import select
import signal
import termios
import threading

from armtree.runtime.interrupts import Interrupts, StopKey


def test_the_first_request_wins_from_any_thread():
    interrupts = Interrupts()
    results = []
    threads = [
        threading.Thread(target=lambda i=i: results.append(interrupts.request(f"r{i}")))
        for i in range(8)
    ]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert results.count(True) == 1 and interrupts.requested
    assert interrupts.wake.is_set() and interrupts.reason.startswith("r")


def test_signals_are_routed_while_the_block_runs_and_a_second_one_forces_exit():
    forced = []
    interrupts = Interrupts(force_exit=lambda: forced.append(True))
    before = signal.getsignal(signal.SIGTERM)
    with interrupts.signals() as installed:
        assert installed
        signal.raise_signal(signal.SIGTERM)
        assert interrupts.reason == "SIGTERM" and forced == []
        signal.raise_signal(signal.SIGINT)
        assert forced == [True] and interrupts.reason == "SIGTERM"
    assert signal.getsignal(signal.SIGTERM) is before


def test_signals_are_left_alone_off_the_main_thread():
    seen = []

    def body():
        with Interrupts().signals() as installed:
            seen.append(installed)

    t = threading.Thread(target=body)
    t.start()
    t.join()
    assert seen == [False]


def test_the_stop_key_reads_q_from_a_terminal_without_blocking_and_restores_it():
    master, slave = pty.openpty()
    stream = os.fdopen(slave, "r")
    try:
        before = termios.tcgetattr(slave)
        with StopKey(stream) as key:
            assert key.active
            assert not key.pressed()
            os.write(master, b"x")
            assert not key.pressed()
            os.write(master, b"Q")
            select.select([slave], [], [], 5.0)
            assert key.pressed()
        assert termios.tcgetattr(slave) == before
    finally:
        stream.close()
        os.close(master)


def test_the_stop_key_is_off_when_stdin_is_not_a_terminal(tmp_path):
    with (tmp_path / "in.txt").open("w+") as stream, StopKey(stream) as key:
        assert not key.active and not key.pressed()


def test_the_signal_handler_takes_no_lock_the_interrupted_code_may_hold():
    # A signal handler runs on the main thread between two bytecodes, perhaps inside
    # request() or a pacing Event.wait(): one that waited for their locks hung a run
    # on a second quick Ctrl-C. Here the locks are held while the handler runs.
    interrupts = Interrupts(force_exit=lambda: None)
    handled = threading.Event()

    def handler() -> None:
        interrupts._on_signal(signal.SIGINT, None)
        handled.set()

    with interrupts._lock, interrupts.wake._cond:
        worker = threading.Thread(target=handler, daemon=True)
        worker.start()
        took_no_lock = handled.wait(2.0)
    worker.join(2.0)
    assert took_no_lock
    assert interrupts.requested and interrupts.reason == "SIGINT"
