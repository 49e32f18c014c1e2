"""What any MCAP file holds, by topic (files other programs wrote)."""

from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path

from mcap.records import Channel as McapChannel
from mcap.records import Message, Schema

from monitor.io.mcap.records import checked_records

__all__ = ["McapListing", "list_mcap"]


@dataclass(frozen=True)
class McapListing:
    """What an MCAP file holds, by topic (any schema, for files other programs wrote).

    Attributes
    ----------
    messages : dict of str to int
        Messages per topic.
    schemas : dict of str to str
        Schema name per topic.
    truncated : bool
        The file was cut short; counts cover its whole chunks.
    """

    messages: dict[str, int]
    schemas: dict[str, str]
    truncated: bool

    @property
    def total(self) -> int:
        """All messages."""
        return sum(self.messages.values())


def list_mcap(path: str | Path) -> McapListing:
    """Count the messages per topic of any MCAP file, streaming, CRCs checked.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    McapListing
    """
    source = Path(path)
    schemas: dict[int, str] = {}
    topics: dict[int, str] = {}
    counts: dict[str, int] = defaultdict(int)
    truncated = False
    names: dict[str, str] = {}
    for record in checked_records(source):
        if record is None:
            truncated = True
        elif isinstance(record, Schema):
            schemas[record.id] = record.name
        elif isinstance(record, McapChannel):
            topics[record.id] = record.topic
            names[record.topic] = schemas.get(record.schema_id, "")
            counts.setdefault(record.topic, 0)
        elif isinstance(record, Message):
            counts[topics.get(record.channel_id, f"channel {record.channel_id}")] += 1
    return McapListing(dict(counts), names, truncated)
