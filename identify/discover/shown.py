"""Effects the fitted model shows by itself: a candidate's physics that the base model
already holds (``Candidate.shown_in_base``: the rear wheels lifted by a contact force below
the centre of gravity), named in the report with the window where it acts in the fitted
model and what the recording's own channel says of it (the candidate's evidence check),
never as a discovery: no mechanism was added for it.
"""

from __future__ import annotations

import numpy as np

from identify.discover.candidates import CANDIDATES
from identify.discover.loop import effect_window_ms


def effects_shown(fr, vehicle, discovered=()) -> list[dict]:
    """result.json's ``shown_by_model``: for each candidate the base model can show
    (``Candidate.shown_in_base``) that is not among the ``discovered`` effects and acts
    within the recording in fit ``fr``: its ``effect``, the sentence that says why the model
    shows it, ``window_ms`` (ms after first contact, measurement clock), ``to_end`` (still
    acting at the recording's last sample: the window's end is the recording's, not the
    effect's), ``evidence`` (one line: seen in a measured channel, inferred, or what
    contradicts it) and ``contradicted`` (True when a measured channel refutes it: a
    conflict between the model and the recording, not an effect the recording shows)."""
    out = []
    t_ms = (np.asarray(fr.trajectory.t) + fr.contact_time) * 1e3
    inside = t_ms <= float(np.max(fr.measurement.t)) * 1e3
    for c in CANDIDATES:
        if not c.shown_in_base or c.effect in set(discovered):
            continue
        window = effect_window_ms(fr, c.effect)
        if window is None:
            continue
        why, line = c.evidence(fr, vehicle, window) if c.evidence is not None else ("", "")
        out.append({"effect": c.effect, "explanation": c.shown_in_base, "window_ms": list(window),
                    "to_end": bool(c.acting(fr)[inside][-1]), "evidence": why or line, "contradicted": bool(why)})
    return out


def shown_status(shown: list[dict]) -> str:
    """What the discovery status adds for the effects the fitted model shows by itself (''
    when none): a status that says candidates were ruled out, the rear axle's among them,
    would otherwise read as if the rear never lifted."""
    named = [e["effect"].replace("_", " ") for e in shown if not e["contradicted"]]
    if not named:
        return ""
    return f"; the fitted base model itself shows {' and '.join(named)} (no mechanism added: below)"
