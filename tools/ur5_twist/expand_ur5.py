#!/usr/bin/env python3
"""Expand the public UR5 xacro of ros-industrial/universal_robot into a URDF.

    python expand_ur5.py --universal-robot PATH/TO/universal_robot --out ur5.urdf

PATH is a checkout of https://github.com/ros-industrial/universal_robot
(package `ur_description`, BSD licence; its meshes are not needed and not
read). The file is expanded with the `xacro` package from PyPI (no ROS
needed): `$(find ur_description)` is replaced by the checkout's path in a
temporary copy of `urdf/` and `config/`.

One fixed link is appended: `target`, a tracker target on the tool, 100 mm
out along `tool0`'s z (the flange normal) and 30 mm off joint 6's axis along
`tool0`'s x, so that joint 6 moves it. That link is the chain's tip for the
measurements (`--tip-link target`). Nothing else is changed; the URDF is not
committed (see README.md).
"""

import argparse
import pathlib
import shutil
import subprocess
import sys
import tempfile

TARGET_XYZ = (0.03, 0.0, 0.10)  # metres, in tool0

TARGET_LINK = """
  <!-- appended by lrmcal tools/ur5_twist/expand_ur5.py: the tracker target -->
  <link name="target"/>
  <joint name="tool0-target" type="fixed">
    <parent link="tool0"/>
    <child link="target"/>
    <origin xyz="{x} {y} {z}" rpy="0 0 0"/>
  </joint>
</robot>
"""


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--universal-robot", required=True, type=pathlib.Path,
                    help="checkout of ros-industrial/universal_robot (or its ur_description folder)")
    ap.add_argument("--out", required=True, type=pathlib.Path)
    args = ap.parse_args()

    src = args.universal_robot
    if (src / "ur_description").is_dir():
        src = src / "ur_description"
    if not (src / "urdf" / "ur5.xacro").is_file():
        sys.exit(f"{src}: no urdf/ur5.xacro (not ur_description?)")

    with tempfile.TemporaryDirectory() as tmp:
        pkg = pathlib.Path(tmp) / "ur_description"
        for sub in ("urdf", "config"):
            shutil.copytree(src / sub, pkg / sub)
        for f in list(pkg.rglob("*.xacro")):
            text = f.read_text()
            f.write_text(text.replace("$(find ur_description)", str(pkg)))
        xacro = shutil.which("xacro") or str(pathlib.Path(sys.executable).parent / "xacro")
        urdf = subprocess.run([xacro, str(pkg / "urdf" / "ur5.xacro")],
                              check=True, capture_output=True, text=True).stdout

    tail = urdf.rstrip().rfind("</robot>")
    if tail < 0:
        sys.exit("xacro output has no </robot>")
    x, y, z = TARGET_XYZ
    urdf = urdf[:tail] + TARGET_LINK.format(x=x, y=y, z=z).lstrip("\n")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(urdf)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
