"""Import from what test benches write: ASAM MDF (asammdf), NI TDMS (npTDMS) and text exports.

A channel-mapping file (TOML) says which source channels become which
recording channels, with the attributes the product needs and the source
does not carry::

    engine_id = "medium-speed-6l32"
    start_time = "2026-11-22T10:15:00Z"   # optional: else the file's own start time
    sample_rate_hz = 25600.0               # optional: else from the file (--rate overrides both)
    [[channel]]
    source = "Vibration/MB3 vertical"      # TDMS: "group/channel"; MDF: the channel name
    name = "mb3-vertical"
    kind = "acceleration"
    unit = "g"                              # optional: else the source's unit
    location = "main bearing 3"
    direction = "vertical"
    scale = 1.0                             # optional factor applied to the samples
    [[channel]]
    source = "Speed/Teeth"
    name = "tooth"
    kind = "tooth"
    fields = { teeth = 60, missing_teeth = 2, first_tooth_angle_deg = 117.0 }

Text exports (``.csv``, ``.txt``, ``.tsv``, and ``.dat`` that is not MDF): one
row per sample, a time column and one column per channel.  The mapping says
more, since a text file carries no start time and no units::

    engine_id = "kluczyk-1cyl-4stroke"
    start_time = "2026-11-22T10:15:00Z"   # required
    time_column = "time"                   # a header name, or a 0-based column number: time_column = 0
    time_unit = "s"                        # "s" (default), "ms", "us" or "ns"
    delimiter = "tab"                      # optional: "tab", ",", ";", "whitespace" or another character
    header_rows = 1                        # optional: lines before the first row of numbers
    time_tolerance_s = 5e-7                # optional: largest deviation of a time from the fixed-rate line
    [[channel]]
    source = 1                             # a 0-based column number, or a header name: source = "tooth"
    name = "tooth"
    kind = "tooth"
    unit = "V"                             # required
    fields = { teeth = 60, missing_teeth = 2, first_tooth_angle_deg = 117.5 }

Without ``delimiter``, it is the first of tab, semicolon, comma and
whitespace that splits the file's last lines into equal numbers of numbers.
With a delimiter other than the comma, a comma in a number is a decimal comma
(``0,25``); a number with both a point and a comma (a thousands separator) is
refused.  Without ``header_rows``, the header is the lines before the first
row of numbers; a column named by ``source`` is looked up in it.  The file is
read in blocks of rows: memory holds the samples (float32 when the first and
last rows print at most 7 significant digits, which float32 tells apart;
float64 otherwise) and the float64 time column.

The sample rate.  ``--rate`` or the mapping's ``sample_rate_hz`` is used as
given, for every channel; the times then give only the start offset.  Else the
rate is derived from the times (a text file's time column, the time stamps of
an MDF channel) by a least-squares line of time against sample index, whose
deviations must stay within the rounding of the written times: half the last
printed digit of a text file's times (fixed decimals or significant digits,
read from its first and last rows), half the decimal grid (1 us, 10 us ...)
that an MDF channel's stamps lie on, or the mapping's ``time_tolerance_s``.
Times with a gap or jitter beyond that are refused with the row named.  When
the nearest whole number of hertz fits the times as well, that is the rate.
TDMS waveforms carry their sample interval (``wf_increment``).

Logic analysers' level-change captures (text): a time column and a column of
levels, 0 or 1, per input, as sigrok-cli's ``csv`` output (a row per sample,
or with ``dedup`` the rows where a level changed) and Saleae Logic 2's digital
export (a row per change) write them.  The mapping says so with ``layout``;
each channel becomes an event channel holding the times of its edges::

    engine_id = "medium-speed-6l32"
    start_time = "2026-11-22T10:15:00Z"   # required: the time 0 of the capture's time column
    layout = "level changes"               # default "samples": the columns of samples above
    time_column = 0                        # optional: default 0; a header name also
    time_unit = "ns"                       # optional: else the header's unit ("nanoseconds", "Time [s]")
    [[channel]]
    source = "D0"                          # a header name, or a 0-based column number
    name = "tooth"
    kind = "tooth"                         # tooth, cam or keyphasor: an angle reference's pulses
    edge = "rising"                        # optional: "rising" (default) or "falling"
    fields = { teeth = 60, missing_teeth = 2, first_tooth_angle_deg = 117.0 }

An edge is a row whose level differs from the row before it, at that row's
time; the stated angles (``first_tooth_angle_deg``, ``cam_angle_deg``,
``pulse_angle_deg``) are those of the chosen edge.  No rate is derived (the
rows are not samples at a rate); ``sample_rate_hz``, ``--rate``,
``time_tolerance_s``, ``header_rows``, a ``scale`` and a ``unit`` other than
``s`` are refused, and so is a kind other than tooth, cam or keyphasor.
Lines starting with ``;`` before the header are comments; the delimiter is
found (``,``, tab, ``;`` or whitespace) or given as ``delimiter``.  A level
other than 0 or 1 (Saleae's ``X``: no data), a time that does not increase,
or a mapped input without an edge of the kind asked for is refused, naming
the line or the column (:mod:`~monitor.io.imports.levels`).

The MDF and TDMS readers are an optional extra (``pip install 'engine-monitor[import]'``);
text files need nothing more.

Modules: :mod:`~monitor.io.imports.mapping` (the channel-mapping file),
:mod:`~monitor.io.imports.rates` (a fixed rate from written times), one module per format
(:mod:`~monitor.io.imports.tdms`, :mod:`~monitor.io.imports.mdf`, :mod:`~monitor.io.imports.text`,
:mod:`~monitor.io.imports.levels`) and :mod:`~monitor.io.imports.dispatch` (a file read by its
suffix and the mapping's ``layout``).
"""
