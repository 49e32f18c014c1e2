"""The product's MCAP recording format (recordings/FORMAT.md): writer, strict reader, third-party listing.

A recording in MCAP is one topic per channel (``/<channel name>``) carrying
blocks of samples.  Messages are protobuf, and the schema embedded in the
file is a real protobuf ``FileDescriptorSet`` (``engine_monitor.SampleBlock``,
``engine_monitor.EventBlock``, with ``google.protobuf.Timestamp``), so a
general MCAP viewer such as Foxglove decodes and plots them.  The recording's
attributes are an MCAP metadata record ``recording``; each channel's are its
MCAP channel metadata.  Chunks are compressed (zstd or lz4) and carry CRCs.

Schema.  The messages are those of ``proto/engine_monitor/recording.proto``,
shipped with the product; its compiled descriptor is the schema embedded in
each file.  The protobuf runtime encodes and decodes them, as ``BlockWire``:
the same fields and wire format, the packed samples taken as the bytes they
are on the wire (a packed ``repeated float`` is a little-endian float32
array), so numpy views them without work per sample; the tests check the
official decoder reads the blocks as ``SampleBlock`` and ``EventBlock``.

Layout.  Each chunk holds one channel: a window of about ``chunk_size``
bytes of it, the windows of all channels in turn, so that a reader of one
topic decompresses that topic's chunks only.

Reading.  :func:`~monitor.io.mcap.reader.read_mcap` streams the file record by record with CRC
validation, which serves indexed and unindexed files alike; a file cut
short is read up to its last whole record, that is its last whole chunk
(a record the file ends inside is never parsed), and the result says so
(``truncated``), unless the cut leaves a channel without samples, which is
refused naming it; a CRC or decompression failure is a checksum failure.
A damaged file is refused with a :class:`FormatError`, in one line, naming what is wrong.
:func:`~monitor.io.mcap.reader.open_mcap` reads an indexed file topic by topic, forward in time, in
bounded memory (the analysis of an hour-long recording).

Modules:

- :mod:`monitor.io.mcap.wire`: the format's names, its schema and the blocks' wire format.
- :mod:`monitor.io.mcap.metadata`: the recording's metadata records and the channels' metadata, and
  the CRC that covers the former.
- :mod:`monitor.io.mcap.writer`: :func:`~monitor.io.mcap.writer.write_mcap`.
- :mod:`monitor.io.mcap.records`: an MCAP file's records, CRCs checked, a file cut short or damaged
  told apart.
- :mod:`monitor.io.mcap.reader`: :func:`~monitor.io.mcap.reader.read_mcap` and
  :func:`~monitor.io.mcap.reader.open_mcap`.
- :mod:`monitor.io.mcap.samples`: a waveform channel read forward by slices (``open_mcap``'s).
- :mod:`monitor.io.mcap.listing`: the topics of any MCAP file.
"""
