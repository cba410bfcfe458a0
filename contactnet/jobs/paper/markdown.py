"""The building blocks of the report's markdown: tables, numbers, and `Report`, the text being written with the
figures it refers to (``DIR/report_plots/``). Shared by the paper's parts (`contactnet.jobs.paper.report`) and the
frontier's (`contactnet.jobs.paper.frontier`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from contactnet.jobs.paper.results import SectionResult

PLOTS = "report_plots"


def table(headers: list[str], rows: list[list[object]]) -> list[str]:
    """A markdown table (cells as text, pipes escaped)."""
    def cell(value: object) -> str:
        return str(value).replace("|", "\\|").replace("\n", " ")

    return ["| " + " | ".join(map(cell, headers)) + " |", "|" + "---|" * len(headers),
            *("| " + " | ".join(map(cell, row)) + " |" for row in rows), ""]


def ms(value: float) -> str:
    """A time in ms with 3 decimals; "-" for none."""
    return "-" if value is None or np.isnan(value) else f"{value:.3f}"


class Report:
    """The markdown being written, with the plots it refers to."""

    def __init__(self, out: Path, header: dict, sections: dict[str, SectionResult]):
        self.out, self.header, self.sections = out, header, sections
        self.lines: list[str] = []
        (out / PLOTS).mkdir(exist_ok=True)

    @property
    def scaled(self) -> bool:
        return self.header.get("scale", 1.0) < 1.0

    @property
    def plan(self) -> str:
        """"paper" (the paper's Sec. IV and the frontier) or "frontier" (the frontier alone)."""
        return self.header.get("plan", "paper")

    def met(self, ok: bool) -> str:
        """"yes" / "no"; in parentheses on a scaled run."""
        word = "yes" if ok else "no"
        return f"({word})" if self.scaled else word

    def add(self, *lines: str) -> None:
        self.lines.extend(lines)

    def figure(self, name: str, caption: str, draw) -> None:  # noqa: ANN001
        path = self.out / PLOTS / f"{name}.png"
        draw(path)
        self.add(f"![{caption}]({PLOTS}/{name}.png)", "")

    def section(self, folder: str) -> SectionResult | None:
        found = self.sections.get(folder)
        return found if found is not None and found.records else None

    def missing(self, folder: str) -> None:
        self.add(f"*Not in this run (no stored trials of `{folder}`).*", "")
