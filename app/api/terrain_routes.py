"""The /api/terrains routes: the terrain files (the user's over the shipped ones): list, read, save."""

# No `from __future__ import annotations`: FastAPI must see the body models themselves (some are built at run
# time, from the registry), not their names.
import asyncio
from typing import Annotated, Any

from fastapi import FastAPI, Query, Request
from fastapi import Path as PathParam

from app.api.errors import STORAGE_CODES, ErrorCodes, as_http_errors, responses
from app.api.models import (
    Saved,
    TerrainEntry,
    TerrainList,
)
from app.live.editor import MAX_UPLOAD_BYTES

TERRAIN_NAME = r"^[A-Za-z0-9][A-Za-z0-9_-]{0,63}$"
TerrainName = Annotated[str, PathParam(pattern=TERRAIN_NAME, description="a terrain file's stem")]


def add_terrain_routes(api: FastAPI, app, codes: ErrorCodes) -> None:  # noqa: ANN001 - a ContactnetApp
    """Add the terrain-file routes of `app` (a ContactnetApp: its `terrains` service) to `api`."""
    everywhere, changing = codes.everywhere, codes.changing

    # ---- terrains ---------------------------------------------------------------------------------
    @api.get("/api/terrains", response_model=TerrainList, tags=["terrains"], responses=responses(*everywhere))
    def list_terrains() -> TerrainList:
        store = app.terrains.store
        return TerrainList(
            terrains=[
                TerrainEntry(name=n, shipped=store.is_shipped(n), url=f"/api/terrains/{n}") for n in store.names()
            ],
            current=app.terrains.label,
        )

    @api.get("/api/terrains/{name}", tags=["terrains"], responses=responses(*everywhere, 404, 409, 422))
    def get_terrain(name: TerrainName) -> dict[str, Any]:
        """The terrain file (the "Terrain file" format of docs/architecture.md): the user's own file of that
        name, else the shipped one. 409 when that file is not a valid terrain (fix or replace it)."""
        with as_http_errors():
            return app.terrains.store.load(name).to_dict()

    @api.put(
        "/api/terrains/{name}",
        response_model=Saved,
        tags=["terrains"],
        responses=responses(*changing, 409, 422, *STORAGE_CODES),
        openapi_extra={
            "requestBody": {
                "required": True,
                "content": {
                    "application/json": {
                        "schema": {
                            "type": "object",
                            "description": "a terrain (docs/architecture.md 'Terrain file'); at most "
                            f"{MAX_UPLOAD_BYTES} bytes",
                            "required": ["name", "start", "goal_x", "regions"],
                        }
                    }
                },
            }
        },
    )
    async def put_terrain(
        name: TerrainName,
        request: Request,
        overwrite: Annotated[
            bool, Query(description="confirm saving your own copy under the name of a shipped terrain")
        ] = False,
    ) -> Saved:
        """Save a terrain as the user's file `name` (validated once, off the event loop; nothing is written if
        it is invalid). The shipped terrains are never changed: under a shipped name (confirmed with
        ``overwrite``) the user's own copy is saved, and shadows the shipped file. The answer's ``path`` is the
        file's name in the user's terrain folder. A file that cannot be written is 500 (507: the disk is full)
        with one line saying why."""
        body = await request.body()  # at most MAX_UPLOAD_BYTES: RequestGuard refuses more while streaming
        job = app.validation_pool.submit(app.terrains.save_upload, body, name, overwrite)
        with as_http_errors():
            path = await asyncio.wrap_future(job)
        return Saved(name=name, path=path.name)  # never the machine's folders

