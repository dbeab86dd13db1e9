"""heliar from Python: estimate the sun and sky of outdoor footage and composite virtual objects
into it, with numpy arrays in and out.

The Rust crate is the single implementation; this package is a thin layer over it (PyO3)::

    import heliar
    scene = heliar.Scene.load("scenes/courtyard")
    est = scene.estimator(sequence="hdr")
    comp = scene.compositor(sequence="hdr")
    for path, time in zip(scene.frame_files("hdr"), scene.frame_times("hdr")):
        frame = heliar.read_frame(path)          # float32 HxWx3 (EXR) or uint8 (PNG)
        e = est.estimate(frame, time)            # e.pd, e.pa, e.status, e.pd_se, ...
        image, report = comp.composite(frame, e)

``heliar.vem.Decomposer`` turns captured environment maps into lights, ``heliar.sun`` gives the
solar position, and ``python -m heliar.ray augment`` runs many clips as Ray tasks.
"""

from ._heliar import (  # noqa: F401
    Compositor,
    Estimate,
    Estimator,
    HeliarError,
    Lighting,
    Scene,
    read_frame,
    sun,
)
from . import vem  # noqa: F401

__all__ = ["Scene", "Estimator", "Estimate", "Compositor", "Lighting", "HeliarError", "read_frame", "sun", "vem"]
