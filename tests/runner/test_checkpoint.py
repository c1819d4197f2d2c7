"""Task checkpoints: finished tasks kept under a key, resumed first, ignored when the key or a payload differs."""

from __future__ import annotations

from pathlib import Path

from roman_sim.core.atomic import write_bytes
from roman_sim.core.jsontypes import JSON
from roman_sim.runner.checkpoint import PARTIAL_DIR, Checkpoint, Kept, clear_checkpoints
from roman_sim.runner.taskrunner import TaskRunner


class BytesCodec:
    """Keeps a task's bytes as ``<stem>.bin`` and their length as the record's data."""

    def write(self, value: bytes, stem: Path) -> Kept:
        path = stem.with_suffix(".bin")
        write_bytes(path, value)
        return Kept(len(value), [path])

    def read(self, data: JSON, stem: Path) -> bytes:
        value = stem.with_suffix(".bin").read_bytes()
        assert data == len(value)
        return value


def _square(i: int) -> bytes:
    return bytes([i * i])


def _run(runner: TaskRunner, calls: list[int]) -> list[tuple[int, bytes]]:
    def fn(i: int) -> bytes:
        calls.append(i)
        return _square(i)

    return list(runner.run(fn, [(i,) for i in range(4)], [f"task {i}" for i in range(4)], list("abcd"), BytesCodec()))


def test_finished_tasks_are_resumed_first_and_only_the_others_run(tmp_path: Path) -> None:
    calls: list[int] = []
    first = _run(TaskRunner(checkpoint=Checkpoint(tmp_path, "stage", "key1")), calls)
    assert first == [(i, _square(i)) for i in range(4)] and calls == [0, 1, 2, 3]
    (tmp_path / PARTIAL_DIR / "stage" / "b.json").unlink()  # task 1 never finished
    (tmp_path / PARTIAL_DIR / "stage" / "c.bin").write_bytes(b"\xff")  # task 2's payload damaged
    calls.clear()
    again = _run(TaskRunner(checkpoint=Checkpoint(tmp_path, "stage", "key1")), calls)
    assert again == [(0, _square(0)), (3, _square(3)), (1, _square(1)), (2, _square(2))]  # resumed ones first
    assert calls == [1, 2]


def test_another_key_recomputes_everything_and_clearing_leaves_no_folder(tmp_path: Path) -> None:
    calls: list[int] = []
    _run(TaskRunner(checkpoint=Checkpoint(tmp_path, "stage", "key1")), calls)
    calls.clear()
    assert [v for _, v in _run(TaskRunner(checkpoint=Checkpoint(tmp_path, "stage", "key2")), calls)] == [
        _square(i) for i in range(4)
    ]
    assert calls == [0, 1, 2, 3]
    clear_checkpoints(tmp_path, "stage")
    assert not (tmp_path / PARTIAL_DIR).exists()


def test_a_runner_without_a_checkpoint_keeps_nothing(tmp_path: Path) -> None:
    calls: list[int] = []
    assert _run(TaskRunner(), calls) == [(i, _square(i)) for i in range(4)]
    assert calls == [0, 1, 2, 3] and not any(tmp_path.iterdir())
