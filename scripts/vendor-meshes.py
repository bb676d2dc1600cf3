#!/usr/bin/env python3
"""Vendors the official meshes of the built-in robots for the studio's 3D view.

Reads each robot's meshes from a checkout of its source repository (see
docs/meshes.md for the repositories, commits and licences), decimates them with
fast-simplification (quadric edge collapse) and writes, per robot, binary STL
files in metres and parts.json: which mesh goes on which joint's moving frame
(null: the base), where (pos, quat w x y z, in that frame) and in what colour.
The placements are the source files' own (MJCF geom pos/quat, URDF visual
origins), on link frames that are keypose's joint frames (tests check it).

Usage: scripts/vendor-meshes.py SO-ARM100 open_manipulator koch-v1-1
  (the three checkouts; needs numpy and fast-simplification, a developer's tool,
  not a dependency of keypose)
"""
import json
import os
import struct
import subprocess
import sys
import xml.etree.ElementTree as ET

import fast_simplification
import numpy as np

OUT = os.path.join(os.path.dirname(__file__), "..", "src", "studio", "web", "meshes")
# At most this many triangles per mesh: about 50 bytes each.
MAX_FACES = 700
# The grid vertices are snapped to before that, metres.
CLUSTER = 0.0005
MAX_CLUSTER = 0.002
PRINTED = {"so": [1.0, 0.82, 0.12, 1.0], "koch": [0.85, 0.85, 0.85, 1.0], "omx": [0.78, 0.8, 0.82, 1.0]}
SERVO = [0.12, 0.12, 0.12, 1.0]


def git_show(repo, path):
    return subprocess.run(["git", "-C", repo, "show", f"HEAD:{path}"], check=True, capture_output=True).stdout


def read_stl(data):
    if data[:5] == b"solid" and b"facet" in data[:400]:
        v = [list(map(float, l.split()[1:4])) for l in data.decode().splitlines() if l.strip().startswith("vertex")]
        return np.array(v).reshape(-1, 3, 3)
    n = struct.unpack("<I", data[80:84])[0]
    rec = np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")])
    return np.frombuffer(data[84:84 + 50 * n], dtype=rec)["v"].astype(float)


