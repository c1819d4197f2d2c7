"""The docs site's structure: every page is in the navigation, every API page documents a package."""

from __future__ import annotations

import importlib
import re
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"


def _nav_pages(node: object) -> list[str]:
    if isinstance(node, str):
        return [node]
    if isinstance(node, list):
        return [p for item in node for p in _nav_pages(item)]
    if isinstance(node, dict):
        return [p for v in node.values() for p in _nav_pages(v)]
    return []


def test_every_page_is_in_the_navigation_once():
    config = yaml.safe_load((ROOT / "mkdocs.yml").read_text(encoding="utf-8"))
    nav = _nav_pages(config["nav"])
    pages = sorted(p.relative_to(DOCS).as_posix() for p in DOCS.rglob("*.md"))
    assert sorted(nav) == pages


def test_api_pages_name_importable_packages():
    for page in sorted((DOCS / "api").glob("*.md")):
        for name in re.findall(r"^::: ([\w.]+)$", page.read_text(encoding="utf-8"), flags=re.M):
            importlib.import_module(name)
    documented = {
        n for p in (DOCS / "api").glob("*.md") for n in re.findall(r"^::: ([\w.]+)$", p.read_text(), flags=re.M)
    }
    packages = {f"roman_sim.{p.name}" for p in (ROOT / "roman_sim").iterdir() if (p / "__init__.py").is_file()}
    assert packages <= documented
