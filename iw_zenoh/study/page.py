"""The HTML page of ``iwz study``: conditions side by side (each measure's mean, 95 % interval and
runs), a plot per measure (every run a dot, the mean and its interval a bar, one column per
condition), the failed runs with their reasons, and every run's row. Self-contained: the plots
are inline SVG, nothing is fetched from anywhere."""

from __future__ import annotations

import html
import io
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import matplotlib as mpl
import numpy as np
from matplotlib.backends.backend_svg import FigureCanvasSVG
from matplotlib.figure import Figure

from iw_zenoh.record.report import ROWS, RUN_ROWS

__all__ = ["page", "write_page"]

mpl.use("Agg")

STYLE = """body{font-family:sans-serif;margin:1.5em}table{border-collapse:collapse;margin:0.5em 0}
td,th{border:1px solid #ccc;padding:0.2em 0.6em;text-align:right}th:first-child,td:first-child{text-align:left}
.plots{display:flex;flex-wrap:wrap;gap:1em}.plots svg{width:22em;height:auto}.failed{color:#a00}
.ci{color:#666;font-size:smaller}"""
FORMATS = {k: f for k, _, f in (*ROWS, *RUN_ROWS)}  # measure -> its number format (iwz report's)
LABELS = {k: label for k, label, _ in (*RUN_ROWS, *ROWS)}


def _fmt(key: str, v: float) -> str:
    fmt = FORMATS.get(key, "{:.2f}")
    return f"{v:.2f}" if fmt == "{}" else fmt.format(v)  # a count's mean has decimals


def _cell(key: str, s: Mapping[str, Any] | None) -> str:
    if not s:
        return "<td>-</td>"
    lo, hi = s["ci95"]
    return (
        f"<td>{html.escape(_fmt(key, s['mean']))} <span class=ci>[{html.escape(_fmt(key, lo))}, "
        f"{html.escape(_fmt(key, hi))}] n={s['n']}</span></td>"
    )


def _svg(fig: Figure) -> str:
    buf = io.StringIO()
    with mpl.rc_context({"svg.fonttype": "none"}):  # text as text: a smaller page
        FigureCanvasSVG(fig).print_svg(buf)  # type: ignore[no-untyped-call]
    text = buf.getvalue()
    return text[text.index("<svg") :]


def _plot(key: str, rows: Sequence[Mapping[str, Any]], names: list[str], summary: Mapping[str, Any]) -> str:
    """Every run's value of a run measure, by condition, with each condition's mean and interval."""
    fig = Figure(figsize=(4.2, 2.6))
    ax = fig.add_subplot()
    for i, name in enumerate(names):
        vals = [r["report"]["run"].get(key) for r in rows if r["condition"] == name and r.get("report")]
        vals = [v for v in vals if v is not None]
        if vals:
            jitter = np.linspace(-0.12, 0.12, len(vals)) if len(vals) > 1 else np.zeros(1)
            ax.plot(i + jitter, vals, "o", color="tab:blue", alpha=0.6, markersize=4)
        s = summary[name]["run"].get(key)
        if s:
            lo, hi = s["ci95"]
            ax.errorbar(
                [i + 0.3], [s["mean"]], yerr=[[s["mean"] - lo], [hi - s["mean"]]], fmt="s", color="k", capsize=4
            )
    ax.set_xticks(range(len(names)), names)
    ax.set_xlim(-0.6, len(names) - 0.4)
    ax.set_title(LABELS.get(key, key), fontsize=10)
    fig.tight_layout()
    return _svg(fig)


