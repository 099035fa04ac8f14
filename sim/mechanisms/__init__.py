"""Optional mechanisms, off by default: each one file, each one class.

``MECHANISMS`` maps the effect names of ``docs/interface.md`` to their classes.
"""

from sim.mechanisms.base import Mechanism as Mechanism
from sim.mechanisms.engine_impact import EngineImpact as EngineImpact
from sim.mechanisms.front_wheel_block import FrontWheelBlock as FrontWheelBlock
from sim.mechanisms.progressive_stiffness import ProgressiveStiffness as ProgressiveStiffness
from sim.mechanisms.rate_dependence import RateDependence as RateDependence
from sim.mechanisms.stiffness_zone import StiffnessZone as StiffnessZone

MECHANISMS = {
    cls.effect: cls for cls in (FrontWheelBlock, StiffnessZone, ProgressiveStiffness, RateDependence, EngineImpact)
}
