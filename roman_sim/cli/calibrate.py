"""``roman-sim calibrate``: fit the simulated front end to a real segmenter or encoder."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import typer
import yaml
from rich.console import Console
from rich.table import Table

from roman_sim.cli import app
from roman_sim.cli.listing import LISTINGS
from roman_sim.core.errors import ConfigError

console = Console(stderr=True)


def _entry(text: str | None, option: str) -> Any:
    """A component entry from the command line: a name or a YAML mapping ``{name: ..., params: {...}}``."""
    if text is None:
        return None
    try:
        value = yaml.safe_load(text)
    except yaml.YAMLError:
        raise ConfigError(f"{option}: {text!r} is not a name or a YAML mapping") from None
    if not isinstance(value, (str, dict)):
        raise ConfigError(f"{option}: expected a name or {{name: ..., params: {{...}}}}, got {text!r}")
    return value


def _fmt(v: Any) -> str:
    return "n/a" if v is None else f"{v:.3f}"


def _print(cal: Any) -> None:
    out = Console()
    if cal.measured_descriptors is not None:
        t = Table(title="descriptor cosines: measured / simulated with the fitted semantics (mean)")
        for col in ("class", "pairs", "measured", "fitted"):
            t.add_column(col, justify="right" if col != "class" else "left")
        fitted = cal.fitted_descriptors.classes if cal.fitted_descriptors is not None else {}
        for name, st in cal.measured_descriptors.classes.items():
            t.add_row(name, str(st.pairs), _fmt(st.mean), _fmt(fitted[name].mean if name in fitted else None))
        out.print(t)
    if cal.measured_segmentation is not None:
        m, f = cal.measured_segmentation, cal.fitted_segmentation
        t = Table(title="segmentation: measured / fastsam with the fitted rates")
        for col in ("grade", "measured", "fitted"):
            t.add_column(col, justify="right" if col != "grade" else "left")
        for name in ("precision", "recall", "mean_iou"):
            t.add_row(name, _fmt(getattr(m, name)), _fmt(getattr(f, name)))
        for name in ("over_segmented", "under_segmented", "spurious"):
            t.add_row(
                f"{name} / frame", _fmt(getattr(m, name) / max(m.frames, 1)), _fmt(getattr(f, name) / max(f.frames, 1))
            )
        out.print(t)


@app.command("calibrate")
def calibrate_cmd(
    scenario: str = typer.Argument(..., help="bundled scenario name or YAML path (its world and robots are rendered)"),
    encoder: str | None = typer.Option(
        None, "--encoder", help="encoder to measure: a name or '{name: clip, params: {weights: /path}}'"
    ),
    segmenter: str | None = typer.Option(None, "--segmenter", help="segmenter to measure, same form"),
    out: Path = typer.Option(Path("calibration.yaml"), "--out", "-o", help="YAML with the fitted frontend section"),
    grades: Path | None = typer.Option(None, "--grades", help="also write measured and fitted grades (JSON)"),
    plot: Path | None = typer.Option(None, "--plot", help="also plot the measured grades (PNG, with a PDF beside it)"),
    frames: int = typer.Option(120, "--frames", min=2, help="frames rendered in all"),
    overrides: list[str] = typer.Option([], "--set", help="override a scenario field, key=value"),
) -> None:
    """Measure an encoder and/or a segmenter on rendered frames; write the fitted simulated front end."""
    from roman_sim.core.atomic import output_file, write_text
    from roman_sim.core.config import validate_model
    from roman_sim.core.records import write_record
    from roman_sim.evaluation.grades import FrontEndGrades, SegmentationGrades
    from roman_sim.frontend.components import build_encoder, build_segmenter, encoder_spec
    from roman_sim.pipeline.calibration import calibrate, render_calibration_frames
    from roman_sim.pipeline.scenario import load_scenario
    from roman_sim.report.grades import plot_frontend_grades

    enc, seg = _entry(encoder, "--encoder"), _entry(segmenter, "--segmenter")
    if enc is None and seg is None:
        raise ConfigError("calibrate: give --encoder and/or --segmenter (what to measure)")
    for path, what in ((out, "--out"), (grades, "--grades"), (plot, "--plot")):
        if path is not None:
            output_file(path, what, create=False)
    sc = load_scenario(scenario, overrides)
    data = sc.frontend.model_dump(mode="json")
    if enc is not None:
        data["encoder"] = enc
    if seg is not None:
        data["segmenter"] = seg
    fe = validate_model(type(sc.frontend), data, source="frontend")
    # Truth-free targets (models) are built first, so bad weights fail before anything renders.
    truth_enc = enc is None or encoder_spec(fe.encoder).reads_truth
    target_enc = None if truth_enc else build_encoder(fe, sc.seed, "calibration")
    target_seg = None if seg is None else build_segmenter(fe, sc.seed, "calibration")
    console.print(f"rendering {frames} frames of {sc.name} ...")
    cal = calibrate(
        render_calibration_frames(sc, frames),
        fe,
        encoder=enc is not None,
        segmenter=seg is not None,
        target_encoder=target_enc,
        target_segmenter=target_seg,
    )
    cal.meta = {"scenario": sc.name, **(cal.meta or {})}
    write_text(out, cal.frontend_yaml())
    if grades is not None:
        write_record(grades, cal.record())
    if plot is not None:
        seg_grades = cal.measured_segmentation or SegmentationGrades()
        plot_frontend_grades(
            FrontEndGrades(
                fe.segmenter.name if seg is not None else "-",
                fe.encoder.name if enc is not None else None,
                seg_grades,
                cal.measured_descriptors,
            ),
            plot,
        )
    _print(cal)
    console.print(f"wrote {out}")


def _encoders() -> list[str]:
    from roman_sim.frontend.components import ENCODER_TYPES

    return ENCODER_TYPES.names()


LISTINGS.update(encoders=_encoders)
