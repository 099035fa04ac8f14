"""Body edges tracked through the film: the roof edge at the top of the windscreen (it
does not deform in a frontal crash), the car's front end, the barrier face and the crush.

Public surface (the modules behind it are ``edges_roof.py`` and ``edges_front.py``)::

    guess, roof, screen, reach = roof_edge_start(sil.polygon_px, sil.windscreen_top_px)
    roof_track = track_roof_edge(frames, guess, roof, screen, reach_px=reach)  # EdgeTrack
    front = track_front_end(frames, direction, rows, sil.front_px[0])          # EdgeTrack
    face = find_barrier_face(frame, direction, wall_rows, sil.front_px[0])    # BarrierFace
    crush = crush_from_body(roof_track, front.uv[0], front.sigma[0, 0], 0, contact_u, ...)

``sil`` is a :class:`video.calibrate.SilhouetteFit`. Positions are image px (u right,
v down), the crush m.
"""

from .edges_front import (BarrierFace as BarrierFace, Crush as Crush, FrontEnd as FrontEnd,
                          crush_from_body as crush_from_body,
                          find_barrier_face as find_barrier_face,
                          locate_front_end as locate_front_end,
                          track_front_end as track_front_end)
from .edges_roof import (Corner as Corner, EdgeTrack as EdgeTrack,
                         locate_corner as locate_corner, roof_edge_start as roof_edge_start,
                         track_roof_edge as track_roof_edge)

__all__ = ["BarrierFace", "Corner", "Crush", "EdgeTrack", "FrontEnd", "crush_from_body", "find_barrier_face",
           "locate_corner", "locate_front_end", "roof_edge_start", "track_front_end",
           "track_roof_edge"]
