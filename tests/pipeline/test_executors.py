"""One run over several workers: same bytes whatever the executor, task errors, resumption."""

from __future__ import annotations

import os
import shutil

import pytest

from roman_sim.core.errors import ConfigError, RomanSimError
from roman_sim.pipeline import pairwork
from roman_sim.pipeline import robot_mapping as maps_stage
from roman_sim.pipeline.executors import ExecutorConfig, LocalPoolExecutor, SerialExecutor, TaskError, open_executor
from roman_sim.pipeline.experiment import Experiment
from roman_sim.pipeline.scenario import load_scenario
from roman_sim.testing import assert_same_run_folder as assert_same_folder


def _fail_on_two(x: int) -> int:
    if x == 2:
        raise ConfigError("two is not allowed")
    return x * x


def _fail_from_two(x: int) -> int:
    if x <= 2:
        raise ConfigError("two is not allowed" if x == 2 else "one is not allowed")
    if x == 5:
        raise ConfigError("five is not allowed")
    return x


def _divide(x: int) -> float:
    return 1 / x


def _pid(_: int) -> int:
    return os.getpid()


def test_serial_and_pool_give_results_in_task_order_and_name_the_failing_worker():
    args = [(i,) for i in range(5)]
    with SerialExecutor() as ex:
        assert ex.map(abs, [(-i,) for i in range(5)], ["t"] * 5) == [0, 1, 2, 3, 4]
        with pytest.raises(ConfigError, match="two is not allowed"):  # in-process: the task's own error
            ex.map(_fail_on_two, args, [f"task {i}" for i in range(5)])
    with LocalPoolExecutor(2) as ex:
        assert ex.map(_fail_on_two, [(i,) for i in (0, 1, 3)], ["a", "b", "c"]) == [0, 1, 9]
        assert os.getpid() not in ex.map(_pid, args, ["p"] * 5)
        with pytest.raises(ConfigError, match="^two is not allowed$"):  # the package's errors unchanged
            ex.map(_fail_on_two, args, [f"task {i}" for i in range(5)])
        with pytest.raises(ConfigError, match="^five is not allowed$"):  # the lowest failed index wins
            ex.map(_fail_from_two, [(i,) for i in (5, 4, 3, 2, 1)], [f"task {i}" for i in range(5)])
        with pytest.raises(TaskError, match=r"^task 1 failed: ZeroDivisionError: division by zero \(at "):
            ex.map(_divide, [(1,), (0,), (2,)], ["task 0", "task 1", "task 2"])


def test_open_executor_kinds():
    assert isinstance(open_executor(None), SerialExecutor)
    assert isinstance(open_executor(ExecutorConfig(kind="local", workers=1)), SerialExecutor)
    pool = open_executor(ExecutorConfig(kind="local", workers=3))
    assert isinstance(pool, LocalPoolExecutor) and pool.workers == 3
    assert ExecutorConfig(kind="local").n_workers() == (os.cpu_count() or 1)


@pytest.mark.slow
def test_smoke_on_local_pool_and_loopback_dask_cluster_gives_the_serial_bytes(smoke_run, tmp_path):
    """The same folder from 2 pool workers (small chunks) and a 2-worker Dask LocalCluster."""
    sc = load_scenario("smoke")
    pool = Experiment(sc, tmp_path / "pool", executor=ExecutorConfig(kind="local", workers=2, chunk_pairs=7)).run()
    assert pool.timings["evaluation"]["pairs"]["executor"] == "local"
    assert_same_folder(smoke_run.run_dir, pool.run_dir)
    dask = Experiment(sc, tmp_path / "dask", executor=ExecutorConfig(kind="dask", workers=2, chunk_pairs=50)).run()
    assert dask.timings["evaluation"]["pairs"] == {
        **dask.timings["evaluation"]["pairs"],
        "executor": "dask",
        "workers": 2,
    }
    assert_same_folder(smoke_run.run_dir, dask.run_dir)


