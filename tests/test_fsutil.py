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


def test_temp_folders_of_killed_owners_are_swept(tmp_path, monkeypatch):
    import subprocess
    import sys
    import tempfile

    from pcbdata.core.fsutil import owned_temp_folder

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    gone = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True)
    dead = tmp_path / f"pcbdata-pool-{gone.stdout.strip()}-abc"
    alive = tmp_path / f"pcbdata-pool-{os.getpid()}-def"
    other_kind = tmp_path / f"pcbdata-env-{gone.stdout.strip()}-ghi"
    unmarked = tmp_path / "pcbdata-pool-12345678"  # a plain mkdtemp name: no owner, kept
    for folder in (dead, alive, other_kind, unmarked):
        (folder / "stage").mkdir(parents=True)
    made = owned_temp_folder("pool")
    assert made.startswith(str(tmp_path / f"pcbdata-pool-{os.getpid()}-"))
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        [alive.name, other_kind.name, unmarked.name, os.path.basename(made)])
