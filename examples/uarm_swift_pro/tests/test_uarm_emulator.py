"""The firmware emulator on its pseudo-terminal, spoken to with pyserial as any host would."""

from __future__ import annotations

import time

import pytest
import serial
from armtree.api.clock import WallClock

from armtree_uarm_swift_pro.plugin import emulator


@pytest.fixture
def arm():
    firmware = emulator({"type": "uarm_swift_pro"}, WallClock())
    port = serial.Serial(firmware.start(), 115200, timeout=3)
    yield port
    port.close()
    firmware.close()


def talk(port: serial.Serial, *lines: str) -> None:
    port.write("".join(f"{line}\n" for line in lines).encode())


def answer(port: serial.Serial) -> str:
    line = port.readline().decode()
    assert line.endswith("\n"), f"no answer in time (got {line!r})"
    return line.strip()


def boot(port: serial.Serial) -> list[str]:
    talk(port, "#1 P2201")
    lines = []
    while not lines or not lines[-1].startswith("$1"):
        lines.append(answer(port))
    return lines


def test_the_board_boots_with_its_banner_and_answers_queries(arm):
    lines = boot(arm)
    assert lines[:5] == [
        "angle offset:0.0000",
        "device name : SwiftPro",
        "soft ver : V4.10.0",
        "api ver : V4.0.5",
        "work mode : 0",
    ]
    assert lines[5:] == ["@1", "@5 V1", "$1 ok SwiftPro"]
    talk(arm, "#2 P2200", "#3 P2220", "P2234")
    assert answer(arm) == "$2 ok B90.0000 L100.9902 R8.0774"
    assert answer(arm) == "$3 ok X200.0000 Y0.0000 Z150.0000"
    assert answer(arm) == "ok V1"  # without #n the reply carries no $n


def test_a_move_is_answered_when_it_is_over_while_queries_are_answered_at_once(arm):
    boot(arm)
    talk(arm, "#2 G0 X250 Y0 Z100")  # no F since boot: ok, and nothing moves
    assert answer(arm) == "$2 ok"
    start = time.monotonic()
    talk(arm, "#3 G0 X250 Y0 Z100 F100", "#4 P2220")
    assert answer(arm).startswith("$4 ok X200.")  # still where it was: the move has begun
    assert answer(arm) == "$3 ok"
    assert time.monotonic() - start > 0.2  # a 40-degree move at F100 takes about half a second
    talk(arm, "#5 P2220")
    assert answer(arm) == "$5 ok X250.0000 Y0.0000 Z100.0000"


def test_refusals_carry_the_firmwares_codes(arm):
    boot(arm)
    talk(arm, "#2 G0 X0 Y0 Z45 F100")
    assert answer(arm) == "$2 E22"  # unreachable
    talk(arm, "#3 M2019", "#4 G0 X200 Y0 Z120 F100", "#5 M17")
    assert [answer(arm) for _ in range(3)] == ["$3 ok", "$4 E27", "$5 ok"]  # motors detached
    talk(arm, "#6 M2231 V7", "#7 M9999", "#8 HELLO", "#9 P2231")
    assert [answer(arm) for _ in range(3)] == ["$6 E21", "$7 E20", "$9 ok V0"]  # 8 is ignored
    talk(arm, "#10 G0 X" + "1" * 80)
    assert answer(arm) == "error: E23"  # longer than 79 characters


def test_a_full_queue_is_refused_without_a_number(arm):
    boot(arm)
    # The first pause holds the queue for 5 s; 20 more fill it; the 22nd is refused.
    talk(arm, *[f"#{n} G2004 P5000" for n in range(2, 24)])
    assert answer(arm) == "E23 buffer full"
    talk(arm, "#30 S1100")  # reset motion: the queue is emptied
    assert answer(arm) == "$30 ok"
