"""What a rig's published geometry predicts, for the checks of the reference fusion consumer
(tests/fusion/check_fusion.py on the host, tests/hil/check_fusion_hil.py on the VM's captures).
Written from the metadata's definitions (docs/contracts.md, "Per-frame metadata"), not taken from
the consumer, so that the checks do not test the consumer against itself.
"""
import json
import math

import numpy as np


def records(path):
    """The JSON-lines metadata of one channel."""
    with open(path, encoding="utf-8") as f:
        return [json.loads(line) for line in f if line.strip()]


def K_of(cam):
    return np.array([[cam["fx_px"], 0.0, cam["cx_px"]], [0.0, cam["fy_px"], cam["cy_px"]],
                     [0.0, 0.0, 1.0]])


def project(cam, X):
    """A scene point's pixel: x_c = R X + t, then K (pixel centres at +0.5)."""
    xc = np.array(cam["R"], float).reshape(3, 3) @ np.asarray(X, float) + np.array(cam["t_m"])
    return (K_of(cam) @ (xc / xc[2]))[:2]


def h_apply(H, p):
    q = H @ np.array([p[0], p[1], 1.0])
    return q[:2] / q[2]


def misregistration_map(cam, ypr_deg):
    """Pixel of the published camera -> pixel of the true one. The true camera is the published
    one turned by yaw (right), pitch (up), roll (Z-Y-X, aerospace) in its body axes (x forward,
    y right, z down); in OpenCV's camera axes (x right, y down, z forward) that rotation is
    Q = C M C^T with C = [[0,1,0],[0,0,1],[1,0,0]], its columns the true axes, so a point's
    camera coordinates are Q^T x in the true camera, and its pixel K Q^T K^-1 p (Hartley &
    Zisserman, Multiple View Geometry, 2nd ed., 2004, §8.4.2: rotation about the camera centre).
    """
    y, p, r = (math.radians(v) for v in ypr_deg)
    Rz = np.array([[math.cos(y), -math.sin(y), 0], [math.sin(y), math.cos(y), 0], [0, 0, 1]])
    Ry = np.array([[math.cos(p), 0, math.sin(p)], [0, 1, 0], [-math.sin(p), 0, math.cos(p)]])
    Rx = np.array([[1, 0, 0], [0, math.cos(r), -math.sin(r)], [0, math.sin(r), math.cos(r)]])
    C = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
    Q = C @ (Rz @ Ry @ Rx) @ C.T
    K = K_of(cam)
    return K @ Q.T @ np.linalg.inv(K)


def predicted_offset_px(rec_a, rec_b, X):
    """What a fiducial at scene point X should show after warping channel A into B with A's
    published ground homography: B's pixel of X less A's true pixel of X (A's misregistration
    applied) mapped by H_AB. Without a misregistration, the parallax of X's height over the
    plane alone."""
    H = np.array(rec_a["rig"]["ground_homography"][rec_b["channel"]], float).reshape(3, 3)
    P = misregistration_map(rec_a["camera"], rec_a["faults"]["misregistration_deg"])
    return project(rec_b["camera"], X) - h_apply(H, h_apply(P, project(rec_a["camera"], X)))
