"""An asyncua server holding OPC UA's address space and the DI, IA and Robotics companion models.

The models are the OPC Foundation's NodeSet2 files (``nodesets/``, vendored
unchanged), imported with asyncua's XML importer. Building the standard address
space and importing the three files costs seconds of pure Python; asyncua can
keep an address space in a shelf and load its nodes lazily, so the first server
built with a ``cache`` folder leaves one there (keyed by the files and asyncua's
version) and later ones start in a fraction of a second.
"""

from __future__ import annotations

import hashlib
import logging
import os
import shutil
import sys
import tempfile
from pathlib import Path

import asyncua
from asyncua.server.server import Server

NODESETS_DIR = Path(__file__).resolve().parent / "nodesets"
NODESETS = ("Opc.Ua.Di.NodeSet2.xml", "Opc.Ua.IA.NodeSet2.xml", "Opc.Ua.Robotics.NodeSet2.xml")
DI_URI = "http://opcfoundation.org/UA/DI/"
IA_URI = "http://opcfoundation.org/UA/IA/"
ROBOTICS_URI = "http://opcfoundation.org/UA/Robotics/"
COMPANIONS = (DI_URI, IA_URI, ROBOTICS_URI)
"""The namespaces the files add, in the order they are imported."""
SHELF = "aspace"

log = logging.getLogger(__name__)


def shelf_folder(cache: Path) -> Path:
    """Where the address space with the companion models is kept (one per files and asyncua)."""
    digest = hashlib.sha256(asyncua.__version__.encode() + sys.version.encode())
    for name in NODESETS:
        digest.update((NODESETS_DIR / name).read_bytes())
    return cache / "opcua" / f"address-space-{digest.hexdigest()[:16]}"


async def companion_server(cache: Path | None = None, robotics: bool = True) -> Server:
    """An initialised asyncua Server with the DI, IA and Robotics models (``robotics`` False: none).

    ``cache``: the folder a shelf of the address space is kept in (None: built every time).
    """
    server = Server()
    if not robotics:
        await server.init()
        return server
    folder = None if cache is None else shelf_folder(cache)
    if folder is not None and (folder / "complete").is_file():
        try:
            await server.init(folder / SHELF)
            for uri in COMPANIONS:  # the namespace array is not part of the shelf
                await server.register_namespace(uri)
            return server
        except Exception:  # a shelf that cannot be read: build the address space again
            log.warning("the cached OPC UA address space in %s is unreadable; rebuilt", folder)
            server = Server()
    await server.init()
    for name in NODESETS:
        await server.import_xml(str(NODESETS_DIR / name))
    if folder is not None:
        _keep(server, folder)
    return server


def _keep(server: Server, folder: Path) -> None:
    """Write the address space as a shelf into ``folder`` (built aside, then moved in whole)."""
    try:
        folder.parent.mkdir(parents=True, exist_ok=True)
        building = Path(tempfile.mkdtemp(prefix=".building-", dir=folder.parent))
    except OSError as exc:
        log.warning("cannot keep the OPC UA address space in %s: %s", folder, exc)
        return
    try:
        shelf = building / SHELF
        server.iserver.aspace.make_aspace_shelf(shelf)
        # asyncua opens a shelf whose name is a file; dbm.dumb writes only .dat and .dir files
        if not shelf.exists() and not shelf.with_suffix(".db").exists():
            shelf.touch()
        (building / "complete").touch()
        os.rename(building, folder)  # another process may have been quicker: then keep theirs
    except OSError:
        pass
    finally:
        shutil.rmtree(building, ignore_errors=True)
