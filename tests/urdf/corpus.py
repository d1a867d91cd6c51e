"""Robot descriptions published by their makers or by well-known robotics projects.

None is copied into this repository: each is read where its PyPI package
installed it (the test extras install pybullet, airo-models, rtb-data and
example-robot-data, the last as data files of its wheel, not a module), as
a user would copy a vendor's description package, and loaded without edits.
``packages`` is only given where the package renamed a ROS package's folder
(rtb-data ships ROS-Industrial's ``kuka_kr6_support`` as ``kuka_kr6``); every
other ``package://`` and ``$(find)`` is found by linkview's own search.

``tests/urdf/test_corpus.py`` checks every robot; ``bench/urdf.py`` times them.
"""

from __future__ import annotations

import importlib.metadata
import importlib.util
from dataclasses import dataclass, field
from pathlib import Path

DATA = {"example-robot-data": "cmeel.prefix/share/example-robot-data/robots"}
"""Distributions whose descriptions are data files of the wheel: where they land."""


def installed(module: str) -> Path:
    """The folder a PyPI package's top-level module (or data, ``DATA``) was installed in."""
    if module in DATA:
        return Path(str(importlib.metadata.distribution(module).locate_file(DATA[module])))
    spec = importlib.util.find_spec(module)
    assert spec is not None and spec.submodule_search_locations, f"{module} is not installed"
    return Path(next(iter(spec.submodule_search_locations)))


@dataclass(frozen=True)
class Described:
    """One published robot description and where its PyPI package keeps it."""

    name: str
    title: str
    """Who made the robot, and who published this description."""
    module: str
    """The installed module holding the files (``pybullet_data``, ``airo_models``, ``rtbdata``)."""
    file: str
    """The URDF or xacro file, relative to the module's folder."""
    packages: dict[str, str] = field(default_factory=dict)
    """ROS package -> folder relative to the module's folder, where the search cannot know."""
    args: dict[str, str] = field(default_factory=dict)
    """xacro arguments."""
    features: tuple[str, ...] = ()

    @property
    def path(self) -> Path:
        """The description file."""
        return installed(self.module) / self.file

    @property
    def package_folders(self) -> dict[str, Path]:
        """``packages`` as absolute folders."""
        root = installed(self.module)
        return {name: root / folder for name, folder in self.packages.items()}


