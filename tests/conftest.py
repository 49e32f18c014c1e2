"""Shared test configuration: strict floating point, seeded randomness, paths."""

from __future__ import annotations

import os
import uuid
import zlib
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any, NoReturn

import numpy as np
import pytest
from hypothesis import settings

ROOT = Path(__file__).resolve().parents[1]
ENGINES = ROOT / "recordings" / "engines"
SHARED = ROOT.parent / "shared"

settings.register_profile("default", deadline=None, max_examples=200)
settings.load_profile("default")


@pytest.fixture(autouse=True)
def _strict_floating_point() -> Iterator[None]:
    """Overflow, division by zero and invalid operations raise instead of warning."""
    with np.errstate(over="raise", divide="raise", invalid="raise", under="ignore"):
        yield


@pytest.fixture
def rng(request: pytest.FixtureRequest) -> np.random.Generator:
    """A generator seeded from the test's name: reproducible, independent per test."""
    seed = zlib.crc32(request.node.nodeid.encode())
    return np.random.default_rng(seed)


def unavailable(reason: str) -> NoReturn:
    """Skip a test whose service or program is missing here, saying why; under CI (``.ci/run`` sets CI),
    where ``make test`` provides them all, fail instead: a test that cannot run there is a broken test."""
    if os.environ.get("CI"):
        pytest.fail(f"{reason} (CI is set: make test provides it)", pytrace=False)
    pytest.skip(reason)


def shared_path(*parts: str) -> Path:
    """Path under ../shared, or skip the test when the folder is absent (a user's clone)."""
    path = SHARED.joinpath(*parts)
    if not path.exists():
        pytest.skip(f"{path.relative_to(ROOT.parent)} is absent: third-party test data not available")
    return path


# ------------------------------------------------------------------------------------------ stores
# The PostgreSQL server on loopback (ENGINE_MONITOR_TEST_POSTGRES overrides the URL); each use gets a
# database of its own, dropped afterwards; where no server answers, the PostgreSQL cases skip and say so
# (and fail under CI).
ADMIN_URL = os.environ.get(
    "ENGINE_MONITOR_TEST_POSTGRES", "postgresql+psycopg://postgres@127.0.0.1:5432/postgres"
)


@contextmanager
def postgres_database() -> Iterator[str]:
    """The URL of a new, empty PostgreSQL database; skips the test if no server answers (fails under CI)."""
    import sqlalchemy as sa

    admin = sa.create_engine(ADMIN_URL, isolation_level="AUTOCOMMIT")
    name = f"engine_monitor_test_{uuid.uuid4().hex[:12]}"
    try:
        with admin.connect() as c:
            c.execute(sa.text(f'CREATE DATABASE "{name}"'))
    except sa.exc.OperationalError as error:
        admin.dispose()
        unavailable(
            f"no PostgreSQL server answers at {admin.url.render_as_string(hide_password=True)}: {error.orig}"
        )
    try:
        yield admin.url.set(database=name).render_as_string(hide_password=False)
    finally:
        with admin.connect() as c:
            c.execute(sa.text(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)'))
        admin.dispose()


@pytest.fixture(params=["sqlite", "postgresql"])
def store_url(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[str]:
    """A store URL: an SQLite file, then a fresh PostgreSQL database (skipped where no server answers)."""
    if request.param == "sqlite":
        yield f"sqlite:///{tmp_path / 'store.db'}"
    else:
        with postgres_database() as url:
            yield url


@pytest.fixture(scope="session")
def browser() -> Iterator[Any]:
    """A headless Chromium driven by selenium (Debian's chromium and chromium-driver, ``make browser``);
    the tests that use it skip, saying why, where none can be started (fail under CI)."""
    import shutil

    driver_path = shutil.which("chromedriver")
    binary = shutil.which("chromium") or shutil.which("chromium-browser")
    if driver_path is None or binary is None:
        unavailable("no chromium and chromedriver here ('make browser' installs them where root apt-get can)")
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = binary
    for argument in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage"):
        options.add_argument(argument)
    options.add_argument("--window-size=1280,1400")
    try:
        driver = webdriver.Chrome(service=Service(driver_path), options=options)
    except Exception as error:  # a browser that is there but cannot start: say so
        unavailable(f"chromium could not be started: {error}")
    try:
        yield driver
    finally:
        driver.quit()
