"""Each stage owns its worker job: its tasks live in the module it names first, and its preload loads."""

from __future__ import annotations

from roman_sim.pipeline.stages import STAGES, WORKER_PRELOAD, evaluation_job, maps_job, submaps
from roman_sim.runner.preload import preload


def test_stages_that_send_tasks_name_the_module_of_their_task_functions_first() -> None:
    first = {s.name: s.worker_preload[0] for s in STAGES if s.worker_preload}
    assert first["maps"] == maps_job.map_robot_task.__module__
    assert first["submaps"] == submaps.submaps_task.__module__
    assert first["evaluation"] == evaluation_job.align_chunk_task.__module__
    assert first["report"] == "roman_sim.report.render"
    assert {s.name for s in STAGES if s.uses_workers} == set(first)


def test_the_runs_preload_is_every_stages_list_once_and_loads_without_a_failure() -> None:
    listed = [m for s in STAGES for m in s.worker_preload]
    assert list(WORKER_PRELOAD) == list(dict.fromkeys(listed))
    assert "roman_sim.align.clipper:warm_up" in WORKER_PRELOAD
    assert preload(("roman_sim.pipeline.stages:WORKER_PRELOAD",)) == []  # the entry the CLI starts the pool with
