"""report.html: a run's tables and pictures on one self-contained page (images embedded).

Built from the files of a run folder, so `roneld-eval show` can refresh it after adding
pictures. It opens from disk with no server and no network. Every note states the
configuration behind its numbers: the tables' own notes (accuracy.md, ...), and the geometry in
summary.json (the configuration's, marked so, when the run recorded none).
"""

from __future__ import annotations

import base64
import html
import io
import json
import re
from pathlib import Path, PurePath

import pandas as pd

from ..errors import InputError
from ..lanes_io import read_bytes, read_text
from ..limits import MAP, RUN_TABLE
from ..methods import METHOD_TABLE
from .gallery import GALLERY_FRAMES
from .tables import Protocol, display_name, official_headline

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
        return [html.escape(c.strip(), quote=False) for c in line.strip("|").split("|")]
    head = "".join(f"<th>{c}</th>" for c in cells(rows[0]))
    body = "".join("<tr>" + "".join(f"<td>{_bold(c)}</td>" for c in cells(row)) + "</tr>" for row in rows[2:])
    return f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def _markdown_notes(text: str) -> str:
    """The paragraphs of one of our Markdown files that are neither its title nor its table."""
    paragraphs = [block.strip() for block in text.split("\n\n")]
    notes = [block for block in paragraphs if block and not block.startswith(("#", "|"))]
    return _bold(" ".join(html.escape(" ".join(block.split()), quote=False) for block in notes))


def _bold(text: str) -> str:
    """Escaped Markdown text with its **bold** as HTML."""
    return re.sub(r"\*\*(.+?)\*\*", r"<b>\1</b>", text)


def _csv_table(path: Path, model: str | None = None) -> str:
    """A CSV of the run as HTML, methods under their display names when the model is known."""
    table = pd.read_csv(path)
    if model and "method" in table.columns:
        table["method"] = [display_name(method, model) for method in table["method"]]
    return table.to_html(index=False, float_format=lambda v: f"{v:.4f}", na_rep="n/a", border=0)


def _official_tables(path: Path, benchmark, model: str | None) -> str:
    """The official scores over the whole set per method, the full official.csv folded below
    (a VIL-100 run's has a row per video and threshold: wider and longer than a page)."""
    headline = official_headline(pd.read_csv(path), benchmark, model or "")
    full = _csv_table(path, model)
    if headline is None:
        return full
    return (_markdown_table(headline.to_markdown())
            + f"<details><summary>Every row of official.csv</summary>{full}</details>")


PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def _image(path: Path, alt: str) -> str:
    raw = read_bytes(path, limit=MAP)
    if not raw.startswith(PNG_SIGNATURE):
        raise InputError(path, "not a PNG image: report.html embeds only the pictures this tool draws")
    data = base64.b64encode(raw).decode("ascii")
    return f'<img alt="{html.escape(alt)}" src="data:image/png;base64,{data}">'


def _present(folder: Path, name: str | None) -> Path | None:
    """The file `name` in `folder`, or None when no name is given or the run has no such file; a
    symbolic link is refused (a folder read back could point it at any file, which the page would
    then carry to whoever it is shared with)."""
    if not name:
        return None
    path = folder / name
    if path.is_symlink():
        raise InputError(path, "a symbolic link: report.html embeds only the folder's own files")
    return path if path.exists() else None


def _shared_name(data_root, fixture: bool) -> str:
    """The data folder as a shared page may name it: its last part, not the user's directory
    layout (summary.json keeps the whole path)."""
    if fixture or not isinstance(data_root, str) or not data_root:
        return str(data_root or "?")
    return f".../{PurePath(data_root).name} (whole path in summary.json)"


