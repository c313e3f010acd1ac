"""The fixed corpus of issues 17 and 32's hostile inputs: each gives its exit code and position."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from hostile_corpus import CASES, Case, write_case

from armtree.cli import commandline as cli

#: Text that must never reach a user: a traceback, a raw exception's name, or Python's name
#: for a value's type (a file's values are named in YAML's words: a list, a mapping).
RAW = re.compile(
    r"Traceback|^error: [A-Za-z]+(Error|Exception)\b|\bMarked(List|Dict)\b|\bNoneType\b"
    r"|<class '|\bgot (str|int|float|bool|list|dict|tuple)\b",
    re.M,
)


def check(case: Case, folder: Path, capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    write_case(case, folder)
    try:
        code = cli.main([*case.command, *case.argv])
    except SystemExit as exc:  # argparse refuses an option's value so, as on the command line
        code = exc.code
    return code, capsys.readouterr().err


@pytest.mark.parametrize("case", CASES, ids=[c.name for c in CASES])
def test_hostile_input_gives_its_exit_code_and_position(
    case: Case, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys
) -> None:
    monkeypatch.chdir(tmp_path)
    code, err = check(case, tmp_path, capsys)
    assert not RAW.search(err), err
    assert code == case.code, err
    if case.code == 2:
        first = err.splitlines()[0]
        if first.startswith("usage:"):  # argparse: the usage, then "PROG: error: argument ..."
            first = err.strip().splitlines()[-1].partition(": error: ")[2]
        for folder in (str(tmp_path.resolve()), str(tmp_path)):
            first = first.replace(folder + "/", "")
        assert first.startswith(case.where), first
        assert case.message in err, err
        if not first.startswith(("-", "argument -")) and not case.where.endswith(": "):
            assert re.match(r"^[^:\s]+:\d+:\d+: ", first), first
