"""One self-contained HTML page: sections of Plotly figures, tables and text.

The page embeds plotly.js from the installed ``plotly`` package (``get_plotlyjs``), so it
opens offline and nothing is fetched at view time. Figures are placed with
``Plotly.newPlot`` from their JSON; every figure div has the class ``plot``.
"""

from __future__ import annotations

import html
import json
from collections.abc import Iterable, Sequence
from pathlib import Path

from handarm._io import write_text_atomic

__all__ = ["Page", "fmt"]

_STYLE = """
body { font-family: system-ui, sans-serif; margin: 0 auto; max-width: 1200px; padding: 0 1em 3em;
       color: #222; }
h1 { margin-bottom: 0.2em; } h2 { border-bottom: 1px solid #ccc; margin-top: 1.6em; }
table { border-collapse: collapse; margin: 0.6em 0; font-size: 0.9em; }
th, td { border: 1px solid #ccc; padding: 3px 7px; text-align: right; vertical-align: top; }
th { background: #f2f2f2; } td.t, th.t { text-align: left; }
pre { background: #f7f7f7; padding: 0.7em; overflow-x: auto; font-size: 0.85em; }
.plot { width: 100%; min-height: 420px; }
.row { display: flex; gap: 1em; flex-wrap: wrap; } .row > div { flex: 1 1 420px; }
.verdict { font-weight: bold; padding: 0.3em 0.6em; display: inline-block; border-radius: 4px; }
.ok { background: #d8f0dc; } .bad { background: #f6d5d2; } .unknown { background: #eee; }
label.slider { display: grid; grid-template-columns: 9em 1fr 6em; gap: 0.5em;
               align-items: center; }
button { margin: 2px; }
nav a { margin-right: 1em; }
"""


def fmt(value, digits: int = 3) -> str:
    """A number for a table cell: ``digits`` significant digits, text as is."""
    if isinstance(value, bool) or value is None:
        return "" if value is None else ("yes" if value else "no")
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return f"{value:.{digits}g}"
    return str(value)


class Page:
    """An HTML report being assembled; ``write`` renders it into one file.

    Parameters
    ----------
    title : str
        Page title (also the first heading).
    """

    def __init__(self, title: str) -> None:
        self.title = title
        self._body: list[str] = []
        self._scripts: list[str] = []
        self._nav: list[tuple[str, str]] = []
        self.plots = 0

    def section(self, title: str, anchor: str) -> None:
        """Start a section (a level-2 heading, listed in the navigation bar)."""
        self._nav.append((f"sec-{anchor}", title))  # sec-: never a plot div's id
        self._body.append(f'<h2 id="sec-{anchor}">{html.escape(title)}</h2>')

    def text(self, paragraph: str) -> None:
        """A paragraph of plain text (escaped)."""
        self._body.append(f"<p>{html.escape(paragraph)}</p>")

    def raw(self, fragment: str) -> None:
        """An HTML fragment as is (the caller escapes what it inserts)."""
        self._body.append(fragment)

    def pre(self, text: str) -> None:
        """Preformatted text (escaped)."""
        self._body.append(f"<pre>{html.escape(text)}</pre>")

    def table(self, headers: Sequence[str], rows: Iterable[Sequence], text_columns=(0,)) -> None:
        """A table; cells are formatted with ``fmt``, headers should carry the units."""
        head = "".join(
            f'<th class="{"t" if i in text_columns else ""}">{html.escape(h)}</th>'
            for i, h in enumerate(headers)
        )
        body = []
        for row in rows:
            cells = "".join(
                f'<td class="{"t" if i in text_columns else ""}">{html.escape(fmt(v))}</td>'
                for i, v in enumerate(row)
            )
            body.append(f"<tr>{cells}</tr>")
        self._body.append(f"<table><tr>{head}</tr>{''.join(body)}</table>")

    def figure(self, fig, div_id: str, *, height: int = 480, wrap: bool = True) -> str:
        """Place a Plotly figure; returns its div (placed here unless ``wrap`` is False)."""
        self.plots += 1
        fig.update_layout(height=height, margin={"l": 40, "r": 20, "t": 50, "b": 40})
        spec = fig.to_json()
        div = f'<div class="plot" id="{div_id}"></div>'
        self._scripts.append(
            f"(function() {{ const f = {spec};\n"
            f"Plotly.newPlot({json.dumps(div_id)}, f.data, f.layout, "
            "{responsive: true, displaylogo: false}); })();"
        )
        if wrap:
            self._body.append(div)
        return div

    def script(self, code: str) -> None:
        """JavaScript run after every figure is placed."""
        self._scripts.append(code)

    def render(self) -> str:
        """The whole page as HTML text."""
        from plotly.offline import get_plotlyjs

        nav = " ".join(f'<a href="#{a}">{html.escape(t)}</a>' for a, t in self._nav)
        return "\n".join(
            [
                "<!DOCTYPE html>",
                '<html lang="en"><head><meta charset="utf-8">',
                f"<title>{html.escape(self.title)}</title>",
                f"<style>{_STYLE}</style>",
                f'<script type="text/javascript">{get_plotlyjs()}</script>',
                "</head><body>",
                f"<h1>{html.escape(self.title)}</h1>",
                f"<nav>{nav}</nav>",
                *self._body,
                "<script>",
                *self._scripts,
                "</script>",
                "</body></html>",
            ]
        )

    def write(self, path: str | Path) -> Path:
        """Write the page atomically; returns the path."""
        path = Path(path)
        write_text_atomic(path, self.render())
        return path
