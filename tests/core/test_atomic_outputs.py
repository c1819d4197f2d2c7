"""Output files: the mode of an ordinary open() (umask respected), and output locations checked up front."""

from __future__ import annotations

import os
import stat
from collections.abc import Iterator

import numpy as np
import pytest

from roman_sim.core import atomic
from roman_sim.core.errors import ConfigError, StorageError


@pytest.fixture
def umask() -> Iterator[object]:
    """``umask(mask)`` sets the process umask for the test; the old one is restored."""
    old = os.umask(0o022)
    os.umask(old)
    yield lambda m: os.umask(m)
    os.umask(old)


def _mode(path) -> int:
    return stat.S_IMODE(os.stat(path).st_mode)


@pytest.mark.parametrize(
    ("mask", "file_mode", "dir_mode"), [(0o022, 0o644, 0o755), (0o077, 0o600, 0o700), (0o002, 0o664, 0o775)]
)
def test_written_files_get_the_umask_mode(tmp_path, umask, mask: int, file_mode: int, dir_mode: int) -> None:
    umask(mask)
    assert atomic.current_umask() == mask
    atomic.write_text(tmp_path / "a.txt", "x")
    atomic.write_json(tmp_path / "b.json", {"a": 1})
    atomic.write_npz(tmp_path / "c.npz", x=np.zeros(3))
    for name in ("a.txt", "b.json", "c.npz"):
        assert _mode(tmp_path / name) == file_mode, name
    import tempfile

    d = tempfile.mkdtemp(dir=tmp_path)
    assert _mode(d) == 0o700
    atomic.make_public_dir(d)
    assert _mode(d) == dir_mode


def test_recordings_get_ordinary_folder_modes(tmp_path, umask) -> None:
    from roman_sim.mapping import synthetic
    from roman_sim.sim.recording import write_recording

    umask(0o022)
    frames = synthetic.drive(synthetic.sphere_field(2, seed=0), n=2, intr=synthetic.intrinsics(32, 24))
    out = write_recording(frames, tmp_path / "rec")
    assert _mode(out) == 0o755
    assert all(_mode(p) == 0o644 for p in out.iterdir() if p.is_file())


def test_no_temporary_file_is_left_after_a_failed_write(tmp_path) -> None:
    (tmp_path / "dir").mkdir()
    with pytest.raises(StorageError, match="is an existing folder, cannot write a file there"):
        atomic.write_text(tmp_path / "dir", "x")
    (tmp_path / "file").write_text("")
    with pytest.raises(StorageError, match="cannot write"):
        atomic.write_text(tmp_path / "file" / "x.txt", "x")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["dir", "file"]


def test_output_folder_and_file_checks(tmp_path) -> None:
    f = tmp_path / "f"
    f.write_text("")
    with pytest.raises(ConfigError, match=r"^--out .*/f: is an existing file, not a folder"):
        atomic.output_folder(f)
    with pytest.raises(ConfigError, match=r"^--dir .*/f/x/y: lies inside .*/f, an existing file, not a folder"):
        atomic.output_folder(f / "x" / "y", "--dir")
    with pytest.raises(ConfigError, match="is an existing folder, expected a file path"):
        atomic.output_file(tmp_path)
    with pytest.raises(ConfigError, match="is an existing file, not a folder"):
        atomic.output_file(f / "x.png")
    assert not atomic.output_folder(tmp_path / "later" / "deep", create=False).exists()
    assert not (tmp_path / "later").exists()  # a check before the work leaves nothing behind
    assert atomic.output_folder(tmp_path / "new" / "deep").is_dir()
    assert atomic.output_file(tmp_path / "n2" / "x.png") == tmp_path / "n2" / "x.png"
    assert (tmp_path / "n2").is_dir()


@pytest.mark.skipif(os.geteuid() == 0, reason="root may write into read-only folders")
def test_unwritable_output_folder(tmp_path) -> None:
    ro = tmp_path / "ro"
    ro.mkdir(mode=0o500)
    with pytest.raises(ConfigError, match="not writable"):
        atomic.output_folder(ro)
