"""sim: the collision model, a pure, differentiable JAX function.

    from sim import load_vehicle, named_params, simulate
    traj = simulate(named_params("paper_identified"), load_vehicle("audi_a4"), speed=15.64)

Vehicles (``Vehicle``, ``load_vehicle``), parameters (``Params``, ``make_params``,
``load_params``, ``named_params``), optional mechanisms (``sim.mechanisms``), the
simulation (``simulate``, ``Solver``, ``Trajectory``) and its events (``events_ms``).
Knows physics, nothing of pixels or files beyond its own vehicle and parameter files.
Enable float64 (``jax.config.update("jax_enable_x64", True)``) before use.
"""

from sim.errors import ConfigError as ConfigError
from sim.events import events_ms as events_ms
from sim.mechanisms import (
    MECHANISMS as MECHANISMS,
    EngineImpact as EngineImpact,
    FrontWheelBlock as FrontWheelBlock,
    Mechanism as Mechanism,
    ProgressiveStiffness as ProgressiveStiffness,
    RateDependence as RateDependence,
    StiffnessZone as StiffnessZone,
)
from sim.params import (
    Params as Params,
    list_param_sets as list_param_sets,
    load_params as load_params,
    make_params as make_params,
    named_params as named_params,
    validate_params as validate_params,
)
from sim.simulate import Solver as Solver, Trajectory as Trajectory, n_samples as n_samples, simulate as simulate
from sim.vehicle import (
    Vehicle as Vehicle,
    list_vehicles as list_vehicles,
    load_vehicle as load_vehicle,
    read_vehicle_file as read_vehicle_file,
    vehicle_from_dict as vehicle_from_dict,
)
