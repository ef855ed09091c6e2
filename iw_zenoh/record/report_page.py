"""The HTML page of ``iwz report --html``: the figures as tables and plots (paths on the map,
speed and clearance over time), one column per run; self-contained (PNGs embedded as base64,
nothing fetched from anywhere)."""

from __future__ import annotations

import base64
import html
import io
from collections.abc import Sequence
from pathlib import Path

import matplotlib as mpl
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.patches import Polygon as PatchPolygon

from iw_zenoh.record.metrics import RunReport, speeds
from iw_zenoh.record.report import ROWS, RUN_ROWS

__all__ = ["page", "write_page"]

mpl.use("Agg")

STYLE = """body{font-family:sans-serif;margin:1.5em}table{border-collapse:collapse;margin:0.5em 0}
td,th{border:1px solid #ccc;padding:0.2em 0.6em;text-align:right}th:first-child,td:first-child{text-align:left}
.runs{display:flex;gap:1.5em;flex-wrap:wrap}.run{flex:1;min-width:28em}img{max-width:100%}"""


def _png(fig: Figure) -> str:
    """A figure as an ``<img>`` with its PNG inline."""
    buf = io.BytesIO()
    FigureCanvasAgg(fig).print_png(buf)  # type: ignore[no-untyped-call]
    return f'<img alt="plot" src="data:image/png;base64,{base64.b64encode(buf.getvalue()).decode()}">'


def _paths(r: RunReport) -> str:
    fig = Figure(figsize=(6, 4))
    ax = fig.add_subplot()
    for w in r.walls:
        ax.add_patch(PatchPolygon(np.asarray(w), closed=True, color="0.5"))
    for rid, s in sorted(r.series.items()):
        ax.plot(s.x, s.y, label=f"chair {rid}")
        ax.plot(s.x[:1], s.y[:1], "o", color="k", markersize=3)
    ax.set_aspect("equal")
    ax.autoscale()
    ax.set(xlabel="x, m", ylabel="y, m", title="paths (dot: start)")
    ax.legend(fontsize="small")
    return _png(fig)


def _over_time(r: RunReport) -> str:
    fig = Figure(figsize=(6, 5))
    top, bottom = fig.subplots(2, 1, sharex=True)
    for rid, s in sorted(r.series.items()):
        t, v = speeds(s)
        top.plot(t, v, label=f"chair {rid}")
        gap = np.minimum(np.asarray(s.wall_m), np.asarray(s.people_m))
        bottom.plot(s.t_s, np.where(np.isfinite(gap), gap, np.nan), label=f"chair {rid}")
    top.set(ylabel="speed, m/s", title="speed and clearance")
    bottom.set(xlabel="simulation time, s", ylabel="clearance, m")
    top.legend(fontsize="small")
    fig.tight_layout()
    return _png(fig)


def _rows(values: list[object], label: str) -> str:
    cells = "".join(f"<td>{html.escape(str(v))}</td>" for v in values)
    return f"<tr><th>{html.escape(label)}</th>{cells}</tr>"


def _fmt(v: object, fmt: str) -> str:
    return "-" if v is None else fmt.format(v)


def _tables(reports: Sequence[tuple[str, RunReport]]) -> str:
    head = "<tr><th></th>" + "".join(f"<th>{html.escape(n)}</th>" for n, _ in reports) + "</tr>"
    run = [_rows([f"{r.duration_s:.1f}" for _, r in reports], "duration, s")]
    run += [_rows([_fmt(r.run.get(k), f) for _, r in reports], label) for k, label, f in RUN_ROWS]
    out = [f"<h2>The run</h2><table>{head}{''.join(run)}</table>"]
    for rid in sorted({c.robot_id for _, r in reports for c in r.chairs}):
        per = [next((c for c in r.chairs if c.robot_id == rid), None) for _, r in reports]
        name = next(c.name for c in per if c is not None)
        rows = [_rows([_fmt(getattr(c, k) if c else None, f) for c in per], label) for k, label, f in ROWS]
        out.append(f"<h2>Chair {rid} ({html.escape(name)})</h2><table>{head}{''.join(rows)}</table>")
    return "".join(out)


def page(reports: Sequence[tuple[str, RunReport]]) -> str:
    """The whole page for one or two runs.

    Args:
        reports: ``(name, report)`` of each run, in column order.

    Returns:
        The HTML text.
    """
    cols = "".join(f'<div class="run"><h3>{html.escape(n)}</h3>{_paths(r)}{_over_time(r)}</div>' for n, r in reports)
    title = " vs ".join(html.escape(Path(n).name) for n, _ in reports)
    return (
        f'<!doctype html><html><head><meta charset="utf-8"><title>iwz report: {title}</title>'
        f"<style>{STYLE}</style></head><body><h1>iwz report: {title}</h1>"
        f'{_tables(reports)}<h2>Plots</h2><div class="runs">{cols}</div></body></html>'
    )


def write_page(path: Path, reports: Sequence[tuple[str, RunReport]]) -> None:
    """Writes :func:`page` to ``path`` (UTF-8)."""
    path.write_text(page(reports), encoding="utf-8")
