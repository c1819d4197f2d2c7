"""``roman-sim scenario ...``: look at a scenario without running it."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.console import Console
from rich.table import Table

from roman_sim.cli import app

scenario_app = typer.Typer(help="Inspect scenarios without rendering or aligning anything.", no_args_is_help=True)
app.add_typer(scenario_app, name="scenario")


@scenario_app.command("stats")
def stats_cmd(
    scenario: str = typer.Argument(..., help="scenario YAML path or bundled scenario name"),
    sets: list[str] | None = typer.Option(None, "--set", "-s", help="override, e.g. --set seed=3"),
    min_pairs: int = typer.Option(10, "--min-pairs", min=1, help="relevant pairs that join two robots"),
    out: Path | None = typer.Option(None, "--out", help="also write the figures as JSON to this file"),
) -> None:
    """Relevant cross-robot pairs per robot pair and whether the robots' overlap graph is connected.

    Paths are planned and driven (no rendering); submap centres are placed as a run places them.
    """
    from roman_sim.core.atomic import output_file
    from roman_sim.pipeline.scenario import load_scenario
    from roman_sim.pipeline.scenario_stats import scenario_stats

    if out is not None:
        output_file(out, "--out", create=False)
    sc = load_scenario(scenario, list(sets or []))
    st = scenario_stats(sc, min_pairs)
    console = Console()
    robots = Table("robot", "submaps", "km", "lateral offset (m)", title=f"{sc.name} (seed {sc.seed})")
    for r, c in st.centres.items():
        robots.add_row(r, str(len(c)), f"{st.length_m[r] / 1000:.2f}", f"{st.offset_m[r]:+.2f}")
    console.print(robots)
    pairs = Table(
        "robots", "relevant pairs", f">= {min_pairs}", title=f"relevant: true centres within {st.relevant_dist_m:g} m"
    )
    for (a, b), n in st.counts.items():
        pairs.add_row(f"{a}, {b}", str(n), "yes" if n >= min_pairs else "no")
    console.print(pairs)
    console.print(st.graph.describe())
    if out is not None:
        from roman_sim.core.atomic import write_json

        write_json(
            out,
            {
                "scenario": sc.name,
                "seed": sc.seed,
                "relevant_dist_m": st.relevant_dist_m,
                "min_pairs": min_pairs,
                "submaps": {r: len(c) for r, c in st.centres.items()},
                "length_m": st.length_m,
                "lateral_offset_m": st.offset_m,
                "relevant_pairs": {f"{a}|{b}": n for (a, b), n in st.counts.items()},
                "connected": st.graph.connected,
                "components": st.graph.components,
            },
        )
