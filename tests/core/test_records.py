"""The schema-checked JSON reader and writer: a dataclass round-trips to the same bytes, and a file
that does not match fails with one line naming the file and the field."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal, TypedDict

import pytest
from committed_results import STANDARD

from roman_sim.core.errors import StorageError
from roman_sim.core.jsontypes import JSONLike
from roman_sim.core.records import OMIT_NONE, RecordError, from_json, read_record, to_json, write_record


@dataclass(frozen=True)
class Point:
    hits: int
    recall: float | None
    ci: tuple[float, float] | None


@dataclass(frozen=True)
class Board:
    name: str
    kind: Literal["inter", "intra"]
    points: dict[str, Point]
    levels: list[Point]
    edges: tuple[float, ...]
    note: str | None = field(default=None, metadata=OMIT_NONE)
    done: bool = False


BOARD = Board(
    "quick",
    "inter",
    {"roman": Point(3, 0.5, (0.2, 0.8))},
    [Point(1, None, None), Point(2, 1, (0.5, 1.0))],
    (0.0, 60.0),
)


def _write(tmp_path: Path, data: object) -> Path:
    path = tmp_path / "board.json"
    path.write_text(json.dumps(data), encoding="utf-8")
    return path


def _good() -> dict:
    return json.loads(json.dumps({"schema": "test/1", **to_json(BOARD)}))  # type: ignore[dict-item]


def test_a_record_round_trips_to_the_same_object_and_bytes(tmp_path: Path) -> None:
    path = write_record(tmp_path / "b.json", BOARD, "test/1")
    data = json.loads(path.read_text(encoding="utf-8"))
    assert data["schema"] == "test/1" and "note" not in data  # None with OMIT_NONE: left out
    assert data["levels"][1]["recall"] == 1 and isinstance(data["levels"][1]["recall"], int)  # kept as written
    again = read_record(path, Board, "test/1")
    assert again == BOARD and isinstance(again.edges, tuple) and isinstance(again.points["roman"].ci, tuple)
    write_record(tmp_path / "c.json", again, "test/1")
    assert (tmp_path / "c.json").read_bytes() == path.read_bytes()


def test_the_committed_leaderboard_reads_and_writes_back_byte_identical(tmp_path: Path) -> None:
    from roman_sim.benchmark.board_records import read_leaderboard, write_leaderboard_json

    committed = STANDARD / "leaderboard.json"
    if not committed.is_file():
        pytest.skip("no committed standard benchmark")
    board = read_leaderboard(committed)
    assert board.levels[0].overall is not None and board.levels[0].overall.point("roman", "max_recall") is not None
    write_leaderboard_json(tmp_path / "leaderboard.json", board)
    assert (tmp_path / "leaderboard.json").read_bytes() == committed.read_bytes()


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda d: d["levels"][0].update(hits="3"), "field levels[0].hits: expected an integer, got a string ('3')"),
        (lambda d: d["levels"][0].update(hits=True), "field levels[0].hits: expected an integer, got a boolean (true)"),
        (lambda d: d["points"]["roman"].pop("recall"), "field points.roman.recall: missing"),
        (lambda d: d.pop("name"), "field name: missing"),
        (lambda d: d.update(kind="both"), "field kind: expected one of 'inter', 'intra', got a string ('both')"),
        (lambda d: d["points"]["roman"].update(ci=[0.1]), "field points.roman.ci: expected a list of 2 values, got 1"),
        (lambda d: d["levels"][1].update(recall="high"), "field levels[1].recall: expected a number, got a string"),
        (lambda d: d.update(levels={}), "field levels: expected a list, got an object"),
        (lambda d: d.update(extra=1), "field extra: unknown (valid: name, kind, points, levels, edges, note, done)"),
        (lambda d: d.update(schema="test/2"), "field schema: expected 'test/1', got 'test/2'"),
    ],
)
def test_a_wrong_or_missing_field_is_one_line_naming_the_file_and_field(tmp_path: Path, edit, message: str) -> None:
    data = _good()
    edit(data)
    path = _write(tmp_path, data)
    with pytest.raises(RecordError) as e:
        read_record(path, Board, "test/1")
    text = str(e.value)
    assert text.startswith(f"{path}: ") and message in text, text
    assert "\n" not in text and isinstance(e.value, StorageError)


def test_absent_optional_fields_read_as_their_defaults(tmp_path: Path) -> None:
    data = _good()
    del data["done"]
    assert read_record(_write(tmp_path, data), Board, "test/1") == BOARD


@pytest.mark.parametrize(
    ("text", "message"),
    [("{", r"not valid JSON \(line 1"), ("[1, 2]", "expected a JSON object, got a list"), (None, "cannot read")],
)
def test_an_unreadable_file_is_one_line(tmp_path: Path, text: str | None, message: str) -> None:
    path = tmp_path / "x.json"
    if text is not None:
        path.write_text(text, encoding="utf-8")
    with pytest.raises(RecordError, match=message) as e:
        read_record(path, Board, "test/1")
    assert str(e.value).startswith(f"{path}: ")


def test_from_json_names_the_source() -> None:
    with pytest.raises(RecordError, match=r"^summary of run x: field hits: expected an integer, got null$"):
        from_json(Point, {"hits": None, "recall": 0.5, "ci": None}, "summary of run x")


class _Row(TypedDict):
    name: str
    value: float | None
    extra: dict[str, JSONLike]


class _Table(TypedDict, total=False):
    rows: list[_Row]
    note: str


def test_a_typed_dict_is_checked_key_by_key_and_read_back_as_a_dict() -> None:
    data = {"rows": [{"name": "a", "value": 2, "extra": {"x": [1, {"y": None}]}}]}
    got = from_json(_Table, data, "t.json")
    assert got == data and type(got) is dict  # optional "note" may be absent; JSON values pass as they are
    with pytest.raises(RecordError, match=r"^t.json: field rows\[0\].value: expected a number, got a string"):
        from_json(_Table, {"rows": [{"name": "a", "value": "x", "extra": {}}]}, "t.json")
    with pytest.raises(RecordError, match=r"^t.json: field rows\[0\].extra: missing$"):
        from_json(_Table, {"rows": [{"name": "a", "value": 1.0}]}, "t.json")
    with pytest.raises(RecordError, match=r"^t.json: field other: unknown \(valid: rows, note\)$"):
        from_json(_Table, {"other": 1}, "t.json")