def decimate(tris, cluster=CLUSTER):
    """Vertices snapped to a grid first (the CAD exports have slivers that quadric collapse
    alone will not touch), degenerate and repeated triangles dropped, then quadric edge
    collapse down to MAX_FACES; a mesh that stays far above it is snapped again, coarser."""
    snapped = np.round(tris.reshape(-1, 3) / cluster)
    points, faces = np.unique(snapped, axis=0, return_inverse=True)
    faces = faces.reshape(-1, 3)
    faces = faces[(faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & (faces[:, 0] != faces[:, 2])]
    _, first = np.unique(np.sort(faces, axis=1), axis=0, return_index=True)
    faces = faces[np.sort(first)]
    points = points * cluster
    if len(faces) > MAX_FACES:
        points, faces = fast_simplification.simplify(points, faces, target_count=MAX_FACES)
    if len(faces) > 1.5 * MAX_FACES and cluster < MAX_CLUSTER:
        return decimate(points[faces], 2 * cluster)
    return points[faces]


def write_stl(path, tris, source):
    normals = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    length = np.linalg.norm(normals, axis=1, keepdims=True)
    normals = np.divide(normals, length, out=np.zeros_like(normals), where=length > 0)
    header = f"keypose: decimated from {source}".encode()[:80].ljust(80, b" ")
    rec = np.zeros(len(tris), dtype=np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")]))
    rec["n"] = normals
    rec["v"] = tris
    with open(path, "wb") as f:
        f.write(header + struct.pack("<I", len(tris)) + rec.tobytes())


def vendor(robot, repo, parts, licence):
    """parts: (source path, file name, joint or None, pos, quat wxyz, rgba, scale)."""
    folder = os.path.join(OUT, robot)
    os.makedirs(folder, exist_ok=True)
    commit = subprocess.run(["git", "-C", repo, "rev-parse", "HEAD"], check=True, capture_output=True, text=True).stdout.strip()
    written = {}
    manifest = []
    for source, name, joint, pos, quat, rgba, scale in parts:
        if name not in written:
            tris = decimate(read_stl(git_show(repo, source)) * scale)
            write_stl(os.path.join(folder, name), tris, source)
            written[name] = len(tris)
        manifest.append({"mesh": name, "joint": joint, "pos": pos, "quat": quat, "rgba": rgba})
    with open(os.path.join(folder, "LICENSE"), "wb") as f:
        f.write(git_show(repo, licence))
    with open(os.path.join(folder, "parts.json"), "w") as f:
        rows = ",\n".join("  " + json.dumps(p) for p in manifest)
        f.write(f'{{"commit": "{commit}",\n "parts": [\n{rows}\n ]}}\n')
    print(robot, commit, written)


def numbers(text):
    return [float(x) for x in text.split()]


def so101(repo):
    """The official MJCF: every visual mesh geom, on its body's joint."""
    root = ET.fromstring(git_show(repo, "Simulation/SO101/so101_new_calib.xml"))
    colours = {m.get("name"): numbers(m.get("rgba")) for m in root.iter("material")}
    parts = []

    def walk(body, joint):
        j = body.find("joint")
        joint = j.get("name") if j is not None else joint
        for g in body.findall("geom"):
            if g.get("class") != "visual":
                continue
            mesh = g.get("mesh")
            rgba = SERVO if mesh.startswith("sts3215") else PRINTED["so"]
            assert colours[g.get("material")][:3] == ([0.1] * 3 if rgba is SERVO else PRINTED["so"][:3])
            parts.append((f"Simulation/SO101/assets/{mesh}.stl", f"{mesh}.stl", joint,
                          numbers(g.get("pos")), numbers(g.get("quat")), rgba, 1.0))
        for child in body.findall("body"):
            walk(child, joint)

    for body in root.find("worldbody").findall("body"):
        walk(body, None)
    return parts


def so100():
    """The official URDF: each link's visuals at the link frame (no visual origin)."""
    links = {"base": None, "shoulder": "shoulder_pan", "upper_arm": "shoulder_lift",
             "lower_arm": "elbow_flex", "wrist": "wrist_flex", "gripper": "wrist_roll", "jaw": "gripper"}
    meshes = {"base": ["Base", "Base_Motor"], "shoulder": ["Rotation_Pitch", "Rotation_Pitch_Motor"],
              "upper_arm": ["Upper_Arm", "Upper_Arm_Motor"], "lower_arm": ["Lower_Arm", "Lower_Arm_Motor"],
              "wrist": ["Wrist_Pitch_Roll", "Wrist_Pitch_Roll_Motor"], "gripper": ["Fixed_Jaw", "Fixed_Jaw_Motor"],
              "jaw": ["Moving_Jaw"]}
    return [(f"Simulation/SO100/assets/{m}.stl", f"{m}.stl", links[link], [0, 0, 0], [1, 0, 0, 0],
             SERVO if m.endswith("_Motor") else PRINTED["so"], 1.0)
            for link, names in meshes.items() for m in names]


def koch():
    """simulation/follower.urdf: each link's visuals at the link frame (origin 0 0 0)."""
    links = [("base_link", None), ("link_1", "shoulder_pan"), ("link_2", "shoulder_lift"),
             ("link_3", "elbow_flex"), ("link_4", "wrist_flex"), ("link_5", "wrist_roll"), ("link_6", "gripper")]
    parts = []
    for link, joint in links:
        parts.append((f"simulation/meshes/{link}.STL", f"{link}.stl", joint, [0, 0, 0], [1, 0, 0, 0], PRINTED["koch"], 1.0))
        if link != "link_6":
            parts.append((f"simulation/meshes/{link}_motor.STL", f"{link}_motor.stl", joint, [0, 0, 0], [1, 0, 0, 0], SERVO, 1.0))
    return parts


def omx():
    """open_manipulator_x_arm.urdf.xacro: millimetre meshes at their link frames; link2's 19 mm
    up. link1 (the base) sits on the desk: keypose's base is the MJCF's, 17 mm below the ROS 2
    URDF's link1 frame (docs/robots.md §3), i.e. where the ROS 1 URDF had link1."""
    base = "open_manipulator_description/meshes/open_manipulator_x"
    rows = [("link1", None, [0, 0, 0]), ("link2", "joint1", [0, 0, 0.019]), ("link3", "joint2", [0, 0, 0]),
            ("link4", "joint3", [0, 0, 0]), ("link5", "joint4", [0, 0, 0]),
            ("gripper_left_palm", "gripper_left_joint", [0, 0, 0]),
            ("gripper_right_palm", "gripper_right_joint", [0, 0, 0])]
    return [(f"{base}/{m}.stl", f"{m}.stl", joint, pos, [1, 0, 0, 0], PRINTED["omx"], 0.001) for m, joint, pos in rows]


def main():
    so_arm, open_manipulator, koch_repo = sys.argv[1:4]
    vendor("so101", so_arm, so101(so_arm), "LICENSE")
    vendor("so100", so_arm, so100(), "LICENSE")
    vendor("koch", koch_repo, koch(), "LICENSE")
    vendor("omx", open_manipulator, omx(), "LICENSE")


if __name__ == "__main__":
    main()
