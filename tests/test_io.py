import fcntl
import hashlib
import json
import os
import signal
import stat
import subprocess
import sys
import time

import numpy as np
import pytest

from bayesmap._io import (
    atomic_open,
    read_input,
    run_folder,
    verify_run_folder,
    write_json,
    write_text,
)
from bayesmap._rng import as_generator, spawn
from bayesmap.errors import ConfigError, FormatError


def test_write_text_replaces_atomically(tmp_path):
    target = tmp_path / "sub" / "out.txt"
    write_text(target, "one")
    write_text(target, "two")
    assert target.read_text() == "two"
    assert [p.name for p in target.parent.iterdir()] == ["out.txt"]


def test_failed_write_keeps_the_old_file_and_leaves_no_temporary(tmp_path):
    target = tmp_path / "keep.txt"
    write_text(target, "precious")
    with pytest.raises(RuntimeError), atomic_open(target) as handle:
        handle.write("half")
        raise RuntimeError("crash mid-write")
    assert target.read_text() == "precious"
    assert [p.name for p in tmp_path.iterdir()] == ["keep.txt"]


def test_write_json_accepts_numpy(tmp_path):
    path = write_json(tmp_path / "m.json", {"a": np.float64(0.5), "b": np.arange(3)})
    assert json.loads(path.read_text()) == {"a": 0.5, "b": [0, 1, 2]}


def test_write_json_writes_undefined_numbers_as_null(tmp_path):
    """JSON has no NaN: a metric with no defined value is null, at any depth, and the file
    is standard JSON (the strict parser accepts it)."""
    data = {"p": float("nan"), "q": [np.float64(np.inf), 1.5], "r": {"s": np.array([np.nan])}}
    path = write_json(tmp_path / "m.json", data)

    def refuse(constant: str) -> None:
        raise AssertionError(f"non-standard JSON constant {constant}")

    assert json.loads(path.read_text(), parse_constant=refuse) == {
        "p": None,
        "q": [None, 1.5],
        "r": {"s": [None]},
    }


def test_as_generator_passes_generators_through_and_seeds_ints():
    generator = np.random.default_rng(3)
    assert as_generator(generator) is generator
    assert as_generator(7).random() == np.random.default_rng(7).random()


def test_spawn_gives_independent_reproducible_streams():
    first = [g.random() for g in spawn(11, 3)]
    again = [g.random() for g in spawn(11, 3)]
    assert first == again
    assert len(set(first)) == 3


def test_new_files_get_the_umask_permissions_and_existing_files_keep_theirs(tmp_path):
    old = os.umask(0o022)
    try:
        fresh = write_text(tmp_path / "fresh.txt", "x")
        assert stat.S_IMODE(fresh.stat().st_mode) == 0o644
        kept = tmp_path / "kept.txt"
        kept.write_text("old")
        kept.chmod(0o600)
        write_text(kept, "new")
        assert stat.S_IMODE(kept.stat().st_mode) == 0o600
    finally:
        os.umask(old)


# ---------------------------------------------------------------------------- run folders
def _leftovers(folder):
    return sorted(p.name for p in folder.iterdir() if p.name.startswith("."))


def _run(target, files, **kwargs):
    options = {"command": "test", "configuration": {"a": 1}, "seed": 7, **kwargs}
    with run_folder(target, **options) as folder:
        for name, text in files.items():
            write_text(folder.path / name, text)
    return folder


def test_a_run_folder_appears_complete_with_its_manifest(tmp_path):
    folder = _run(tmp_path / "out", {"a.txt": "one", "sub/b.json": "{}"})
    assert folder.final(folder.path / "sub" / "b.json") == tmp_path / "out" / "sub" / "b.json"
    manifest = verify_run_folder(tmp_path / "out")
    assert manifest["command"] == "test"
    assert manifest["configuration"] == {"a": 1}
    assert manifest["seed"] == 7
    assert manifest["started"] <= manifest["finished"]
    assert [(f["path"], f["bytes"]) for f in manifest["files"]] == [("a.txt", 3), ("sub/b.json", 2)]
    expected = hashlib.sha256(b"one").hexdigest()
    assert manifest["files"][0]["sha256"] == expected
    assert _leftovers(tmp_path) == []


def test_a_new_run_replaces_the_old_one_whole(tmp_path):
    _run(tmp_path / "out", {"old.png": "x", "metrics.json": "1"})
    _run(tmp_path / "out", {"metrics.json": "2"})
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["manifest.json", "metrics.json"]
    assert _leftovers(tmp_path) == []


