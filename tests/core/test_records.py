"""The schema-checked JSON reader and writer: a dataclass round-trips to the same bytes, and a file
that does not match fails with one line naming the file and the field."""

from __future__ import annotations

import ast
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal, TypedDict

import numpy as np
import pytest
from committed_results import STANDARD

import roman_sim
from roman_sim.core.config import StrictModel
from roman_sim.core.errors import StorageError
from roman_sim.core.jsontypes import JSONLike
from roman_sim.core.records import (
    INLINE,
    NONE_AS_EMPTY,
    OMIT_EMPTY,
    OMIT_NONE,
    RecordError,
    dumps_record,
    from_json,
    json_key,
    loads_record,
    read_record,
    to_json,
    via,
    write_record,
)


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


@dataclass
class _Counts:
    hits: int
    relevant: int


@dataclass
class _Curve:
    """An older file's layout: the counts at the top level, then the pair sets as keys of their own."""

    label: str = field(metadata=json_key("curve-label"))
    counts: _Counts = field(metadata=INLINE)
    recall: np.ndarray = field(
        metadata=via(
            list[float | None],
            lambda a: [None if math.isnan(x) else x for x in a.tolist()],
            lambda v: np.array([math.nan if x is None else x for x in v]),
        )
    )
    sets: dict[str, _Counts] = field(default_factory=dict, metadata=INLINE)
    points: dict[str, int] = field(default_factory=dict, metadata=OMIT_EMPTY)
    extra: _Counts | None = field(default=None, metadata=NONE_AS_EMPTY)


class _Settings(StrictModel):
    k_max: int = 30


@dataclass
class _Run:
    settings: _Settings


def test_inline_fields_sit_at_their_parents_level_and_read_back() -> None:
    curve = _Curve("a", _Counts(3, 4), np.array([0.5, math.nan]), {"inter": _Counts(1, 2)})
    data = to_json(curve)
    expected = {
        "curve-label": "a",
        "hits": 3,
        "relevant": 4,
        "recall": [0.5, None],
        "inter": {"hits": 1, "relevant": 2},
    }
    assert data == {**expected, "extra": {}}  # no points (empty: left out), no extra (None: {})
    back = from_json(_Curve, json.loads(json.dumps(data)), "c.json")
    assert back.counts == curve.counts and back.sets == curve.sets and back.extra is None and back.points == {}
    assert back.recall[0] == 0.5 and math.isnan(back.recall[1])
    assert dumps_record(back) == dumps_record(curve)
    assert loads_record(dumps_record(curve), _Curve, "c.npz").label == "a"


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda d: d.pop("hits"), "field hits: missing"),
        (lambda d: d.pop("curve-label"), "field curve-label: missing"),
        (lambda d: d["inter"].update(hits="x"), "field inter.hits: expected an integer"),
        (lambda d: d.update(recall=[0.5, "x"]), "field recall[1]: expected a number, got a string"),
        (lambda d: d.update(extra={"hits": 1}), "field extra.relevant: missing"),
    ],
)
def test_an_inline_or_converted_field_names_its_path(edit, message: str) -> None:
    data = json.loads(json.dumps(to_json(_Curve("a", _Counts(3, 4), np.zeros(2), {"inter": _Counts(1, 2)}))))
    edit(data)
    with pytest.raises(RecordError) as e:
        from_json(_Curve, data, "c.json")
    assert str(e.value).startswith(f"c.json: {message}"), str(e.value)


def test_an_inline_dataclass_alone_leaves_no_key_unclaimed() -> None:
    @dataclass
    class Flat:
        counts: _Counts = field(metadata=INLINE)

    with pytest.raises(RecordError, match=r"^f.json: field other: unknown \(valid: hits, relevant\)$"):
        from_json(Flat, {"hits": 1, "relevant": 2, "other": 3}, "f.json")


def test_a_pydantic_model_is_its_json_dump_and_its_errors_name_the_field() -> None:
    assert to_json(_Run(_Settings(k_max=5))) == {"settings": {"k_max": 5}}
    assert from_json(_Run, {"settings": {"k_max": 5}}, "m.json") == _Run(_Settings(k_max=5))
    with pytest.raises(RecordError, match=r"^m.json: field settings.k_max: ") as e:
        from_json(_Run, {"settings": {"k_max": "many"}}, "m.json")
    assert "\n" not in str(e.value)
    with pytest.raises(RecordError, match=r"^m.json: field settings.other: unknown key"):
        from_json(_Run, {"settings": {"other": 1}}, "m.json")


def test_a_document_inside_a_file_names_the_file() -> None:
    with pytest.raises(RecordError, match=r"^x.npz: not valid JSON"):
        loads_record(b"{", _Counts, "x.npz")
    with pytest.raises(RecordError, match=r"^x.npz: not a JSON document \(not UTF-8"):
        loads_record(b"\xff", _Counts, "x.npz")


#: The modules that may parse JSON themselves: the records mechanism, and the independent scorer
#: (which must not share code with what it checks).
JSON_PARSERS = {"roman_sim/core/records.py", "roman_sim/studies/independent_scorer.py"}
_PARSE = {"load", "loads", "JSONDecoder", "raw_decode"}


def _json_parses(tree: ast.AST) -> list[int]:
    """Lines of ``tree`` that parse JSON with the standard library (``json.load``, ``json.loads``, a
    decoder), whatever name ``json`` or its functions are imported under."""
    modules, functions = set(), set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            modules |= {a.asname or a.name for a in node.names if a.name == "json"}
        elif isinstance(node, ast.ImportFrom) and node.module == "json":
            functions |= {a.asname or a.name for a in node.names if a.name in _PARSE}
    lines = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and node.attr in _PARSE:
            if isinstance(node.value, ast.Name) and node.value.id in modules:
                lines.append(node.lineno)
        elif isinstance(node, ast.Name) and node.id in functions:
            lines.append(node.lineno)
    return lines


def test_only_the_records_module_parses_json() -> None:
    """Every JSON document the package reads goes through ``roman_sim.core.records`` (checked fields,
    one line naming the file and the field); no other module calls ``json.load`` / ``json.loads``."""
    root = Path(roman_sim.__file__).parent
    found = {
        f"{p.relative_to(root.parent).as_posix()}:{line}"
        for p in sorted(root.rglob("*.py"))
        if p.relative_to(root.parent).as_posix() not in JSON_PARSERS
        for line in _json_parses(ast.parse(p.read_text(encoding="utf-8")))
    }
    assert not found, "JSON parsed outside roman_sim.core.records: " + ", ".join(sorted(found))
    assert _json_parses(ast.parse((root / "core" / "records.py").read_text(encoding="utf-8")))


def test_the_json_rule_sees_every_spelling() -> None:
    source = "import json as j\nfrom json import loads as parse\nj.load(f)\nparse(s)\nx = json.loads\nj.dumps(v)\n"
    assert sorted(_json_parses(ast.parse(source))) == [3, 4]  # json itself is not imported: line 5 is another name