def build_html(folder: Path, benchmark) -> str:
    """The page for the run in `folder`, of the dataset of `benchmark`."""
    folder = Path(folder)
    summary_path = folder / "summary.json"
    summary = json.loads(summary_path.read_text(encoding="utf-8")) if summary_path.exists() else {}
    config = summary.get("config", {})
    counts = summary.get("counts", {})
    protocol = Protocol.from_summary(summary)
    fixture = str(summary.get("data_root", "")).startswith("bundled fixture")
    dataset = benchmark.display_name
    title = f"roneld-eval: {config.get('model', '')} on {dataset}" + (" (bundled synthetic fixture)" if fixture else "")
    parts = [f"<h1>{html.escape(title)}</h1>",
             '<p class="meta">' + html.escape(
                 f"{counts.get('clips', '?')} clips, {counts.get('frames', '?')} frames, "
                 f"{counts.get('labelled_frames', '?')} scored, {counts.get('ego_lanes', '?')} ego lanes; "
                 f"data: {_shared_name(summary.get('data_root'), fixture)}; "
                 f"roneld-eval {summary.get('versions', {}).get('roneld-eval', '?')}")
             + "</p>"]
    if protocol is not None:
        line = f"Paper's protocol: {protocol.paper()}."
        official = benchmark.official_protocol(protocol)
        if official:
            line += f" Official {benchmark.display_name} protocol: {official}."
        parts.append(f'<p class="meta">{html.escape(line, quote=False)}</p>')
    notes = summary.get("notes")
    for note in notes if isinstance(notes, list) else ():
        if isinstance(note, str):  # summary.json is read back: text only, escaped
            parts.append(f'<p class="meta">Note: {html.escape(note, quote=False)}.</p>')
    official_note = benchmark.official_note(protocol)
    drawn = [f"{METHOD_TABLE[m].words} {METHOD_TABLE[m].overlay_colour}" for m in config.get("methods", METHOD_TABLE)
             if m in METHOD_TABLE]
    picture_note = (", ".join(["Ground truth blue", *drawn])
                    + "; numbers are each lane's IoU under the paper's protocol"
                    + (f" ({protocol.paper()})." if protocol is not None else "."))
    sections = [
        ("Accuracy (the RONELD paper's protocol)", "accuracy.md", None, None),
        ("Accuracy against IoU threshold", None, "accuracy_curve.png", None),
        ("Preceding-frame tracking ablation", "ablation.md", None, None),
        ("Official scores", "official.csv", None, official_note),
        ("By category", None, "categories.png", None),
        ("Runtime per frame", "runtime.md", None, None),
        ("Where the methods differ most", None, "overlays.png", picture_note),
    ]
    for title, table_file, image_file, note in sections:
        table_path = _present(folder, table_file)
        if table_path is not None and table_file == "official.csv":
            parts += _section(title, None, _present(folder, image_file), note,
                              _official_tables(table_path, benchmark, config.get("model")))
        else:
            parts += _section(title, table_path, _present(folder, image_file), note, model=config.get("model"))
    parts += diagnosis_sections(folder, folder, gallery_note(1, RUN_GALLERY))
    return _page(parts)


def _page(parts: list[str]) -> str:
    body = "\n".join(parts)
    return (f'<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8"><title>roneld-eval report</title>'
            f"<style>{STYLE}</style></head><body>\n{body}\n</body></html>\n")


def _section(title: str, table_path: Path | None, image_path: Path | None, note: str | None,
             table_html: str | None = None, model: str | None = None) -> list[str]:
    """A heading, the notes, a table (our Markdown or CSV file, or `table_html`) and a picture;
    nothing where there is neither table nor picture."""
    if table_path is None and image_path is None and table_html is None:
        return []
    parts = [f"<h2>{html.escape(title)}</h2>"]
    markdown: str | None = None
    if table_path is not None and table_path.suffix == ".md":
        markdown = read_text(table_path, RUN_TABLE)
    # A table's own notes (what produced its numbers) go with it; else the section's.
    text = html.escape(note, quote=False) if note else _markdown_notes(markdown) if markdown else ""
    if text:
        parts.append(f'<p class="meta">{text}</p>')
    if table_html is not None:
        parts.append(table_html)
    elif markdown is not None:
        parts.append(_markdown_tables(markdown))
    elif table_path is not None:
        parts.append(_csv_table(table_path, model))
    if image_path is not None:
        parts.append(_image(image_path, title))
    return parts