def test_a_failed_run_leaves_the_previous_one_untouched(tmp_path):
    _run(tmp_path / "out", {"metrics.json": "1"})
    with (
        pytest.raises(RuntimeError),
        run_folder(tmp_path / "out", command="t", configuration={}, seed=None) as folder,
    ):
        write_text(folder.path / "metrics.json", "2")
        write_text(folder.path / "new.png", "half")
        raise RuntimeError("interrupted")
    assert (tmp_path / "out" / "metrics.json").read_text() == "1"
    assert not (tmp_path / "out" / "new.png").exists()
    verify_run_folder(tmp_path / "out")
    assert _leftovers(tmp_path) == []


def test_run_folders_refuse_to_replace_what_is_not_a_run(tmp_path):
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "thesis.tex").write_text("precious")
    with pytest.raises(ConfigError, match="no manifest.json"):
        _run(tmp_path / "mine", {"a": "b"})
    assert (tmp_path / "mine" / "thesis.tex").read_text() == "precious"
    (tmp_path / "file").write_text("x")
    with pytest.raises(ConfigError, match="is a file"):
        _run(tmp_path / "file", {"a": "b"})
    with pytest.raises(ConfigError, match="is a file"):
        _run(tmp_path / "file" / "below", {"a": "b"})
    (tmp_path / "empty").mkdir()
    _run(tmp_path / "empty", {"a": "b"})
    assert _leftovers(tmp_path) == []


def test_a_run_never_replaces_a_file_its_previous_run_did_not_write(tmp_path):
    _run(tmp_path / "out", {"metrics.json": "1", "maps/a.png": "x"})
    (tmp_path / "out" / "maps" / "log.txt").write_text("the only copy")  # an input, say
    (tmp_path / "out" / "notes").mkdir()
    with pytest.raises(ConfigError, match=r"holds 'maps/log.txt', 'notes', which its previous"):
        _run(tmp_path / "out", {"metrics.json": "2"})
    assert (tmp_path / "out" / "maps" / "log.txt").read_text() == "the only copy"
    assert (tmp_path / "out" / "metrics.json").read_text() == "1"
    (tmp_path / "out" / "manifest.json").write_text("{")
    with pytest.raises(ConfigError, match="manifest.json that cannot be read"):
        _run(tmp_path / "out", {"metrics.json": "2"})
    assert _leftovers(tmp_path) == []


def test_a_folder_that_cannot_be_written_is_one_error(tmp_path, monkeypatch):
    def refuse(**_: object) -> str:
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr("bayesmap._io.tempfile.mkdtemp", refuse)
    with pytest.raises(ConfigError, match="cannot write into the folder .*: Permission denied"):
        _run(tmp_path / "out", {"a": "b"})


def test_verify_run_folder_notices_a_changed_or_missing_file(tmp_path):
    _run(tmp_path / "out", {"a.txt": "one"})
    (tmp_path / "out" / "a.txt").write_text("two")
    with pytest.raises(FormatError, match="SHA-256"):
        verify_run_folder(tmp_path / "out")
    (tmp_path / "out" / "a.txt").unlink()
    with pytest.raises(FormatError, match="missing"):
        verify_run_folder(tmp_path / "out")
    with pytest.raises(FormatError):
        verify_run_folder(tmp_path)


def _age(path, seconds=3600.0):
    old = time.time() - seconds
    os.utime(path, (old, old))


def test_abandoned_temporaries_are_swept_and_live_ones_kept(tmp_path):
    dead_dir = tmp_path / ".out.run-dead.tmp"
    dead_dir.mkdir()
    (dead_dir / "half.png").write_text("x")
    _age(dead_dir)
    live_dir = tmp_path / ".out.run-live.tmp"
    live_dir.mkdir()
    _age(live_dir)
    dead_file = tmp_path / ".x.txt.partial-dead.tmp"
    dead_file.write_text("half")
    _age(dead_file)
    fresh_file = tmp_path / ".x.txt.partial-fresh.tmp"
    fresh_file.write_text("being written")
    holder = os.open(live_dir, os.O_RDONLY)
    try:
        fcntl.flock(holder, fcntl.LOCK_EX)
        _run(tmp_path / "out", {"a": "b"})
        write_text(tmp_path / "x.txt", "whole")
    finally:
        os.close(holder)
    assert _leftovers(tmp_path) == [".out.run-live.tmp", ".x.txt.partial-fresh.tmp"]


