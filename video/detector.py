"""What every detector of the video stage is: ``detect(frame) -> Candidates``.

A detector finds one kind of thing in one frame and says where, to a fraction of a
pixel, and how clean each find is. Each kind is one class in the module that owns its
image processing:

- :class:`video.targets.QuadrantTargetDetector`: quadrant targets (on the body, on the
  hubs, on the barrier or the floor: all look alike; which is which is told by how they
  move, :func:`video.motion.classify_targets`: a hub target's pattern turns);
- :class:`video.calibrate_tape.CheckerTapeDetector`: the reference tapes;
- :class:`video.contact_seen.FrontEndDetector`: the car's front end in the nose's rows,
  against the background before the car got there.

Adding a kind is a new subclass beside its image processing; the pipeline
(:mod:`video.track`) calls ``detect`` and reads ``found`` for the kind's own details.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

__all__ = ["Candidates", "Detector"]


@dataclass(frozen=True)
class Candidates:
    """What one detector found in one frame.

    Attributes
    ----------
    kind : str
        The detector's kind (``Detector.kind``).
    centres : (N, 2) float64
        Sub-pixel image positions ``[u, v]``, px (a target's centre, a tape's middle,
        the front end's column at the nose's middle row).
    quality : (N,) float64
        How clean each find is, 0 (barely accepted) to 1 (ideal); what it measures is the
        kind's own (a target's symmetry, a tape's spacing residual, the front's contrast).
    found : object
        The kind's own result, for its details (``video.targets.Detections``, a list of
        ``video.calibrate_tape.Tape``, ...).
    """

    kind: str
    centres: np.ndarray
    quality: np.ndarray
    found: Any

    def __len__(self) -> int:
        return len(self.centres)


class Detector(ABC):
    """Finds one kind of thing in a frame (grey or colour array)."""

    kind: ClassVar[str] = ""

    @abstractmethod
    def detect(self, frame: np.ndarray) -> Candidates:
        """Everything of this kind in ``frame``; empty ``Candidates`` when none."""

    def _candidates(self, centres, quality, found) -> Candidates:
        """``Candidates`` of this kind, arrays shaped (N, 2) and (N,), quality in [0, 1]."""
        centres = np.asarray(centres, float).reshape(-1, 2)
        quality = np.clip(np.asarray(quality, float).reshape(-1), 0.0, 1.0)
        return Candidates(self.kind, centres, quality, found)
