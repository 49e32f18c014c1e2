"""Engine descriptions: ``GET /engines`` lists the ids a fleet's recordings may name (its own and the
bundled engines, :mod:`api.engines`), ``POST /engines`` adds the fleet's own, ``GET, PUT
/engines/{engine_id}`` read and replace one (a bundled engine is read-only).

A description is validated as an engine file is: one that breaks the format answers 422
``invalid_engine`` with the product's message (:data:`api.errors.PRODUCT_ERRORS`).
"""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, Query

from api.auth import Fleet
from api.dependencies import ServiceStore
from api.engines import Source, visible_engine
from api.errors import ApiError
from api.schemas import ERRORS, EngineId, EngineIn, EngineOut
from monitor.model.engine import bundled_engines, parse_engine

__all__ = ["router"]

router = APIRouter(tags=["engines"])


def _checked_engine(engine_id: str, description: dict[str, Any]) -> dict[str, Any]:
    """The description, if it is a valid engine of this id (an EngineDescriptionError otherwise)."""
    engine = parse_engine(description, origin="engine")
    if len(engine.id) > 200:
        raise ApiError(422, "invalid_engine", f"id: at most 200 characters, got {len(engine.id)}")
    if engine.id != engine_id:
        raise ApiError(
            422, "invalid_engine", f"the description's id is {engine.id!r}, the path's {engine_id!r}"
        )
    return description


@router.get("/engines", response_model=list[str], responses=ERRORS)
def list_engines(
    fleet_id: Fleet,
    store: ServiceStore,
    source: Annotated[
        Source | None,
        Query(description="only the fleet's own descriptions, or only the bundled engines"),
    ] = None,
) -> list[str]:
    """The ids of the engines the fleet's recordings may name, sorted: the fleet's own descriptions and
    the bundled engines (an id in both once; GET /engines/{engine_id} says which it is)."""
    own = store.engines(fleet_id) if source != "bundled" else []
    bundled = list(bundled_engines()) if source != "fleet" else []
    return sorted(set(own) | set(bundled))


@router.post("/engines", status_code=201, response_model=EngineOut, responses=ERRORS)
def create_engine(fleet_id: Fleet, body: EngineIn, store: ServiceStore) -> dict[str, Any]:
    """Add an engine description (validated as an engine file is)."""
    engine_id = str(body.description.get("id", ""))
    description = _checked_engine(engine_id, body.description)
    if store.engine(fleet_id, engine_id) is not None:
        raise ApiError(
            409, "exists", f"engine {engine_id!r} exists already: PUT /engines/{engine_id} replaces it"
        )
    store.put_engine(fleet_id, engine_id, description)
    return {"engine_id": engine_id, "description": description, "source": "fleet"}


@router.get("/engines/{engine_id}", response_model=EngineOut, responses=ERRORS)
def get_engine(fleet_id: Fleet, engine_id: EngineId, store: ServiceStore) -> dict[str, Any]:
    """An engine's description: the fleet's own, else the bundled one (``source`` says which)."""
    found = visible_engine(store, fleet_id, engine_id)
    if found is None:
        raise ApiError(404, "not_found", f"no engine {engine_id!r}")
    return {"engine_id": engine_id, "description": found[0], "source": found[1]}


@router.put("/engines/{engine_id}", response_model=EngineOut, responses=ERRORS)
def put_engine(fleet_id: Fleet, engine_id: EngineId, body: EngineIn, store: ServiceStore) -> dict[str, Any]:
    """Replace an engine description (later analyses use it)."""
    if store.engine(fleet_id, engine_id) is None:
        read_only = " (a bundled engine is read-only: POST /engines adds the fleet's own)"
        hint = read_only if engine_id in bundled_engines() else ""
        raise ApiError(404, "not_found", f"no engine {engine_id!r} among the fleet's own{hint}")
    store.put_engine(fleet_id, engine_id, _checked_engine(engine_id, body.description))
    return {"engine_id": engine_id, "description": body.description, "source": "fleet"}
