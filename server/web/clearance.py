"""``POST /api/clearance``: a page with the Clearance toggle on asks for it (a lease of 10 s).

The result travels on the stream (the ``clearance`` message), to every viewer;
nobody asking, the server measures nothing.
"""

from __future__ import annotations

from fastapi import APIRouter, HTTPException, Request, Response

from ..clearance import ClearanceService

router = APIRouter()


@router.post("/api/clearance", status_code=204)
async def want_clearance(request: Request) -> Response:
    """Measure clearance for the next 10 s (the page repeats this while its toggle is on)."""
    service: ClearanceService | None = request.app.state.clearance
    if service is None:
        raise HTTPException(404, "clearance is off on this server (LINKVIEW_CLEARANCE_M=0)")
    service.want()
    return Response(status_code=204)
