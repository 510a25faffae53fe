#!/usr/bin/env python3
"""Writes data/demo-multiframe/val/s00004 — the Multi Frame track's demo scene — from the TUM RGB-D fr2/desk frames in
../shared/data/tum_fr2_desk_seq (CC BY 4.0; see data/demo-multiframe/README.md). Run once by the maintainers; the
scene is committed, so neither a build nor a test runs this.

The scene: the first of the 20 frames is the reference (seq0), the other 19 are the query scan (seq1, frame_00000 …
frame_00018), so linear position 9 (frame_00009) is the one evaluated frame, with its window frame_00001 …
frame_00009. poses.txt is the motion-capture ground truth interpolated at each photo's timestamp (lerp + slerp),
world-to-camera with the reference camera as the world, as the benchmark writes it. poses_device.txt holds the
window's tracking poses in the track's documented convention (frame_from_query), taken from the same ground truth —
a drift-free tracker, which a phone is not. Photos are re-encoded as JPEG (quality 95), as the benchmark ships them.

    /usr/bin/python3 scripts/make-multiframe-demo.py [--source ../shared/data/tum_fr2_desk_seq]
"""

import argparse
import os

import numpy as np
from PIL import Image

K = (520.908620, 521.007327, 325.141442, 249.701764)


def quat_to_mat(x, y, z, w):
    n = np.sqrt(x * x + y * y + z * z + w * w)
    x, y, z, w = x / n, y / n, z / n, w / n
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def mat_to_quat_wxyz(R):
    w = np.sqrt(max(0.0, 1 + R[0, 0] + R[1, 1] + R[2, 2])) / 2
    x = np.sqrt(max(0.0, 1 + R[0, 0] - R[1, 1] - R[2, 2])) / 2
    y = np.sqrt(max(0.0, 1 - R[0, 0] + R[1, 1] - R[2, 2])) / 2
    z = np.sqrt(max(0.0, 1 - R[0, 0] - R[1, 1] + R[2, 2])) / 2
    x = np.copysign(x, R[2, 1] - R[1, 2])
    y = np.copysign(y, R[0, 2] - R[2, 0])
    z = np.copysign(z, R[1, 0] - R[0, 1])
    q = np.array([w, x, y, z])
    return q / np.linalg.norm(q)


def slerp(q0, q1, a):
    d = float(np.dot(q0, q1))
    if d < 0:
        q1, d = -q1, -d
    if d > 0.9995:
        q = q0 + a * (q1 - q0)
        return q / np.linalg.norm(q)
    th = np.arccos(d)
    return (np.sin((1 - a) * th) * q0 + np.sin(a * th) * q1) / np.sin(th)


def world_from_camera(gt, t):
    """The 4x4 T_w_c at time t (TUM lines: timestamp tx ty tz qx qy qz qw)."""
    i = np.searchsorted(gt[:, 0], t)
    a = (t - gt[i - 1, 0]) / (gt[i, 0] - gt[i - 1, 0])
    p = (1 - a) * gt[i - 1, 1:4] + a * gt[i, 1:4]
    q = slerp(gt[i - 1, 4:8], gt[i, 4:8], a)  # x y z w
    T = np.eye(4)
    T[:3, :3] = quat_to_mat(*q)
    T[:3, 3] = p
    return T


def line(name, T):
    q = mat_to_quat_wxyz(T[:3, :3])
    return name + " " + " ".join(f"{v:.16f}" for v in (*q, *T[:3, 3]))


def main():
    ap = argparse.ArgumentParser()
    here = os.path.dirname(os.path.abspath(__file__))
    ap.add_argument("--source", default=os.path.join(here, "..", "..", "shared", "data", "tum_fr2_desk_seq"))
    ap.add_argument("--out", default=os.path.join(here, "..", "data", "demo-multiframe", "val", "s00004"))
    a = ap.parse_args()
    gt = np.loadtxt(os.path.join(a.source, "rgbd_dataset_freiburg2_desk-groundtruth.txt"), comments="#")
    stamps = sorted(f[:-4] for f in os.listdir(os.path.join(a.source, "rgb")) if f.endswith(".png"))
    assert len(stamps) == 20, stamps
    names = ["seq0/frame_00000.jpg"] + [f"seq1/frame_{i:05d}.jpg" for i in range(len(stamps) - 1)]
    for d in ("seq0", "seq1"):
        os.makedirs(os.path.join(a.out, d), exist_ok=True)
    poses = {n: world_from_camera(gt, float(s)) for n, s in zip(names, stamps)}
    ref = poses[names[0]]
    for n, s in zip(names, stamps):
        Image.open(os.path.join(a.source, "rgb", s + ".png")).convert("RGB").save(os.path.join(a.out, n), quality=95)
    with open(os.path.join(a.out, "poses.txt"), "w") as f:  # camera_from_reference, the reference the world
        f.write("\n".join(line(n, np.eye(4) if n == names[0] else np.linalg.inv(poses[n]) @ ref) for n in names) + "\n")
    with open(os.path.join(a.out, "intrinsics.txt"), "w") as f:
        f.write("".join(f"{n} {K[0]:.6f} {K[1]:.6f} {K[2]:.6f} {K[3]:.6f} 640 480\n" for n in names))
    seq1 = names[1:]
    lines = []
    for i in range(9, len(seq1), 10):  # the evaluated frames and their windows (linear positions)
        q = poses[seq1[i]]
        for j in range(i - 8, i + 1):
            T = np.eye(4) if j == i else np.linalg.inv(poses[seq1[j]]) @ q  # frame_from_query
            lines.append(line(seq1[j], T))
    with open(os.path.join(a.out, "poses_device.txt"), "w") as f:
        f.write("\n".join(lines) + "\n")
    with open(os.path.join(a.out, "frame_sources.txt"), "w") as f:
        f.write("".join(f"{n} <- rgb/{s}.png\n" for n, s in zip(names, stamps)))


if __name__ == "__main__":
    main()
