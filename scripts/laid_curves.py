"""Shared geometry of laid fibres for the analysis scripts: the signed turning angles of a
laid polyline in the belt plane (as geometry::bending_energy measures them, unsigned)."""
import numpy as np


def turning_angles(xy):
    """(turn, length) of a laid polyline (n, 2), rows with NaN and zero-length segments
    dropped: turn[k] the signed angle (rad) from segment k to k + 1, length the segments'."""
    xy = xy[np.all(np.isfinite(xy), axis=1)]
    seg = np.diff(xy, axis=0)
    length = np.hypot(seg[:, 0], seg[:, 1])
    seg = seg[length > 0]
    length = length[length > 0]
    heading = np.arctan2(seg[:, 1], seg[:, 0])
    return np.angle(np.exp(1j * np.diff(heading))), length