def _markdown_tables(text: str) -> str:
    """Every table of one of our Markdown files, each under its own `## ` heading where it has one."""
    blocks = re.split(r"^## (.+)$", text, flags=re.MULTILINE)
    out = [_markdown_table(blocks[0])]
    for heading, block in zip(blocks[1::2], blocks[2::2]):
        out += [f"<h3>{html.escape(heading.strip(), quote=False)}</h3>", _markdown_table(block)]
    return "".join(out)


def gallery_note(per_reason: int, redrawn: str) -> str:
    """What the gallery section says of its pictures: `per_reason` frames a reason, and how to draw
    them otherwise (`redrawn`)."""
    frames = "the frame" if per_reason == 1 else f"the {per_reason} frames"
    return (f"For each method, {frames} with most errors (FP + FN) in each category and with most of each error "
            "type: ground truth in blue, each method's lanes in turn red, green, ...; its counts in the caption. "
            f"{redrawn}")


RUN_GALLERY = (f"gallery.json keeps {GALLERY_FRAMES} frames a reason with their lanes; `roneld-eval score NAME "
               "--diagnose --out` on the run's lanes/ and `roneld-eval show --run` of that folder draw more, over the "
               "images.")


def _best_scores(path: Path) -> str:
    """The best F1 of each method's score sweep over all frames, as sweep_scores.csv marks it."""
    try:
        table = pd.read_csv(io.StringIO(read_text(path, RUN_TABLE)), keep_default_na=False,
                            dtype={"threshold": str, "score_threshold": str, "best": str})
        best = table[(table["category"] == "all") & (table["best"] == "True")]
        shown = best.drop(columns=["category", "best"]).to_html(index=False, border=0,
                                                              float_format=lambda v: f"{v:.4f}")
    except (ValueError, KeyError, pd.errors.ParserError) as error:
        raise InputError(path, f"not a score sweep this tool writes: {error}") from None
    if best.empty:
        raise InputError(path, "not a score sweep this tool writes: no row over all frames marks the best F1")
    return shown


def diagnosis_sections(tables: Path, pictures: Path, note: str) -> list[str]:
    """What --diagnose and --score-sweep wrote in `tables` (errors.md/.png, sweep_scores.csv/.png)
    and the gallery drawn in `pictures` (gallery.png, of which `note` speaks), as report.html
    shows them."""
    sweep = _present(tables, "sweep_scores.csv")
    return [*_section("Why F1 is not higher: error types", _present(tables, "errors.md"),
                      _present(tables, "errors.png"), None),
            *_section("Score sweep", None, _present(tables, "sweep_scores.png"),
                      "Precision, recall and F1 with only the lanes each score threshold keeps (by the benchmark's own "
                      "rule, in the figure's title); the best F1 is chosen on the test set itself (every threshold in "
                      "sweep_scores.csv).",
                      None if sweep is None else _best_scores(sweep)),
            *_section("Gallery: the worst frames", None, _present(pictures, "gallery.png"), note)]


def build_diagnosis_html(tables: Path, pictures: Path, title: str, per_reason: int) -> str:
    """The page of a score written with --diagnose or --score-sweep (`tables`), its gallery drawn
    in `pictures` (`roneld-eval show` writes it there, `per_reason` frames a reason)."""
    note = gallery_note(per_reason, f"gallery.json keeps {GALLERY_FRAMES} a reason: `--worst N` draws more, "
                                    "`--image-root` over the images.")
    return _page([f"<h1>{html.escape(title)}</h1>", *diagnosis_sections(tables, pictures, note)])
