"""URDF robots: files read into ``UrdfRobot`` (kinematics + visuals) and link meshes as GLB.

All file I/O for URDF robots lives here; the kinematics are ``server.kinematics.UrdfChain``.
"""

from .loader import load_urdf
from .meshes import convert_link, link_meshes, mesh_key
from .model import (
    BoxGeometry,
    CylinderGeometry,
    Geometry,
    MeshGeometry,
    SphereGeometry,
    UrdfError,
    UrdfRobot,
    Visual,
)

__all__ = [
    "BoxGeometry",
    "CylinderGeometry",
    "Geometry",
    "MeshGeometry",
    "SphereGeometry",
    "UrdfError",
    "UrdfRobot",
    "Visual",
    "convert_link",
    "link_meshes",
    "load_urdf",
    "mesh_key",
]
