"""The service's settings: limits, workers, sessions, alerts (``engine-monitor serve`` fills them)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from api.auth import SESSION_S
from api.reads import KEY_TTL_S
from api.validate import MAX_EXPANSION
from monitor.jobs.delivery import DeliveryPolicy

__all__ = ["Settings"]


@dataclass
class Settings:
    """The service's settings (``engine-monitor serve`` fills them from its options).

    Attributes
    ----------
    store_url : str
    data_dir : Path
        Stored recordings (``recordings/``), uploads in progress (``incoming/``), plots.
    max_upload_bytes : int
    validation_memory_bytes, validation_timeout_s : int, float
        Limits of the validating child process.
    validations, validations_per_fleet : int
        Files validated at once, in all and per fleet (a fleet's next waits, without a thread, so one
        fleet never takes every slot and reads never wait for validations).
    uploads_per_fleet : int
        A fleet's uploads in progress at once; one more is refused with 429.
    upload_idle_s : float
        Longest wait for the next bytes of an upload's body [s]; then 408.
    upload_min_rate : float
        Slowest average rate of an upload's body after its first ``upload_idle_s`` [bytes/s]; a
        slower one (a trickle that holds a connection and a file open) is cut off with 408.
    max_expansion : float
        Declared samples [bytes] per byte of file beyond which an upload is refused unread.
    workers : int
        Analysis processes in this server (0: none; a separate worker runs them).
    lease_s : float
        A running analysis whose worker has been silent this long is taken back [s].
    retry_backoff_s : float
        Wait before an analysis that failed for a passing reason is tried again, doubled after each
        attempt [s].
    key_ttl_s : float
        How long a key found in the store is trusted without asking again [s]: a revoked key is
        refused at most this long after (0: every request asks the store).
    calibrations : int
        Baselines calibrated at once (``POST /engines/{id}/baseline``; a fleet has one at a time, its
        next is refused with 429 meanwhile; another fleet's waits its turn).
    calibration_memory_bytes, calibration_timeout_s : int, float
        Limits of the calibrating child process (its request waits for it).
    session_s : float
        How long a browser's session lasts after its login (``POST /login``) [s].
    read_threads : int
        Threads that run the reads' queries at once on PostgreSQL (each holds a connection; more would
        only take turns at the interpreter's lock, fewer would leave the round trips unoverlapped). On
        SQLite a read's query runs on the event loop.
    alerts : DeliveryPolicy
        How the webhooks' events are posted and retried (:mod:`api.routes.webhooks`).
    """

    store_url: str
    data_dir: Path
    max_upload_bytes: int = 4 << 30
    validation_memory_bytes: int = 2 << 30
    validation_timeout_s: float = 120.0
    validations: int = 2
    validations_per_fleet: int = 1
    uploads_per_fleet: int = 4
    upload_idle_s: float = 30.0
    upload_min_rate: float = 1024.0
    max_expansion: float = MAX_EXPANSION
    workers: int = 1
    lease_s: float = 30.0
    retry_backoff_s: float = 10.0
    key_ttl_s: float = KEY_TTL_S
    calibrations: int = 1
    calibration_memory_bytes: int = 4 << 30
    calibration_timeout_s: float = 300.0
    session_s: float = SESSION_S
    read_threads: int = 8
    alerts: DeliveryPolicy = field(default_factory=DeliveryPolicy)
