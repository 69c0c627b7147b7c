"""Offline interactive HTML reports of builds, studies and optimizations.

``write_report(folder)`` looks at what the folder holds and writes ``folder/report.html``:
a ``handarm build`` folder (``design.toml`` and ``carve.json``), a study folder
(``results.csv``) or an optimization folder (``trials.csv``). The page is one file with
plotly.js embedded from the installed package: it opens without a network. Nothing is
recomputed but the verdicts of a few named poses.
"""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["write_report", "report_kind"]


def report_kind(folder: str | os.PathLike[str]) -> str:
    """What kind of output folder ``folder`` is: "build", "study" or "optimize".

    Returns
    -------
    str

    Raises
    ------
    ValueError
        If the folder does not exist or holds none of them.
    """
    folder = Path(folder)
    if not folder.is_dir():
        why = "is not a folder" if folder.exists() else "no such folder"
        raise ValueError(f"{folder}: {why}")
    if (folder / "design.toml").is_file() and (folder / "carve.json").is_file():
        return "build"
    if (folder / "trials.csv").is_file():
        return "optimize"
    if (folder / "results.csv").is_file():
        return "study"
    raise ValueError(
        f"{folder}: not a handarm output folder (no design.toml + carve.json, results.csv "
        "or trials.csv)"
    )


def write_report(folder: str | os.PathLike[str]) -> Path:
    """Write ``report.html`` into an output folder; returns its path.

    Parameters
    ----------
    folder : path
        What ``handarm build``, ``handarm study`` or ``handarm optimize`` wrote.

    Returns
    -------
    Path

    Raises
    ------
    ValueError
        If the folder is not one of those (the message says what is missing).
    """
    kind = report_kind(folder)
    try:
        if kind == "build":
            from handarm.report.build_page import build_report

            return build_report(folder)
        from handarm.report.study_page import study_report

        return study_report(folder, kind)
    except KeyError as exc:  # a file of the folder lacks what handarm writes into it
        raise ValueError(
            f"{folder}: a file of the folder lacks {exc} (edited, or from another version?)"
        ) from None
