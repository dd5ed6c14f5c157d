"""Atomic writes (src/xicm/core/results/atomic.py): the new content or the old, never part of one, and no temp file left."""

import os

import numpy as np
import pytest

from xicm.core.results.atomic import write_atomic, write_dir_atomic, write_json_atomic


def test_text_bytes_and_writer_functions_replace_the_file(tmp_path):
    target = tmp_path / "out" / "file.bin"  # the folder is created
    write_atomic(target, "première\n")
    assert target.read_bytes() == "première\n".encode()
    write_atomic(target, b"\x00\x01")
    assert target.read_bytes() == b"\x00\x01"
    write_atomic(target, lambda f: np.save(f, np.arange(3)))
    assert np.load(target).tolist() == [0, 1, 2]
    assert os.listdir(target.parent) == ["file.bin"]


def test_json_is_indented_utf8_with_str_for_other_values(tmp_path):
    target = tmp_path / "summary.json"
    write_json_atomic(target, {"task": "fermer", "path": tmp_path, "é": 1})
    write_json_atomic(target, {"x": 2})  # replaces, leaves nothing beside it
    assert target.read_text(encoding="utf-8") == '{\n  "x": 2\n}'
    write_json_atomic(target, {"path": tmp_path, "é": 1}, indent=1)
    assert target.read_text(encoding="utf-8") == f'{{\n "path": "{tmp_path}",\n "é": 1\n}}'
    assert [p.name for p in tmp_path.iterdir()] == ["summary.json"]


def test_a_failed_write_keeps_the_old_file_and_leaves_no_partial_one(tmp_path):
    target = tmp_path / "run.json"
    target.write_text('{"old": true}')

    def breaks_half_way(f):
        f.write(b'{"new": ')
        raise OSError("disk full")

    with pytest.raises(OSError, match="disk full"):
        write_atomic(target, breaks_half_way)
    assert target.read_text() == '{"old": true}'
    assert os.listdir(tmp_path) == ["run.json"]


def test_new_files_get_the_mode_open_would_give(tmp_path):
    write_atomic(tmp_path / "atomic.txt", "x")
    (tmp_path / "plain.txt").write_text("x")
    assert (tmp_path / "atomic.txt").stat().st_mode == (tmp_path / "plain.txt").stat().st_mode


def test_a_folder_is_swapped_in_whole(tmp_path):
    final = tmp_path / "final"
    write_dir_atomic(final, lambda d: (d / "a.txt").write_text("1"))
    write_dir_atomic(final, lambda d: (d / "b.txt").write_text("2"))
    assert sorted(p.name for p in final.iterdir()) == ["b.txt"]  # the older folder is gone, not merged
    assert os.listdir(tmp_path) == ["final"]


def test_a_failed_folder_write_keeps_the_old_one_and_a_killed_ones_leftover_is_cleared(tmp_path):
    final = tmp_path / "final"
    write_dir_atomic(final, lambda d: (d / "a.txt").write_text("1"))

    def breaks(d):
        (d / "half.txt").write_text("partial")
        raise RuntimeError("out of memory")

    with pytest.raises(RuntimeError):
        write_dir_atomic(final, breaks)
    assert [p.name for p in final.iterdir()] == ["a.txt"] and os.listdir(tmp_path) == ["final"]
    (tmp_path / ".final.tmp").mkdir()  # as a killed attempt leaves it
    (tmp_path / ".final.tmp" / "half.txt").write_text("partial")
    write_dir_atomic(final, lambda d: (d / "c.txt").write_text("3"))
    assert [p.name for p in final.iterdir()] == ["c.txt"] and os.listdir(tmp_path) == ["final"]
