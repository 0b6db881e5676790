"""Self-contained HTML report: figures embedded as data URIs, tables, settings.

The report is one file that can be mailed or archived: PNG figures are
embedded (base64), videos are embedded when small enough and otherwise linked
relative to the report (a video a browser cannot play, not H.264, is shown as a
still frame with a note), settings are shown as JSON.
"""

from __future__ import annotations

import base64
import html
import json
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from dexlfd.io import atomic_write

__all__ = ["Report", "Section", "words", "write_report"]

MAX_EMBEDDED_VIDEO_BYTES = 12 * 1024 * 1024

_CSS = """
body{font-family:system-ui,-apple-system,Segoe UI,sans-serif;max-width:1200px;margin:2em auto;
padding:0 1em;color:#222;line-height:1.45}
h1{border-bottom:2px solid #444}h2{margin-top:2em;border-bottom:1px solid #ccc}
figure{margin:1em 0}figure img,video{max-width:100%;border:1px solid #ddd}
figcaption{font-size:.9em;color:#555}
table{border-collapse:collapse;margin:1em 0;font-size:.92em}
td,th{border:1px solid #bbb;padding:.25em .6em;text-align:right}th{background:#f0f0f0}
td:first-child,th:first-child{text-align:left}
pre{background:#f6f6f6;padding:.8em;overflow-x:auto;font-size:.85em}
.note{background:#fff8e0;border-left:4px solid #e0b000;padding:.5em 1em}
"""


@dataclass
class Section:
    """One part of the report (a pipeline stage, typically)."""

    title: str
    paragraphs: list[str] = field(default_factory=list)
    figures: list[tuple[Path, str]] = field(default_factory=list)  # (png, caption)
    tables: list[tuple[Sequence[str], Sequence[Sequence[Any]], str]] = field(
        default_factory=list
    )  # (header, rows, caption)
    videos: list[tuple[Path, str]] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    preformatted: list[str] = field(default_factory=list)  # monospace text (tables, logs)
    settings: dict[str, Any] | None = None


@dataclass
class Report:
    """A titled list of sections."""

    title: str
    intro: str = ""
    sections: list[Section] = field(default_factory=list)


def _data_uri(path: Path, mime: str) -> str:
    return f"data:{mime};base64," + base64.b64encode(path.read_bytes()).decode()


def words(value: Any) -> str:
    """A value as a reader reads it: yes/no, "none", lists comma-separated, floats to 6 digits.

    Python's own spellings (``True``, ``None``, ``[0.1, 0.2]``) are no prose.
    """
    if isinstance(value, bool):
        return "yes" if value else "no"
    if value is None:
        return "none"
    if isinstance(value, float):
        return f"{value:.6g}"
    if isinstance(value, list | tuple):
        return ", ".join(words(v) for v in value) if value else "none"
    return str(value)


def _cell(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:.4g}"
    return html.escape(words(value))


def _section_html(sec: Section, folder: Path) -> str:
    e = html.escape
    parts = [f"<h2>{e(sec.title)}</h2>"]
    parts += [f"<p>{e(p)}</p>" for p in sec.paragraphs]
    parts += [f'<p class="note">{e(n)}</p>' for n in sec.notes]
    for header, rows, caption in sec.tables:
        head = "".join(f"<th>{e(str(h))}</th>" for h in header)
        body = "".join("<tr>" + "".join(f"<td>{_cell(v)}</td>" for v in r) + "</tr>" for r in rows)
        parts.append(f"<table><caption>{e(caption)}</caption><tr>{head}</tr>{body}</table>")
    parts += [f"<pre>{e(text)}</pre>" for text in sec.preformatted]
    for png, caption in sec.figures:
        if Path(png).is_file():
            parts.append(
                f'<figure><img src="{_data_uri(Path(png), "image/png")}" alt="{e(caption)}">'
                f"<figcaption>{e(caption)}</figcaption></figure>"
            )
        else:
            parts.append(f'<p class="note">figure missing: {e(str(png))}</p>')
    parts += [_video_html(Path(video), caption, folder) for video, caption in sec.videos]
    if sec.settings is not None:
        text = json.dumps(sec.settings, indent=2, sort_keys=True, default=str)
        parts.append(f"<details><summary>settings</summary><pre>{e(text)}</pre></details>")
    return "\n".join(parts)


def _video_html(video: Path, caption: str, folder: Path) -> str:
    """A ``<video>`` player; a still frame and a note where a browser cannot play the file.

    Browsers play H.264 MP4 only: a video written without an H.264 encoder (MPEG-4
    Part 2, see :mod:`dexlfd.io.video`) is shown as its middle frame, linked.
    """
    from dexlfd.io.video import browser_playable, still_frame_png

    e = html.escape
    if not video.is_file():
        return f'<p class="note">video missing: {e(str(video))}</p>'
    link = e(os.path.relpath(video, folder))
    if not browser_playable(video):
        png = still_frame_png(video)
        img = (
            f'<img src="data:image/png;base64,{base64.b64encode(png).decode()}" alt="{e(caption)}">'
            if png is not None
            else ""
        )
        return (
            f"<figure>{img}<figcaption>{e(caption)}: a still frame of "
            f'<a href="{link}">{e(video.name)}</a></figcaption></figure>'
            f'<p class="note">{e(video.name)} is not H.264, so browsers cannot play it: '
            "no H.264 encoder was found (install dexlfd[video], imageio-ffmpeg); it "
            "plays in desktop players such as VLC.</p>"
        )
    src = (
        _data_uri(video, "video/mp4") if video.stat().st_size <= MAX_EMBEDDED_VIDEO_BYTES else link
    )
    return (
        f'<figure><video controls muted loop preload="auto" src="{src}"></video>'
        f"<figcaption>{e(caption)} ({e(video.name)})</figcaption></figure>"
    )


def write_report(report: Report, path: str | os.PathLike[str]) -> Path:
    """Render ``report`` to one self-contained HTML file at ``path`` (atomic write)."""
    path = Path(path)
    folder = path.parent
    body = "\n".join(_section_html(s, folder) for s in report.sections)
    doc = (
        "<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>"
        f"<title>{html.escape(report.title)}</title><style>{_CSS}</style></head><body>"
        f"<h1>{html.escape(report.title)}</h1><p>{html.escape(report.intro)}</p>{body}"
        "</body></html>"
    )
    data = doc.encode()
    atomic_write(path, lambda fh: fh.write(data))
    return path
