"""The OpenAPI document as the docs page shows it: its descriptions, written as docstrings in
reStructuredText, made the Markdown Swagger UI renders."""

from __future__ import annotations

import re
from typing import Any

from fastapi import FastAPI

__all__ = ["markdown", "markdown_descriptions", "openapi_in_markdown"]


#: a reStructuredText role (``:mod:`api.auth```, ``:attr:`~Settings.x```): its target is shown as code
_ROLE = re.compile(r":[a-z]+(?::[a-z]+)?:`~?([^`]+)`")


def markdown(text: str) -> str:
    """A docstring's reStructuredText as the Markdown the docs page renders: roles and literals
    (``:mod:`x```, double backquotes) become code spans; the rest (paragraphs, ``-`` lists) is read
    alike by both. Markdown given to it comes back unchanged.

    Parameters
    ----------
    text : str

    Returns
    -------
    str
    """
    return _ROLE.sub(r"`\1`", text).replace("``", "`")


def markdown_descriptions(document: Any) -> Any:
    """An OpenAPI document with every ``description`` made :func:`markdown` (in place; returned)."""
    if isinstance(document, dict):
        for key, value in document.items():
            if key == "description" and isinstance(value, str):
                document[key] = markdown(value)
            else:
                markdown_descriptions(value)
    elif isinstance(document, list):
        for value in document:
            markdown_descriptions(value)
    return document


def openapi_in_markdown(app: FastAPI) -> None:
    """Make ``app.openapi()`` answer the document with its descriptions (from docstrings) as the
    Markdown the docs page renders."""
    plain_openapi = app.openapi

    def openapi_markdown() -> dict[str, Any]:
        """The OpenAPI document, its descriptions (from docstrings) as the Markdown the docs page renders."""
        return markdown_descriptions(plain_openapi())

    app.openapi = openapi_markdown  # type: ignore[method-assign]