class Interrupt(BaseException):
    """Stands for Ctrl-C / a killed job (not an Exception, like KeyboardInterrupt)."""


def test_interrupted_run_resumes_per_robot_and_per_chunk_to_the_same_bytes(smoke_run, tmp_path, monkeypatch):
    sc = load_scenario("smoke")
    run_dir = tmp_path / "run"
    ex = ExecutorConfig(kind="serial", chunk_pairs=8)
    real_map, real_chunk = maps_stage.map_robot, pairwork.align_chunk_task
    mapped: list[str] = []
    chunks: list[int] = []

    def map_robot(ctx, world, cfg, path, grader=None):
        if cfg.name == "b" and "interrupted" not in mapped:
            mapped.append("interrupted")
            raise Interrupt
        mapped.append(cfg.name)
        return real_map(ctx, world, cfg, path, grader)

    def align_chunk(spec, submaps, pairs):
        chunks.append(len(pairs))
        if len(chunks) == 3:
            raise Interrupt
        return real_chunk(spec, submaps, pairs)

    monkeypatch.setattr(maps_stage, "map_robot", map_robot)
    monkeypatch.setattr(pairwork, "align_chunk_task", align_chunk)
    with pytest.raises(Interrupt):  # robot a finished, b interrupted
        Experiment(sc, run_dir, executor=ex).run()
    assert mapped == ["a", "interrupted"]
    assert (run_dir / "partial" / "maps" / "a.json").is_file() and not (run_dir / "maps" / "b.npz").exists()
    with pytest.raises(Interrupt):  # b mapped (a reused), evaluation interrupted in its third chunk
        Experiment(sc, run_dir, executor=ex).run()
    assert mapped == ["a", "interrupted", "b"]
    assert len(list((run_dir / "partial" / "evaluation").glob("*.json"))) == 2
    assert not (run_dir / "partial" / "maps").exists()  # the maps stage completed
    Experiment(sc, run_dir, executor=ex).run()
    n_pairs = smoke_run.metrics.n_pairs
    n_chunks = -(-n_pairs // 8)
    assert len(chunks) == 3 + (n_chunks - 2)  # the two finished chunks were not aligned again
    assert sum(chunks[3:]) == n_pairs - 16
    assert not (run_dir / "partial").exists()
    assert_same_folder(smoke_run.run_dir, run_dir)


def test_checkpoints_of_another_configuration_are_ignored(smoke_run, tmp_path, monkeypatch):
    """A checkpoint under another stage key (other aligner settings) is recomputed, not reused."""
    run_dir = tmp_path / "copy"
    shutil.copytree(smoke_run.run_dir, run_dir)
    fake = run_dir / "partial" / "evaluation"
    fake.mkdir(parents=True)
    calls: list[int] = []
    real_chunk = pairwork.align_chunk_task

    def align_chunk(spec, submaps, pairs):
        calls.append(len(pairs))
        return real_chunk(spec, submaps, pairs)

    monkeypatch.setattr(pairwork, "align_chunk_task", align_chunk)
    first = sorted(smoke_run.metrics.methods)
    (fake / "stale.json").write_text('{"schema": "roman_sim.checkpoint/1", "key": "other", "data": []}')
    Experiment(load_scenario("smoke"), run_dir, from_stage="evaluation").run()
    assert sum(calls) == smoke_run.metrics.n_pairs
    assert sorted(smoke_run.metrics.methods) == first
    assert_same_folder(smoke_run.run_dir, run_dir)


def test_a_task_error_stops_the_run_with_one_line(tmp_path):
    sc = load_scenario(
        "smoke",
        [
            "robots.0.max_length_m=6",
            "robots.1.max_length_m=6",
            "aligners=[roman, 'no_such_module_xyz:Aligner']",
            "posegraph_method=roman",
        ],
    )
    with pytest.raises(RomanSimError, match="no_such_module_xyz"):
        Experiment(sc, tmp_path / "r", executor=ExecutorConfig(kind="local", workers=2)).run()
