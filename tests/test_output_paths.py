"""Output folders and files (issue 32): refused before any work, exit 2 naming the path."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from armtree.api import output_paths
from armtree.api.output_paths import output_file, output_folder, path_kind
from armtree.cli import commandline as cli
from armtree.cli.run_command import claim_record_folder
from armtree.errors import ConfigError

TREE = "rig: sim_dobot\nroot: {success: {}}\n"


def test_path_kind_names_what_a_path_is(tmp_path: Path) -> None:
    os.mkfifo(tmp_path / "fifo")
    (tmp_path / "zero").symlink_to("/dev/zero")
    (tmp_path / "dangling").symlink_to(tmp_path / "gone")
    (tmp_path / "f").write_text("x")
    assert path_kind(tmp_path / "fifo").startswith("a FIFO")
    assert path_kind(tmp_path / "zero") == "a device"
    assert path_kind(tmp_path / "dangling") == "a link to nothing"
    assert path_kind(tmp_path / "f") == "a file"
    assert path_kind(tmp_path) == "a folder"
    assert path_kind(tmp_path / "f" / "under") == "nothing"


def test_a_folder_that_cannot_be_written_is_refused_with_the_reason(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # Root may write anywhere, so the refusal of access(2) is stood in for.
    monkeypatch.setattr(output_paths.os, "access", lambda path, mode: False)
    monkeypatch.setattr(output_paths, "_read_only_fs", lambda folder: True)
    with pytest.raises(ConfigError) as folder:
        output_folder(str(tmp_path / "rec"), "--record")
    assert folder.value.file == f"--record {tmp_path / 'rec'}"
    assert "cannot write there (Read-only file system)" in folder.value.message
    with pytest.raises(ConfigError) as file:
        output_file(str(tmp_path / "m.png"), "-o")
    assert "cannot write there (Read-only file system)" in file.value.message


def test_an_existing_file_named_with_o_is_replaced(tmp_path: Path) -> None:
    (tmp_path / "m.png").write_bytes(b"old")
    assert output_file(str(tmp_path / "m.png"), "-o") == tmp_path / "m.png"


def test_overwrite_removes_the_earlier_run_and_keeps_other_files(tmp_path: Path) -> None:
    (tmp_path / "run.jsonl").write_text("{}\n")
    (tmp_path / "notes.txt").write_text("mine")
    output_folder(str(tmp_path), "--record", ("run.jsonl", "score.json"), overwrite=True)
    assert not (tmp_path / "run.jsonl").exists()
    assert (tmp_path / "notes.txt").read_text() == "mine"


def test_a_second_run_into_a_folder_being_recorded_is_refused(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "t.yaml").write_text(TREE)
    held = claim_record_folder("rec", overwrite=False)  # the first run, still writing
    try:
        code = cli.main(["run", "t.yaml", "--quiet", "--record", "rec"])
    finally:
        held.release()
    err = capsys.readouterr().err
    assert code == 2, err
    assert err.startswith("--record rec: rec is being written by process "), err
    assert not (tmp_path / "rec" / "run.jsonl").exists()
    assert cli.main(["run", "t.yaml", "--quiet", "--record", "rec"]) == 0
    assert (tmp_path / "rec" / "run.jsonl").exists()


def _file_size_limit(limit: int):
    """For a child: writes past ``limit`` bytes fail with EFBIG, as on a full disk."""
    import resource
    import signal

    def limit_size() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # the error, not the default kill
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    return limit_size


@pytest.mark.parametrize("limit", [0, 1000, 4096, 30_000])
def test_a_record_that_fills_the_disk_names_the_folder_and_stops_cleanly(
    tmp_path: Path, limit: int
) -> None:
    """Issue 32: a disk that fills up while a run is recorded (a file-size limit stands in
    for it) gives exit 2 naming --record and what to do, not the bare OSError."""
    import subprocess
    import sys

    (tmp_path / "t.yaml").write_text("rig: sim_dobot\nroot: {wait: {seconds: 2}}\n")
    proc = subprocess.run(
        [str(Path(sys.executable).with_name("run-tree")), "t.yaml", "--quiet", "--record", "rec"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=120,
        preexec_fn=_file_size_limit(limit),
    )
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.splitlines()
    assert lines and all(line.startswith("--record rec: ") for line in lines), proc.stderr
    assert all("; the record is incomplete; free some space" in line for line in lines), lines
    reasons = "File too large" if limit < 30_000 else "overhead.mp4: cut short"
    assert reasons in lines[0], lines
    assert "Error" not in proc.stderr and "Traceback" not in proc.stderr
