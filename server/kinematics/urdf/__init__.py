"""URDF kinematics: a joint tree (``description``) checked and flattened (``_tree``),
compiled to column operations (``_program``), run by one kernel per batch size
(``_kernels``), behind ``UrdfChain`` (``chain``). Modules import in that order.

Reading URDF files and their meshes is ``server.urdf``'s job; this package is pure numpy.
"""

from .chain import UrdfChain
from .description import JointType, UrdfJoint, UrdfMimic, UrdfTree

__all__ = ["JointType", "UrdfChain", "UrdfJoint", "UrdfMimic", "UrdfTree"]
