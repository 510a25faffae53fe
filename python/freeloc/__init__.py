"""freeloc — map-free metric relocalization: the pose of a query photo relative to a reference photo, in metres.

The same C++ pipeline as the ``freeloc`` command, numpy in and out. Poses are ``query_from_ref``
(``x_query = R @ x_ref + t``). Keyword options take the pipeline's option names (``freeloc.option_names()``):
``preset``, ``solver``, ``scale``, ``threshold_px``, ``depth``, ``matcher``, …; an unknown name or value raises
``ValueError`` naming it. Library errors (unreadable files, bad checkpoints) raise ``freeloc.Error``.

    import freeloc, numpy as np
    r = freeloc.estimate_relative_pose(x_ref, x_query, K_ref, K_query, depth_ref, depth_query)
    print(r.status, r.R, r.t, r.confidence)
    reloc = freeloc.Relocalizer("sift-essential")
    r = reloc.relocalize("ref.png", "query.png", K, K, "ref.depth.png", "query.depth.png")
    r = reloc.relocalize("a.jpg", "b.jpg")  # intrinsics from EXIF (or, dust3r/mast3r presets, the pointmap)
    freeloc.read_intrinsics("a.jpg")          # {'K': ..., 'source': 'exif', 'why': ..., 'orientation': 6, ...}
    metrics = freeloc.evaluate("data/mapfree", "submission.zip")
    # The Multi Frame track: a window of frames (oldest first, the evaluated one last), fused into one pose.
    r = reloc.relocalize_window("ref.png", ["f1.png", "f2.png", "q.png"], K, K, "ref.depth.png", depths)
    freeloc.run("data/mapfree", "multi.zip", track="multi-frame")
    metrics = freeloc.evaluate("data/mapfree", "multi.zip", track="multi-frame")
"""

import json as _json
import os as _os

from . import _blas

_blas.select()  # OpenBLAS reads OPENBLAS_CORETYPE when _freeloc loads it, so this comes first

from ._freeloc import (  # noqa: F401,E402
    Dust3r,
    Error,
    Metric3D,
    PoseResult,
    Relocalizer,
    SegGPT,
    __version__,
    estimate_relative_pose,
    option_families,
    option_names,
    preset_names,
    read_depth,
    read_image,
    read_intrinsics,
    run,
    set_limit,
)
from . import _freeloc  # noqa: E402
from .client import Client, ServiceError  # noqa: E402,F401

__all__ = [
    "Client", "ServiceError", "Dust3r", "Error", "Metric3D", "PoseResult", "Relocalizer", "SegGPT", "__version__", "estimate_relative_pose",
    "evaluate", "option_families", "option_names", "preset_names", "read_depth", "read_image", "read_intrinsics", "run",
    "set_limit",
]


def evaluate(data, submission, split="val", scenes=None, track="single-frame"):
    """Map-free metrics of a submission ZIP, as ``freeloc eval --json``: a dict keyed by the official metric names.

    ``track="multi-frame"`` scores the Multi Frame track's evaluated frames (linear positions 9, 19, … of each
    scene's sorted seq1 frames) instead of every 5th frame."""
    if isinstance(scenes, str):
        scenes = [s for s in scenes.split(",") if s]
    return _json.loads(_freeloc._evaluate(_os.fspath(data), _os.fspath(submission), split, list(scenes or []), track))