KUKA = "xacro/kuka_description"
CORPUS: tuple[Described, ...] = (
    # pybullet (pybullet_data): Bullet's robot models.
    Described("kuka_iiwa", "KUKA LBR iiwa 14 R820, from pybullet", "pybullet_data",
              "kuka_iiwa/model.urdf", features=("7-axis", "obj")),
    Described("franka_panda", "Franka Emika Panda with hand, from pybullet", "pybullet_data",
              "franka_panda/panda.urdf", features=("7-axis", "mimic", "obj", "package-by-folder")),
    Described("xarm6_gripper", "UFACTORY xArm 6 with gripper, from pybullet", "pybullet_data",
              "xarm/xarm6_with_gripper.urdf", features=("6-axis", "mimic", "stl")),
    Described("laikago", "Unitree Laikago quadruped, from pybullet", "pybullet_data",
              "laikago/laikago_toes_zup.urdf", features=("legged", "floating base", "obj")),
    Described("a1", "Unitree A1 quadruped, from pybullet", "pybullet_data", "a1/a1.urdf",
              features=("legged", "floating base", "obj")),
    Described("aliengo", "Unitree Aliengo quadruped, from pybullet", "pybullet_data",
              "aliengo/aliengo.urdf", features=("legged", "floating base", "obj")),
    Described("mini_cheetah", "MIT Mini Cheetah quadruped, from pybullet", "pybullet_data",
              "mini_cheetah/mini_cheetah.urdf", features=("legged", "floating base", "obj")),
    Described("husky", "Clearpath Husky, from pybullet", "pybullet_data", "husky/husky.urdf",
              features=("mobile", "floating base", "substitution args in a .urdf")),
    Described("racecar", "MIT RACECAR, from pybullet", "pybullet_data", "racecar/racecar.urdf",
              features=("mobile", "floating base", "material inside geometry")),
    # airo-models: Ghent University AIRO lab's curated robot descriptions.
    Described("ur5e", "Universal Robots UR5e, from airo-models", "airo_models",
              "arms/ur5e/ur5e.urdf", features=("6-axis", "transmission", "drake: attributes")),
    Described("ur3e", "Universal Robots UR3e, from airo-models", "airo_models",
              "arms/ur3e/ur3e.urdf", features=("6-axis", "transmission")),
    Described("robotiq_2f_85", "Robotiq 2F-85 gripper, from airo-models", "airo_models",
              "grippers/robotiq_2f_85/urdf/robotiq_2f_85.urdf", features=("mimic", "stl")),
    Described("schunk_egk40", "Schunk EGK 40 gripper, from airo-models", "airo_models",
              "grippers/schunk_egk40/urdf/schunk_egk40.urdf", features=("prismatic",)),
    # rtb-data: the Robotics Toolbox's copies of ROS-Industrial, Franka and vendor packages.
    Described("kuka_kr6", "KUKA KR 6 R700 sixx, ROS-Industrial kuka_experimental (rtb-data)",
              "rtbdata", f"{KUKA}/kuka_kr6/urdf/kr6r700sixx.xacro",
              packages={"kuka_kr6_support": f"{KUKA}/kuka_kr6",
                        "kuka_resources": f"{KUKA}/kuka_resources"},
              features=("6-axis", "industrial", "dae", "xacro")),
    Described("kuka_kr210", "KUKA KR 210 L150, ROS-Industrial kuka_experimental (rtb-data)",
              "rtbdata", f"{KUKA}/kuka_kr210/urdf/kr210l150.urdf",
              packages={"kuka_kr210_support": f"{KUKA}/kuka_kr210"},
              features=("6-axis", "industrial", "dae")),
    Described("kuka_iiwa14_ros", "KUKA LBR iiwa 14 R820, ROS-Industrial (rtb-data)", "rtbdata",
              f"{KUKA}/kuka_lbr_iiwa/urdf/lbr_iiwa_14_r820.urdf",
              packages={"kuka_lbr_iiwa_support": f"{KUKA}/kuka_lbr_iiwa"},
              features=("7-axis", "dae")),
    Described("panda_xacro", "Franka Emika Panda with hand, QUT's franka_description (rtb-data)",
              "rtbdata", "xacro/qut_frankie_description/robots/panda_arm_hand.urdf.xacro",
              features=("7-axis", "mimic", "dae", "xacro", "find-by-folder")),
    Described("px100", "Trossen Interbotix PincherX 100, from rtb-data", "rtbdata",
              "xacro/trossen_descriptions/urdf/px100.urdf.xacro", args={"robot_name": "px100"},
              features=("mimic", "xacro", "args")),
    Described("puma560", "Unimation PUMA 560, from rtb-data", "rtbdata",
              "xacro/unimation_puma560_description/urdf/puma560_robot.urdf.xacro",
              features=("6-axis", "xacro")),
    Described("ridgeback", "Clearpath Ridgeback, from rtb-data", "rtbdata",
              "xacro/clearpath_ridgeback_description/urdf/ridgeback.urdf.xacro",
              features=("mobile", "xacro", "find-by-package.xml")),
    # example-robot-data: the Gepetto team's (LAAS-CNRS) collection, used with pinocchio.
    Described("tiago_dual", "PAL Robotics TIAGo++ dual-arm mobile manipulator, example-robot-data",
              "example-robot-data", "tiago_description/robots/tiago_dual.urdf",
              features=("mobile", "dual-arm", "more than 60 joints", "mimic", "stl", "dae")),
    Described("tiago", "PAL Robotics TIAGo mobile manipulator (example-robot-data)",
              "example-robot-data", "tiago_description/robots/tiago.urdf",
              features=("mobile", "more than 32 joints", "stl", "dae")),
    Described("g1_hands", "Unitree G1 humanoid, 29 DoF with hands (example-robot-data)",
              "example-robot-data", "g1_description/urdf/g1_29dof_with_hand_rev_1_0.urdf",
              features=("humanoid", "more than 32 joints", "floating base", "stl")),
)  # fmt: skip


def tree_urdf(links: int, movable: int, name: str = "l", chain: bool = False) -> str:
    """A binary tree (``chain``: a chain) of ``links`` box links; the first ``movable``
    joints revolute, each link 10 mm above its parent."""
    out = ['<robot name="big">', f'<link name="{name}0"/>']
    for i in range(1, links):
        kind = "revolute" if i <= movable else "fixed"
        out.append(
            f'<link name="{name}{i}"><visual><geometry><box size="0.01 0.01 0.01"/>'
            f'</geometry></visual></link><joint name="j{i}" type="{kind}">'
            f'<parent link="{name}{i - 1 if chain else (i - 1) // 2}"/><child link="{name}{i}"/>'
            '<origin xyz="0 0 0.01"/><axis xyz="0 0 1"/>'
            '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
        )
    return "\n".join([*out, "</robot>"])
