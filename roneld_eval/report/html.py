"""report.html: a run's tables and pictures on one self-contained page (images embedded).

Built from the files of a run folder, so `roneld-eval show` can refresh it after adding
pictures. It opens from disk with no server and no network.
"""

from __future__ import annotations

import base64
import html
import json
import re
from pathlib import Path

import pandas as pd

STYLE = """
body { font-family: system-ui, -apple-system, "Segoe UI", sans-serif; margin: 2em auto; max-width: 1100px;
       color: #1a1a1a; padding: 0 1em; line-height: 1.45; }
h1 { font-size: 1.6em; margin-bottom: .2em; } h2 { font-size: 1.2em; margin-top: 1.8em; border-bottom: 1px solid #ccc; }
table { border-collapse: collapse; margin: .6em 0; font-size: .9em; }
th, td { border: 1px solid #bbb; padding: .3em .6em; text-align: right; } th { background: #eee; }
td:first-child, th:first-child { text-align: left; }
img { max-width: 100%; border: 1px solid #ddd; } .meta { color: #555; font-size: .9em; }
"""


def _markdown_table(text: str) -> str:
    """Our own Markdown tables (| a | b |) as HTML; **bold** kept."""
    rows = [line.strip() for line in text.splitlines() if line.strip().startswith("|")]
    if len(rows) < 2:
        return ""
    def cells(line):
        return [html.escape(c.strip()) for c in line.strip("|").split("|")]
    def bold(cell):
        return re.sub(r"\*\*(.+?)\*\*", r"<b>\1</b>", cell)
    head = "".join(f"<th>{c}</th>" for c in cells(rows[0]))
    body = "".join("<tr>" + "".join(f"<td>{bold(c)}</td>" for c in cells(row)) + "</tr>" for row in rows[2:])
    return f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def _csv_table(path: Path) -> str:
    table = pd.read_csv(path)
    return table.to_html(index=False, float_format=lambda v: f"{v:.4f}", na_rep="n/a", border=0)


def _image(path: Path, alt: str) -> str:
    data = base64.b64encode(path.read_bytes()).decode("ascii")
    return f'<img alt="{html.escape(alt)}" src="data:image/png;base64,{data}">'


def build_html(folder: Path) -> str:
    """The page for the run in `folder`."""
    folder = Path(folder)
    summary = json.loads((folder / "summary.json").read_text()) if (folder / "summary.json").exists() else {}
    config = summary.get("config", {})
    counts = summary.get("counts", {})
    dataset = {"culane": "CULane", "tusimple": "TuSimple"}.get(summary.get("dataset"), summary.get("dataset", "?"))
    parts = [f"<h1>roneld-eval: {html.escape(str(config.get('model', '')))} on {html.escape(dataset)}</h1>",
             '<p class="meta">' + html.escape(
                 f"{counts.get('clips', '?')} clips, {counts.get('frames', '?')} frames, "
                 f"{counts.get('labelled_frames', '?')} scored, {counts.get('ego_lanes', '?')} ego lanes; "
                 f"data: {summary.get('data_root', '?')}; roneld-eval {summary.get('versions', {}).get('roneld-eval', '?')}")
             + "</p>"]
    sections = [
        ("Accuracy (the RONELD paper's protocol)", "accuracy.md", None,
         "True positive when IoU &gt; threshold; Acc. Inc. with its 95% interval (paired bootstrap over clips)."),
        ("Accuracy against IoU threshold", None, "accuracy_curve.png", None),
        ("Preceding-frame tracking ablation", "ablation.md", None, None),
        ("Official scores", "official.csv", None,
         "CULane: SCNN's evaluator (IoU &gt; 0.5, 30 px) per category, and 'ego': the two ego lanes only. "
         "TuSimple: evaluate/lane.py."),
        ("By category", None, "categories.png", None),
        ("Runtime per frame", "runtime.md", None, "Extraction alone, after numba warm-up; map loading apart."),
        ("Where the methods differ most", None, "overlays.png", "Ground truth blue, baseline red (dashed), RONELD green; "
         "numbers are each lane's IoU."),
    ]
    for title, table_file, image_file, note in sections:
        table_path = folder / table_file if table_file else None
        image_path = folder / image_file if image_file else None
        if (table_path is None or not table_path.exists()) and (image_path is None or not image_path.exists()):
            continue
        parts.append(f"<h2>{html.escape(title)}</h2>")
        if note:
            parts.append(f'<p class="meta">{note}</p>')
        if table_path is not None and table_path.exists():
            parts.append(_csv_table(table_path) if table_path.suffix == ".csv" else _markdown_table(table_path.read_text()))
        if image_path is not None and image_path.exists():
            parts.append(_image(image_path, title))
    body = "\n".join(parts)
    return (f'<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8"><title>roneld-eval report</title>'
            f"<style>{STYLE}</style></head><body>\n{body}\n</body></html>\n")
