"""URDF robots: files read into ``UrdfRobot`` (kinematics + visuals) and link meshes as GLB.

All file I/O for URDF robots lives here: ``loader`` reads a file (``_xacro`` has
xacro expanded by ``server.sandbox``'s worker process, ``_xml`` cleans and checks
the XML, ``_paths`` finds meshes), ``meshes`` converts each link's visuals to one
GLB. The kinematics are ``server.kinematics.urdf``.
"""

from .loader import load_urdf
from .meshes import LinkMeshes, convert_link, link_meshes, mesh_key
from .model import (
    BoxGeometry,
    CapsuleGeometry,
    CylinderGeometry,
    Geometry,
    MeshGeometry,
    SphereGeometry,
    StandInGeometry,
    UrdfError,
    UrdfRobot,
    Visual,
)

__all__ = [
    "BoxGeometry",
    "CapsuleGeometry",
    "CylinderGeometry",
    "Geometry",
    "MeshGeometry",
    "LinkMeshes",
    "SphereGeometry",
    "StandInGeometry",
    "UrdfError",
    "UrdfRobot",
    "Visual",
    "convert_link",
    "link_meshes",
    "load_urdf",
    "mesh_key",
]
