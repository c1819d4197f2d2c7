"""Fail when two or more modules of the package import each other, directly or through others.

The import graph is grimp's (the library behind import-linter): every import statement of
every module, those inside functions and under ``TYPE_CHECKING`` included. Prints each cycle
(a strongly connected component of the module graph) and exits with 1 when there is one.
"""

from __future__ import annotations

import sys

import grimp
import networkx as nx


def cycles(package: str = "roman_sim") -> list[list[str]]:
    """Every set of modules of ``package`` that import each other, each sorted, largest first."""
    graph = grimp.build_graph(package)
    g = nx.DiGraph()
    for module in graph.modules:
        g.add_node(module)
        for imported in graph.find_modules_directly_imported_by(module):
            g.add_edge(module, imported)
    comps = [sorted(c) for c in nx.strongly_connected_components(g) if len(c) > 1]
    return sorted(comps, key=lambda c: (-len(c), c))


def main() -> int:
    found = cycles()
    for comp in found:
        print("import cycle: " + " <-> ".join(comp))
    if not found:
        print("no import cycles")
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
