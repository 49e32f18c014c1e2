import datetime

from google.protobuf import timestamp_pb2 as _timestamp_pb2
from google.protobuf.internal import containers as _containers
from google.protobuf import descriptor as _descriptor
from google.protobuf import message as _message
from collections.abc import Iterable as _Iterable, Mapping as _Mapping
from typing import ClassVar as _ClassVar, Optional as _Optional, Union as _Union

DESCRIPTOR: _descriptor.FileDescriptor

class SampleBlock(_message.Message):
    __slots__ = ("timestamp", "start_offset_s", "sample_rate_hz", "samples_f32", "samples_f64", "mean", "rms", "minimum", "maximum")
    TIMESTAMP_FIELD_NUMBER: _ClassVar[int]
    START_OFFSET_S_FIELD_NUMBER: _ClassVar[int]
    SAMPLE_RATE_HZ_FIELD_NUMBER: _ClassVar[int]
    SAMPLES_F32_FIELD_NUMBER: _ClassVar[int]
    SAMPLES_F64_FIELD_NUMBER: _ClassVar[int]
    MEAN_FIELD_NUMBER: _ClassVar[int]
    RMS_FIELD_NUMBER: _ClassVar[int]
    MINIMUM_FIELD_NUMBER: _ClassVar[int]
    MAXIMUM_FIELD_NUMBER: _ClassVar[int]
    timestamp: _timestamp_pb2.Timestamp
    start_offset_s: float
    sample_rate_hz: float
    samples_f32: _containers.RepeatedScalarFieldContainer[float]
    samples_f64: _containers.RepeatedScalarFieldContainer[float]
    mean: float
    rms: float
    minimum: float
    maximum: float
    def __init__(self, timestamp: _Optional[_Union[datetime.datetime, _timestamp_pb2.Timestamp, _Mapping]] = ..., start_offset_s: _Optional[float] = ..., sample_rate_hz: _Optional[float] = ..., samples_f32: _Optional[_Iterable[float]] = ..., samples_f64: _Optional[_Iterable[float]] = ..., mean: _Optional[float] = ..., rms: _Optional[float] = ..., minimum: _Optional[float] = ..., maximum: _Optional[float] = ...) -> None: ...

class EventBlock(_message.Message):
    __slots__ = ("timestamp", "times_s")
    TIMESTAMP_FIELD_NUMBER: _ClassVar[int]
    TIMES_S_FIELD_NUMBER: _ClassVar[int]
    timestamp: _timestamp_pb2.Timestamp
    times_s: _containers.RepeatedScalarFieldContainer[float]
    def __init__(self, timestamp: _Optional[_Union[datetime.datetime, _timestamp_pb2.Timestamp, _Mapping]] = ..., times_s: _Optional[_Iterable[float]] = ...) -> None: ...

class BlockWire(_message.Message):
    __slots__ = ("timestamp", "start_offset_s", "sample_rate_hz", "values_4", "values_5", "mean", "rms", "minimum", "maximum")
    TIMESTAMP_FIELD_NUMBER: _ClassVar[int]
    START_OFFSET_S_FIELD_NUMBER: _ClassVar[int]
    SAMPLE_RATE_HZ_FIELD_NUMBER: _ClassVar[int]
    VALUES_4_FIELD_NUMBER: _ClassVar[int]
    VALUES_5_FIELD_NUMBER: _ClassVar[int]
    MEAN_FIELD_NUMBER: _ClassVar[int]
    RMS_FIELD_NUMBER: _ClassVar[int]
    MINIMUM_FIELD_NUMBER: _ClassVar[int]
    MAXIMUM_FIELD_NUMBER: _ClassVar[int]
    timestamp: _timestamp_pb2.Timestamp
    start_offset_s: float
    sample_rate_hz: float
    values_4: bytes
    values_5: bytes
    mean: float
    rms: float
    minimum: float
    maximum: float
    def __init__(self, timestamp: _Optional[_Union[datetime.datetime, _timestamp_pb2.Timestamp, _Mapping]] = ..., start_offset_s: _Optional[float] = ..., sample_rate_hz: _Optional[float] = ..., values_4: _Optional[bytes] = ..., values_5: _Optional[bytes] = ..., mean: _Optional[float] = ..., rms: _Optional[float] = ..., minimum: _Optional[float] = ..., maximum: _Optional[float] = ...) -> None: ...
