"""``TaskRunner``: one stage's independent tasks on the run's executor, each finished one checkpointed.

The experiment builds one runner per stage: the run's executor and a ``Checkpoint`` under
the stage's cache key. A stage hands it the tasks (a top-level function, one argument
tuple and one item name per task) and the ``TaskCodec`` of their results; the runner
yields first every task an interrupted run already finished (read back from the
checkpoint), then the others as they finish, each written to the checkpoint and read back
before it is yielded, so a fresh and a resumed task give the stage the same values. A
runner without a checkpoint (``TaskRunner()``: serial, nothing kept) runs every task and
yields its result as it is; that is what a stage run on its own, outside an experiment,
gets.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterator, Sequence
from typing import TypeVar

from roman_sim.runner.checkpoint import Checkpoint, TaskCodec
from roman_sim.runner.executor_base import Executor

log = logging.getLogger(__name__)

T = TypeVar("T")


class TaskRunner:
    """Runs a stage's tasks (see the module docstring).

    Args:
        executor: where the tasks run (None: in this process, one after the other).
        checkpoint: where finished tasks are kept (None: nothing is kept or resumed).
    """

    def __init__(self, executor: Executor | None = None, checkpoint: Checkpoint | None = None) -> None:
        if executor is None:
            from roman_sim.runner.executors import SerialExecutor

            executor = SerialExecutor()
        self.executor = executor
        self.checkpoint = checkpoint

    @property
    def kind(self) -> str:
        """The executor's kind (``serial``, ``local`` or ``dask``)."""
        return self.executor.kind

    @property
    def workers(self) -> int:
        """The executor's worker count."""
        return self.executor.workers

    @property
    def in_process(self) -> bool:
        """Whether tasks run in this process (they may then take live objects instead of plain data)."""
        return self.executor.kind == "serial"

    def run(
        self,
        fn: Callable[..., T],
        args: Sequence[tuple[object, ...]],
        labels: Sequence[str],
        items: Sequence[str],
        codec: TaskCodec[T],
    ) -> Iterator[tuple[int, T]]:
        """Yield ``(index, result)`` of every task: resumed ones first (in order), then fresh ones as they finish.

        ``items`` names each task's checkpoint entry (unique within the stage); ``labels``
        name the tasks in errors.
        """
        todo: list[int] = []
        for i, item in enumerate(items):
            kept = None if self.checkpoint is None else self.checkpoint.get(item, codec)
            if kept is None:
                todo.append(i)
                continue
            log.info("%s: reusing the result of an interrupted run", labels[i])
            yield i, kept
        tasks = self.executor.run_tasks(fn, [args[i] for i in todo], [labels[i] for i in todo])
        for j, value in tasks:
            i = todo[j]
            if self.checkpoint is not None:
                self.checkpoint.put(items[i], value, codec)
                back = self.checkpoint.get(items[i], codec)
                if back is None:  # the files just written cannot be read: a disk problem, not a resumable state
                    from roman_sim.core.errors import StorageError

                    raise StorageError(f"{labels[i]}: its checkpoint in {self.checkpoint.folder} cannot be read back")
                value = back
            yield i, value

    def run_unkept(
        self, fn: Callable[..., T], args: Sequence[tuple[object, ...]], labels: Sequence[str]
    ) -> Iterator[tuple[int, T]]:
        """Yield ``(index, result)`` of every task as it finishes, with no checkpoint (quick tasks: plots)."""
        return self.executor.run_tasks(fn, args, labels)
