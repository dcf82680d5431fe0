import json
import os
import stat

import numpy as np
import pytest

from bayesmap._io import atomic_open, write_json, write_text
from bayesmap._rng import as_generator, spawn


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
