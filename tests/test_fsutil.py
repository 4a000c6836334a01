import os

from pcbdata.core.fsutil import remove_stale_temps, write_atomic, write_dir_atomic


def test_atomic_writes_honour_the_umask_and_replace_whole(tmp_path):
    mask = os.umask(0o022)
    try:
        write_atomic(tmp_path / "a" / "f.txt", "one")
        write_dir_atomic(tmp_path / "d", {"x": "1", "y": b"2"})
        write_dir_atomic(tmp_path / "d", {"x": "3"})
    finally:
        os.umask(mask)
    assert (tmp_path / "a" / "f.txt").read_text() == "one"
    assert oct((tmp_path / "a" / "f.txt").stat().st_mode & 0o777) == oct(0o644)
    assert oct((tmp_path / "d").stat().st_mode & 0o777) == oct(0o755)
    assert sorted(p.name for p in (tmp_path / "d").iterdir()) == ["x"]
    assert not [p for p in tmp_path.rglob("*") if p.name.endswith(".tmp")]


def test_leftovers_of_a_killed_writer_are_removed(tmp_path):
    (tmp_path / ".board_00001.abc.tmp").mkdir()
    (tmp_path / ".manifest.json.xyz.tmp").write_text("half")
    (tmp_path / "keep.txt").write_text("x")
    assert remove_stale_temps(tmp_path) == 2
    assert [p.name for p in tmp_path.iterdir()] == ["keep.txt"]