# The child gets Ctrl-C as at a terminal: a shell's background job (`cmd &` without job
# control, as a CI runner may start the suite) begins with SIGINT ignored, and Python then
# never raises KeyboardInterrupt.
_INTERRUPTED = """
import signal, sys, time
from pathlib import Path
from bayesmap._io import run_folder, terminate_as_exit, write_text
signal.signal(signal.SIGINT, signal.default_int_handler)
target = Path(sys.argv[1])
with terminate_as_exit(), run_folder(target, command="t", configuration={}, seed=1) as folder:
    write_text(folder.path / "metrics.json", "new")
    with open(folder.path / "figure.png", "w") as handle:
        handle.write("half")
        print("ready", flush=True)
        time.sleep(60)
"""


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT, signal.SIGKILL])
def test_an_interrupted_run_leaves_the_previous_run_and_no_temporaries(tmp_path, signum):
    _run(tmp_path / "out", {"metrics.json": "old"})
    child = subprocess.Popen(
        [sys.executable, "-c", _INTERRUPTED, str(tmp_path / "out")],
        stdout=subprocess.PIPE,
        text=True,
    )
    assert child.stdout is not None and child.stdout.readline().strip() == "ready"
    child.send_signal(signum)
    child.wait(30)
    assert (tmp_path / "out" / "metrics.json").read_text() == "old"
    verify_run_folder(tmp_path / "out")
    left = _leftovers(tmp_path)
    if signum == signal.SIGKILL:  # nothing runs on SIGKILL: the next run sweeps it
        assert len(left) == 1
        _age(tmp_path / left[0])
        _run(tmp_path / "out", {"metrics.json": "next"})
    assert _leftovers(tmp_path) == []


# A clean-up that never ends: the SIGTERM watchdog must end the process anyway.
_STUCK = """
import time
from bayesmap._io import terminate_as_exit
with terminate_as_exit(grace=1.0):
    try:
        print("ready", flush=True)
        time.sleep(60)
    finally:
        time.sleep(60)
"""


def test_a_clean_up_that_hangs_after_sigterm_ends_with_the_stacks_printed():
    child = subprocess.Popen(
        [sys.executable, "-c", _STUCK],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert child.stdout is not None and child.stdout.readline().strip() == "ready"
    child.send_signal(signal.SIGTERM)
    _, err = child.communicate(timeout=30)
    assert child.returncode == 1
    assert "Timeout (0:00:01)!" in err and "in <module>" in err


# SIGTERM while a finaliser runs: Python prints that SystemExit and drops it, so the run
# goes on; the exit must come again, and its repeats must leave the clean-up alone.
_SWALLOWED = """
import os, signal, sys, time
from pathlib import Path
from bayesmap._io import run_folder, terminate_as_exit, write_text

class Collected:
    def __del__(self):
        os.kill(os.getpid(), signal.SIGTERM)
        total = 0
        for k in range(1000):  # bytecode after the signal: its handler runs in here
            total += k

target, marker = Path(sys.argv[1]), Path(sys.argv[2])
run = run_folder(target, command="t", configuration={}, seed=1)
with terminate_as_exit(retry=0.2), run as folder:
    write_text(folder.path / "metrics.json", "new")
    try:
        Collected()
        start = time.monotonic()
        while time.monotonic() - start < 20:
            sum(range(1000))
        print("the exit was lost", flush=True)
    finally:
        time.sleep(1.0)  # a slow clean-up: five repeats would fall in it
        marker.write_text("cleaned")
"""


def test_a_sigterm_dropped_by_a_finaliser_still_ends_the_run_cleanly(tmp_path):
    _run(tmp_path / "out", {"metrics.json": "old"})
    marker = tmp_path / "cleaned.txt"
    child = subprocess.run(
        [sys.executable, "-c", _SWALLOWED, str(tmp_path / "out"), str(marker)],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert child.returncode == 143, child.stderr
    assert "the exit was lost" not in child.stdout
    assert "Exception ignored in" in child.stderr  # the first exit was indeed dropped
    assert marker.read_text() == "cleaned"
    assert (tmp_path / "out" / "metrics.json").read_text() == "old"
    assert _leftovers(tmp_path) == []


def test_read_input_refuses_what_is_not_a_regular_file(tmp_path):
    with pytest.raises(FormatError, match="regular file"):
        read_input(tmp_path, max_bytes=10)
    with pytest.raises(FormatError, match="cannot open"):
        read_input(tmp_path / "missing", max_bytes=10)
    (tmp_path / "big").write_bytes(b"x" * 11)
    with pytest.raises(FormatError, match="max_bytes"):
        read_input(tmp_path / "big", max_bytes=10)


def test_writing_over_a_folder_or_under_a_file_is_a_config_error(tmp_path):
    (tmp_path / "folder").mkdir()
    with pytest.raises(ConfigError, match="is a folder"):
        write_text(tmp_path / "folder", "x")
    (tmp_path / "file").write_text("x")
    with pytest.raises(ConfigError, match="is a file"):
        write_text(tmp_path / "file" / "out.txt", "x")


def test_a_name_with_a_nul_character_is_a_format_error():
    with pytest.raises(FormatError, match="NUL"):
        read_input("map\x00.pgm", max_bytes=10)
