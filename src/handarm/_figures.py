"""Figures without pyplot: handarm never changes the user's matplotlib backend.

Pictures are drawn on ``matplotlib.figure.Figure`` objects with their own Agg canvas, so that
importing handarm leaves ``matplotlib.get_backend()`` as the user set it, and nothing is
registered with pyplot's figure manager.
"""

from __future__ import annotations

import io
import os
from pathlib import Path

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from handarm._io import write_bytes_atomic

__all__ = ["new_figure", "save_png"]


def new_figure(figsize: tuple[float, float]) -> Figure:
    """A Figure with an Agg canvas of ``figsize`` inches."""
    fig = Figure(figsize=figsize)
    FigureCanvasAgg(fig)
    return fig


def save_png(fig: Figure, path: str | os.PathLike[str], dpi: int = 110) -> Path:
    """Render ``fig`` to PNG at ``path`` atomically; returns the path."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi, bbox_inches="tight")
    path = Path(path)
    write_bytes_atomic(path, buf.getvalue())
    return path
