"""A benchmark's section of a document: the text between its two markers, replaced whole."""

from __future__ import annotations

from pathlib import Path


def replace_section(doc: Path, start: str, end: str, section: str) -> None:
    """Put ``section`` (which begins with ``start`` and ends with ``end``) in place of the document's
    text between those markers, or at its end when it has none yet; the rest is kept as it is.

    Parameters
    ----------
    doc : Path
        A Markdown document (created if missing).
    start, end : str
        The markers (HTML comments).
    section : str
        The new section, markers included.
    """
    text = doc.read_text(encoding="utf-8") if doc.exists() else ""
    if start in text and end in text:
        head, rest = text.split(start, 1)
        text = head + section + rest.split(end, 1)[1]
    else:
        text = text.rstrip("\n") + "\n\n" + section + "\n"
    doc.write_text(text, encoding="utf-8")