def _table(names: list[str], summary: Mapping[str, Any]) -> str:
    head = "<tr><th>measure</th>" + "".join(f"<th>{html.escape(n)}</th>" for n in names) + "</tr>"
    rows = [
        "<tr><th>runs measured (failed)</th>"
        + "".join(f"<td>{summary[n]['runs']} ({summary[n]['failed']})</td>" for n in names)
        + "</tr>",
        "<tr><th>criteria met</th>" + "".join(f"<td>{summary[n]['criteria_met']}</td>" for n in names) + "</tr>",
        "<tr><th>duration, s</th>" + "".join(_cell("duration_s", summary[n]["duration_s"]) for n in names) + "</tr>",
    ]
    rows += [
        f"<tr><th>{html.escape(label)}</th>" + "".join(_cell(k, summary[n]["run"].get(k)) for n in names) + "</tr>"
        for k, label, _ in RUN_ROWS
    ]
    out = [f"<h2>The runs</h2><p>mean [95 % interval] n=runs</p><table>{head}{''.join(rows)}</table>"]
    ids = sorted({rid for n in names for rid in summary[n]["chairs"]}, key=int)
    for rid in ids:
        per = [summary[n]["chairs"].get(rid) for n in names]
        name = next(c["name"] for c in per if c)
        reached = "".join(f"<td>{c['reached']} of {c['runs']}</td>" if c else "<td>-</td>" for c in per)
        lines = [f"<tr><th>goal reached</th>{reached}</tr>"]
        lines += [
            f"<tr><th>{html.escape(label)}</th>"
            + "".join(_cell(k, c["measures"].get(k) if c else None) for c in per)
            + "</tr>"
            for k, label, _ in ROWS
        ]
        out.append(f"<h2>Chair {html.escape(rid)} ({html.escape(name)})</h2><table>{head}{''.join(lines)}</table>")
    return "".join(out)


def _runs(rows: Sequence[Mapping[str, Any]]) -> str:
    head = "<tr><th>condition</th><th>seed</th><th>status</th><th>criteria</th><th>goals</th><th>collisions</th>"
    head += "<th>duration, s</th><th>wall, s</th><th>reason</th></tr>"
    lines = []
    for r in rows:
        run = (r.get("report") or {}).get("run", {})
        dur = (r.get("report") or {}).get("duration_s")
        cls = "" if r.get("status") == "ok" else ' class="failed"'
        cells = [
            r["condition"],
            r["seed"],
            r.get("status", ""),
            "met" if r.get("criteria_met") else "-",
            run.get("goals_reached", "-"),
            run.get("collisions", "-"),
            "-" if dur is None else f"{dur:.1f}",
            r.get("wall_s", "-"),
            r.get("reason", ""),
        ]
        lines.append(f"<tr{cls}>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in cells) + "</tr>")
    return f"<h2>Every run</h2><table>{head}{''.join(lines)}</table>"


def page(study: Mapping[str, Any]) -> str:
    """The page of a study (``iwz study``'s JSON object)."""
    names = [c["name"] for c in study["conditions"]]
    summary, rows = study["summary"], study["runs"]
    conds = "".join(
        f"<li><b>{html.escape(c['name'])}</b>: {html.escape(' '.join(c['sets']) or 'the scenario as written')}</li>"
        for c in study["conditions"]
    )
    keys = [k for k, _, _ in RUN_ROWS if any(summary[n]["run"].get(k) for n in names)]
    plots = "".join(_plot(k, rows, names, summary) for k in keys)
    failed = [r for r in rows if r.get("status") != "ok"]
    fails = (
        "<h2 class=failed>Failed runs</h2><ul>"
        + "".join(
            f"<li class=failed>{html.escape(r['condition'])} seed {r['seed']}: {html.escape(r.get('reason', ''))}</li>"
            for r in failed
        )
        + "</ul>"
        if failed
        else ""
    )
    title = f"iwz study: {html.escape(study['scenario_name'])}"
    return (
        f'<!doctype html><html><head><meta charset="utf-8"><title>{title}</title><style>{STYLE}</style></head>'
        f"<body><h1>{title}</h1><p>{html.escape(study['scenario'])}, seeds {html.escape(study['seeds_text'])}, "
        f"{len(rows)} runs</p><ul>{conds}</ul>{fails}{_table(names, summary)}"
        "<h2>Plots</h2><p>each dot a run; the square its mean, the bar its 95 % interval</p>"
        f'<div class="plots">{plots}</div>'
        f"{_runs(rows)}</body></html>"
    )


def write_page(path: Path, study: Mapping[str, Any]) -> None:
    """Writes :func:`page` to ``path`` (UTF-8)."""
    path.write_text(page(study), encoding="utf-8")
