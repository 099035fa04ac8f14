"""``identify.fit``: from a recording to parameters, a result document and a results folder.

The flow: recording (``identify.recordings.load``) -> Measurement -> fit (``identify.fitting.collision_fit``)
-> result.json, tracks.csv, plots and report.md (written atomically).
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from identify.errors import UserError
from identify.fitting.collision_fit import FitOptions, FitResult
from identify.fitting.model import NUISANCE
from identify.recordings.load import Recording, load_recording
from identify.report.markdown import held_where
from identify.report.results import ResultsFolder, default_output_folder as default_output_folder

COLLISION_PARAMETERS = ("k_compression", "k_restitution", "restitution", "dz_contact")
# result.json's "parameters" (and report.md's table): the collision parameters and the barrier
# face's friction, fitted or held, so that --params rebuilds the fitted model
RESULT_PARAMETERS = (*COLLISION_PARAMETERS, "mu_face")


@dataclasses.dataclass
class Identification:
    """What ``identify.fit`` returns.

    document : the result.json content (dict).
    fit : identify.fitting.collision_fit.FitResult (values, covariance, trajectory, predictions ...).
    recording : identify.recordings.load.Recording (the measurement, and a film's tracks).
    vehicle : sim.Vehicle.
    out : the results folder, or None when nothing was written.
    discovery : identify.discover.loop.DiscoveryResult, or None with ``discover=False``.
    one_body : FitResult of the base model (its engine assumed, on its mounts) on the cabin's channels
        alone, when the recording measured a second body (the engine) and has load cells to score both on.
    """

    document: dict
    fit: FitResult
    recording: Recording
    vehicle: object
    out: Path | None = None
    discovery: object = None
    one_body: FitResult | None = None

    @property
    def parameters(self) -> dict:
        """name -> {"value", "unit", "std", ...} of the collision parameters."""
        return self.document["parameters"]




def vehicle_reference(name_or_path) -> str:
    """What loads this vehicle again: its name when it is one of ``data/vehicles/``, else
    the absolute path of its file."""
    from sim.vehicle import VEHICLE_DIR, vehicle_path

    path = vehicle_path(name_or_path).resolve()
    return path.stem if path == (VEHICLE_DIR / path.name).resolve() else str(path)


def car_geometry_of(vehicle):
    """The video stage's CarGeometry of a (validated) sim.Vehicle."""
    from video.types import CarGeometry

    return CarGeometry(
        length=float(vehicle.length),
        height=float(vehicle.height),
        wheelbase=float(vehicle.wheelbase),
        front_overhang=float(vehicle.front_overhang),
        wheel_radius=float(vehicle.wheel_radius),
        cg_height=float(vehicle.cg_height),
        cg_to_front_axle=float(vehicle.cg_to_front_axle),
        silhouette_side=np.asarray(vehicle.silhouette_side, float),
        windscreen_top=np.asarray(vehicle.windscreen_top if vehicle.windscreen_top else (np.nan, np.nan), float),
        mass=float(vehicle.mass),
    )


def free_parameters(measurement, speed_mps: float | None, face_friction: bool = False) -> tuple[tuple, dict[str, str]]:
    """What the fit moves for this recording, and the collision parameters it holds fixed
    with the reason: the impact speed when the user gave it; dz_contact when the recording
    has neither pitch nor height (the force's height shows only there: a sensor recording's
    X accelerometers say nothing of it), held at V-SIM's 0 m, and with it the barrier face's
    friction (``mu_face``, a vertical force), held at V-SIM's 0, as it is unless
    ``face_friction`` (``FitOptions.face_friction``)."""
    from identify.fitting.model import base_parameters

    free, held = base_parameters(face_friction), {}
    if speed_mps is not None:
        free = tuple(p for p in free if p.name != "impact_speed")
    if not {"z_m", "pitch_rad"} & set(measurement.channels):
        # the face's friction acts vertically: it too shows only in pitch and heave, held at V-SIM's 0
        free = tuple(p for p in free if p.name not in ("dz_contact", "mu_face"))
        held["dz_contact"] = ("not identified: the recording has no pitch or height channel, and the height of the"
                              " contact force shows only in the car's pitch and heave; held at V-SIM's 0 m")
        held["mu_face"] = ("not identified: the recording has no pitch or height channel, and the barrier face's"
                           " friction, a vertical force, shows only there; held at V-SIM's 0")
    elif not face_friction:
        held["mu_face"] = ("not fitted (--no-face-friction): held at V-SIM's 0, a model without friction on the"
                           " barrier face")
    return free, held


def result_document(fr: FitResult, recording: Recording, vehicle, discoveries=(), discovery_status="",
                    held: dict | None = None, vehicle_ref: str | None = None) -> dict:
    """The result.json content (``docs/interface.md``), NaN-free after ``results.dumps``.

    ``held`` maps a collision parameter the fit held fixed to the reason why;
    ``vehicle_ref`` is what ``--vehicle`` must be given to load the vehicle again (its name,
    or the path of a file outside ``data/vehicles/``; default the name)."""
    from identify.discover.candidates import assumed_in_base
    from identify.discover.shown import effects_shown, shown_status
    from sim import events_ms

    params = {}
    for name in RESULT_PARAMETERS:
        if name not in fr.values:
            params[name] = {"value": float(getattr(fr.params, name)), "unit": _unit(name), "std": None,
                            "identified": False, "reason": (held or {}).get(name, "held fixed, not fitted")}  # fmt: skip
            continue
        ok, reason = fr.identified.get(name, (True, ""))
        if ok:
            reason = _barely_narrowed(fr, name) or _model_error_unmeasured(fr, name)
            ok = not reason
        entry = {"value": fr.values[name], "unit": fr.units[name], **_std_entry(fr, name), "identified": ok}
        if not ok:
            entry["reason"] = reason
        if note := at_physical_floor(name, fr.values[name]):
            entry["note"] = note
        params[name] = entry
    for key in fr.names:  # a discovered mechanism's parameters: "stiffness_zone.depth"
        if "." in key:
            params[key] = {"value": fr.values[key], "unit": fr.units[key], **_std_entry(fr, key), "identified": True}
            ok, reason = fr.identified.get(key, (True, ""))
            if not ok:
                params[key].update(identified=False, reason=reason)
            elif reason := _barely_narrowed(fr, key):
                params[key].update(identified=False, reason=reason)
    model_events = {k: (v + fr.contact_time * 1e3 if v is not None else None) for k, v in events_ms(fr.trajectory).items()}
    shown = effects_shown(fr, vehicle, [d["effect"] for d in discoveries])
    tracks = recording.tracks
    doc = {
        "vehicle": vehicle_ref or vehicle.key,
        "vehicle_name": vehicle.name,
        "recording": str(recording.path),
        "recording_kind": recording.kind,
        "fps": fr.measurement.fps,
        "impact_speed_kmh": fr.speed * 3.6,
        "impact_speed_std_kmh": fr.std.get("impact_speed", 0.0) * 3.6,
        "speed_mps": fr.speed,
        "contact_time_ms": fr.contact_time * 1e3,
        "parameters": params,
        "nuisance": {n: _nuisance_entry(fr, n) for n in NUISANCE if n in fr.values},
        "covariance": {"names": list(fr.names), "matrix": fr.covariance},
        "correlation": {"names": list(fr.names), "matrix": fr.correlation},
        "fit": {
            "rms_m": fr.rms_m,
            "model": fr.model,
            "rms_by_channel": fr.rms,
            "chi2": fr.chi2,
            "dof": fr.dof,
            "reduced_chi2": fr.reduced_chi2,
            "converged": fr.converged,
            "starts": fr.starts,
            "starts_at_best": fr.starts_at_best,
            "other_minima_cost": fr.other_minima,
            "fitted_channels": [c for c in fr.rms if c not in fr.measurement.derived],
            "derived_channels": [c for c in fr.rms if c in fr.measurement.derived],
            # a channel fitted only up to then (ms after contact), its later samples left out
            "fitted_until_ms": dict(fr.measurement.fitted_until_ms),
            "correlation_time_samples": dict(fr.correlation_time),  # integrated autocorrelation time of each residual
            # each channel's reduced chi-square (at least 1): the factor its variance was widened by
            "misfit_by_channel": dict(fr.misfit),
            # the factor each widened channel's sigma was multiplied by in the fit's weights (its own misfit)
            "sigma_widened_by_channel": dict(fr.sigma_widened),
            # the base model's parts that were assumed, not fitted (the engine on its mounts)
            "assumed": assumed_in_base(fr.params, {n.split(".", 1)[0] for n in fr.names if "." in n}),
        },
        "priors": fr.pulls(),
        "discoveries": list(discoveries),
        "discovery_status": discovery_status + shown_status(shown),
        # a candidate's effect the fitted base model shows by itself (the rear wheels lifted)
        "shown_by_model": shown,
        "events_ms": dict(fr.measurement.events_ms),
        "model_events_ms": model_events,
        "notes": list(fr.measurement.notes) + _second_body_notes(fr, recording),
    }
    if tracks is not None:
        doc["contact_frame"] = int(tracks.contact_frame)
        doc["scale_m_per_px"] = float(tracks.scale_m_per_px)
        doc["scale_std_m_per_px"] = float(tracks.scale_sigma)
        doc["scale_source"] = str(tracks.scale_source)
        doc["fps"] = float(tracks.fps)
    return doc


# a parameter with a prior counts as identified when the fit's std is below this share of the
# prior's: the recording, not the prior, decides its value
PRIOR_NARROWING = 0.5


def at_physical_floor(name: str, value: float) -> str:
    """A note for a base parameter whose floor is a law of physics (``FreeParameter.floor_is_physical``:
    the face's friction) fitted at that floor (within ``FreeParameter.AT_BOUND`` of its range),
    else '': the recording asks for none of it, and its std, taken at the floor, says only
    how little above it the value may be (the bundled sample's nose slides on the face: 1e-9
    +- 4e-5)."""
    from identify.fitting.model import base_parameters

    p = next((p for p in base_parameters(face_friction=True) if p.name == name), None)
    if p is None or not p.at_physical_floor(value):
        return ""
    return (f"at its physical floor, {p.lower:g}: the recording asks for none; its std, at the floor, says only how"
            f" little above {p.lower:g} it may be")


def _barely_narrowed(fr: FitResult, name: str) -> str:
    """'not identified: ...' when ``name`` had a prior that is knowledge, not a measurement
    of this recording (a vehicle file's engine mass, the face's friction), and the fit's std
    is more than ``PRIOR_NARROWING`` of the prior's: the prior, not the recording, decided
    it; '' otherwise."""
    if name not in fr.priors or name in NUISANCE or fr.std[name] <= PRIOR_NARROWING * fr.priors[name][1]:
        return ""
    mu, sigma = fr.priors[name]
    unit = f" {fr.units[name]}" if fr.units[name] != "1" else ""
    return (f"not identified: the fit barely narrows what was known before it ({mu:.4g} +- {sigma:.2g}{unit};"
            f" fitted +- {fr.std[name]:.2g} with the model's own error)")


def _model_error_unmeasured(fr: FitResult, name: str) -> str:
    """'not identified: ...' for a fitted collision parameter the calibrated model-error table
    of the recording's kind does not list (``identify.fitting.model_error``: the face's
    friction, which no calibration world scores), '' otherwise. Its std is the data's alone,
    and the value is this model's effective coefficient, not a measured property of the car
    or the face: the model's front sticks where the reference world's creeps, and on
    development world 960016 the fit gave 0.023 +- 0.004 where the world's face had 0.169."""
    from identify.fitting.model_error import kind_of, table

    if fr.measurement is None:
        return ""
    calibrated = table(kind_of(fr.measurement))
    if name in calibrated.relative or name in calibrated.absolute:
        return ""
    return ("not identified: the model's own error for it has not been measured, so its std is the data's alone;"
            " it is this model's effective value, which the fit needs, not a measured property of the car")


def _nuisance_entry(fr: FitResult, name: str) -> dict:
    """result.json's entry of a nuisance parameter; marked not identified with the reason
    when the fit says so (a contact time stopped by its bound)."""
    entry = {"value": fr.values[name], "unit": fr.units[name], **_std_entry(fr, name)}
    if name in fr.held_measured:
        h = fr.held_measured[name]
        where = ("where the recording measured it" if h.get("held_at", h["measured"]) == h["measured"]
                 else "where the recording measured it, combined with where the fitted channels alone put it")
        entry["held"] = f"not fitted: held {where} (priors)"
    ok, reason = fr.identified.get(name, (True, ""))
    if not ok:
        entry.update(identified=False, reason=reason)
    return entry


def _std_entry(fr: FitResult, name: str) -> dict:
    """A fitted quantity's standard deviations: ``std`` (what to quote), and its two parts,
    the data's ``std_data`` and the model's own error ``std_model`` (``identify.fitting.model_error``),
    which holds ``model_choice_shift`` when discovery's mechanisms moved the parameter
    (``identify.discover.loop.with_model_choice``); ``std_model_measured`` says where that
    error was measured when a regime's, not the clean worlds' (``FitResult.model_error_where``)."""
    entry = {"std": fr.std[name], "std_data": fr.std_data.get(name, fr.std[name]), "std_model": fr.std_model.get(name, 0.0)}
    if name in fr.model_choice:
        entry["model_choice_shift"] = fr.model_choice[name]
    if name in fr.model_error_where:
        entry["std_model_measured"] = fr.model_error_where[name]
    return entry


def _unit(name):
    from sim.params import UNITS

    return UNITS[name]


def write_results(out, ident: Identification, default_traj) -> Path:
    """Write the results folder atomically: result.json, tracks.csv, PNGs, report.md.

    ``out`` is a path or an open :class:`identify.report.results.ResultsFolder` (created before
    the work started, so that an unwritable place fails at once)."""
    from identify.report import plots
    from identify.report.markdown import render_report
    from identify.report.results import ResultsFolder, dumps
    from sim import named_params

    fr, rec, vehicle = ident.fit, ident.recording, ident.vehicle
    folder = out if isinstance(out, ResultsFolder) else ResultsFolder(out)
    out = folder.out
    with folder as tmp:
        forces = []
        if rec.sensor_test is not None and rec.sensor_test.barrier:
            from identify.report.force_check import force_check_document

            start = ident.discovery.start if ident.discovery is not None else None
            base, base_label = None, "base model, before discovery"
            if ident.one_body is not None:
                base, base_label = (ident.one_body.trajectory, ident.one_body.contact_time), "base model on the cabin alone"
            elif start is not None and fr.model != start.model:
                base = (start.trajectory, start.contact_time)
            from identify.discover.candidates.engine_impact import ENGINE_MASS_FRACTION, typical_engine_mass

            engine_mass = (typical_engine_mass(vehicle),
                           "the vehicle file's" if vehicle.engine_mass is not None
                           else f"{100 * ENGINE_MASS_FRACTION:.0f} % of the vehicle's mass, typical")
            ident.document["force_check"] = force_check_document(
                rec.sensor_test, fr.measurement, fr.trajectory, tmp, fr.contact_time,
                title=f"{vehicle.name}: barrier load cells vs fitted model ({fr.model})", base=base,
                base_label=base_label, engine_mass=engine_mass)
            forces = ["force_time.png", "force_crush.png"]
        (tmp / "result.json").write_text(dumps(ident.document))
        if rec.tracks is not None:
            from video.report import tracks_csv, write_report

            (tmp / "tracks.csv").write_text(tracks_csv(rec.tracks))
            write_report(rec.tracks, tmp, film=rec.film, car=car_geometry_of(vehicle))
        else:
            (tmp / "tracks.csv").write_text(_measurement_csv(fr.measurement))
        figures = [
            plots.plot_displacement_velocity(fr, default_traj, tmp / "displacement_velocity.png").name,
            plots.plot_residuals(fr, tmp / "residuals.png", windows=[
                (d["effect"], *d["window_ms"]) for d in ident.document.get("discoveries", [])
            ]).name,  # fmt: skip
            plots.plot_silhouettes(fr, vehicle, default_traj, tmp / "silhouettes.png").name,
        ]
        overlay = plots.plot_overlay(fr, vehicle, rec, tmp / "overlay.png")
        if overlay is not None:
            figures.append(overlay.name)
        if ident.discovery is not None:
            from identify.discover.plots import plot_discovery

            figures += plot_discovery(ident.discovery, tmp, vehicle)
        figures += forces
        (tmp / "predictions.csv").write_text(_predictions_csv(fr))
        defaults = {n: float(getattr(named_params("vsim_default"), n)) for n in RESULT_PARAMETERS}
        (tmp / "report.md").write_text(render_report(ident.document, defaults, figures))
    return out


def _predictions_csv(fr: FitResult) -> str:
    """The fitted model on the measurement's clock: ``t_ms`` (0 = measured first contact)
    and one column per channel (SI units, offsets removed as the fit removes them)."""
    names = list(fr.predictions)
    cols = [np.asarray(fr.measurement.t) * 1e3] + [np.asarray(fr.predictions[n], float) for n in names]
    rows = [",".join(["t_ms"] + names)]
    rows += [",".join("nan" if not np.isfinite(v) else f"{v:.9g}" for v in row) for row in zip(*cols)]
    return "\n".join(rows) + "\n"


def _measurement_csv(m) -> str:
    names = list(m.channels)
    header = ["t_ms"] + names + [f"{n}_sigma" for n in names]
    rows = [",".join(header)]
    for i, t in enumerate(m.t):
        vals = [m.channels[n][i] for n in names] + [m.sigma[n][i] for n in names]
        rows.append(f"{t * 1e3:.6f}," + ",".join("nan" if not np.isfinite(v) else f"{v:.9g}" for v in vals))
    return "\n".join(rows) + "\n"


#: What ``identify fit`` (and :func:`fit`) fits with unless told otherwise: the barrier face's
#: friction too (``FitOptions.face_friction``; ``--no-face-friction`` holds it at V-SIM's 0).
#: The reference world's cars rub their crushed fronts on the face; without it the contact
#: force's height came out 0.02-0.06 m high on clean calibration films (dz_contact within
#: 0.03 m on 9 of 22; 22 of 22 with it) and 0.12-0.14 m high where the rear wheels lift
#: (README, "How accurate is it today").
FIT_OPTIONS = FitOptions(face_friction=True)


def fit(
    recording: str | Path,
    vehicle: str | Path,
    *,
    fps: float | None = None,
    tape_segment: float = 0.1,
    speed_kmh: float | None = None,
    out: str | Path | None = None,
    write: bool = True,
    discover: bool = True,
    options: FitOptions = FIT_OPTIONS,
    progress=None,
    force: bool = False,
) -> Identification:
    """Identify the collision parameters from a recording (the Python twin of ``identify fit``).

    Parameters
    ----------
    recording : a video file, a folder of frames, or a tracks.csv.
    vehicle : a vehicle name (``audi_a4``) or a path to a vehicle TOML file.
    fps : the true frame rate when the container's is wrong.
    tape_segment : m, one reference-tape segment.
    speed_kmh : impact speed if known (held fixed); else measured.
    out : results folder (default ``<recording stem>.identify/`` beside it), or an
        ``identify.report.results.ResultsFolder`` made already; ``write=False`` writes nothing.
    discover : look for physics the base model left out.
    options : identify.fitting.collision_fit.FitOptions: its starts, seed, solver, face
        friction (on: :data:`FIT_OPTIONS`), misfit weighting and contact comparison; the solver's step limit and
        tolerances are discovery's (``identify.discover.loop.CANDIDATE_FIT``), continued
        while the step limit stops it.
    progress : callable taking a one-line status string, or None.
    force : fit even when the film contradicts the vehicle file (wheelbase, length); the
        result then carries the contradiction in ``"warnings"``.

    Returns
    -------
    Identification (``.parameters``, ``.document``, ``.fit``, ``.out``).
    """
    import jax

    jax.config.update("jax_enable_x64", True)
    from sim import load_vehicle

    say = progress or (lambda msg: None)
    veh = load_vehicle(vehicle)
    if speed_kmh is not None and not (0 < speed_kmh <= 360):
        raise UserError(f"--speed must be in (0, 360] km/h, got {speed_kmh}")
    if not Path(recording).exists():
        raise UserError(f"{recording} does not exist")
    folder = None
    if isinstance(out, ResultsFolder):  # made by the caller before any work (``identify fit``)
        folder = out if write else None
    elif write:  # the results' temporary sibling is made now: an unwritable place fails at once
        folder = ResultsFolder(Path(out) if out is not None else default_output_folder(Path(recording)))
    try:
        return _fit(recording, vehicle, veh, folder, fps, tape_segment, speed_kmh, discover, options, say, force)
    except BaseException:
        if folder is not None:
            folder.discard()
        raise


def _fit(recording, vehicle, veh, folder, fps, tape_segment, speed_kmh, discover, options, say, force):
    from sim import named_params, simulate

    speed_mps = speed_kmh / 3.6 if speed_kmh is not None else None

    def video_progress(done, total, stage):
        if done == total or done % 50 == 0:
            say(f"{stage}: frame {done} of {total}")

    say(f"reading {recording}")
    rec = load_recording(recording, car_geometry_of(veh), fps=fps, tape_segment_m=tape_segment,
                         speed_mps=speed_mps, progress=video_progress)  # fmt: skip
    warnings = []
    if rec.tracks is not None:
        from identify.recordings.consistency import check_film_against_vehicle

        warnings = check_film_against_vehicle(rec.tracks, veh, vehicle_label(vehicle), force=force)
        for w in warnings:
            say(f"warning: {w}")
    from identify.fitting.wheel_spin import without_spinning_wheels

    rec = dataclasses.replace(rec, measurement=without_spinning_wheels(rec.measurement, float(veh.wheel_radius)))
    free, held = free_parameters(rec.measurement, speed_mps, options.face_friction)
    from identify.discover.loop import CANDIDATE_FIT, discover as discover_missing, fit_base, with_model_choice

    # the base fit is run as discovery's candidates are (one compile: the solver's step limit and
    # tolerances are compiled in, so a recording fitted with and without discovery shares it);
    # without discovery it is the reported fit, each channel then weighted by its own misfit
    base_options = dataclasses.replace(CANDIDATE_FIT, starts=options.starts, seed=options.seed, solver=options.solver,
                                       hold_measured_contact=options.hold_measured_contact,
                                       held_from_channels=options.held_from_channels,
                                       misfit_weights=options.misfit_weights and not discover)
    say("fitting the collision model (the first run compiles it: ~20 s)")
    base = fit_base(rec.measurement, veh, free=free, options=base_options, speed_mps=speed_mps, progress=say)
    # every later fit holds the contact where the base fit did: the measured one combined with the base model's
    rec = _with_contact_held_as(rec, base)
    base_options = dataclasses.replace(base_options, held_from_channels=False)
    found = None
    if discover:
        say(f"base model: x RMS {base.rms_m * 1e3:.2f} mm; looking for physics it left out")
        found = discover_missing(rec.measurement, veh, base, progress=say)
        fr, discoveries, status = found.final, found.discoveries, found.status
        say(f"discovery: {status}")
    else:
        fr, discoveries, status = base, [], "discovery of missing physics was switched off (--no-discover)"
    fr = dataclasses.replace(fr, held_measured=base.held_measured)  # what the measured contact was combined with
    one_body = _cabin_alone(rec, veh, free, base_options, speed_mps, say)
    engine_doubt, disputed = second_body_doubts(fr, one_body)
    if engine_doubt:  # the cabin prefers the base model's engine: the choice between the two is no measurement
        fr = with_model_choice(fr, one_body, ["engine_impact"], choice=(
            "the engine fitted as a second body, which the cabin's motion does not bear out,"))
    for name, reason in disputed.items():  # the data do not decide between the two models there
        fr.mark_not_identified(name, reason)
    doc = result_document(fr, rec, veh, discoveries=discoveries, discovery_status=status, held=held,
                          vehicle_ref=vehicle_reference(vehicle))
    if found is not None:  # every candidate tried, round by round, and why it was not accepted
        doc["discovery_rounds"] = [[trial.as_dict() for trial in r] for r in found.rounds]
        # the models not adopted that the recording does not rule out: they widen the stds
        doc["discovery_alternatives"] = [dataclasses.asdict(a) for a in found.alternatives]
        # the multi-start search is the base model's; discovery refines from its best fit
        doc["fit"]["starts"], doc["fit"]["starts_at_best"] = base.starts, base.starts_at_best
        doc["fit"]["starts_of"] = "base model"
    if engine_doubt:
        warnings.append(engine_doubt)
    warnings += unconverged_warning(base) + fit_warnings(fr)
    if warnings:
        doc["warnings"] = list(warnings)
    ident = Identification(document=doc, fit=fr, recording=rec, vehicle=veh, discovery=found, one_body=one_body)
    if folder is not None:
        say(f"writing {folder.out}")
        default_traj = simulate(named_params("vsim_default"), veh, fr.speed, duration=float(fr.measurement.t.max()) + 0.001)
        ident.out = write_results(folder, ident, default_traj)
    return ident


def unconverged_warning(base) -> list[str]:
    """The base model's fit ``base`` where the solver stopped at its step limit before its
    tolerances were met, taken as the best fit because its starts agree on it
    (``identify.discover.loop.fit_base``, which refuses it otherwise): one warning, or none."""
    if base.converged:
        return []
    return [f"the base model's fit stopped at the solver's step limit, its tolerances not met; {base.starts_at_best}"
            f" of {base.starts} starting points ended at this misfit (reduced chi-square {base.reduced_chi2:.3g}),"
            " taken as the best fit: its numbers carry that misfit in their uncertainty"]


def fit_warnings(fr) -> list[str]:
    """What the user must be told of fit ``fr`` before its numbers: every fitted quantity a
    bound stopped (not identified: the fit's range set it), and every quantity pulled beyond
    ``FitResult.PULL_CONFLICT`` sigma from what was known before the fit (a measured speed or
    contact, a vehicle file's engine mass): the model and the recording disagree there; and a
    fit that misses x beyond any fit the model's error was measured on (its errors scaled)."""
    out = [f"every parameter's model error {fr.model_error_scaled}"] if fr.model_error_scaled else []
    out += [f"{name} ended {where} ({fr.values[name]:.4g} {fr.units[name]}): not identified; the fit's range, not"
           " the recording, set it (the model may be trading it against what it cannot explain)"
           for name, where in fr.at_bound.items()]
    for name, p in fr.pulls().items():
        if p.get("at_bound"):
            conflict = (f", already {p['pull']:+.1f} sigma from where the recording measured it: the model and the"
                        " recording disagree there" if p["conflict"] else "")
            out.append(f"{name}: the fitted channels alone ran {p['at_bound']} ({p['value']:.4g} {p['unit']}): they"
                       f" cannot place it within the fit's range{conflict}; held where the recording measured it,"
                       f" {p['held_at']:.4g} +- {p['held_std']:.2g}")
        elif p["conflict"] and p.get("held"):
            out.append(f"{name}: the fitted channels alone put it at {p['value']:.4g} +- {p['std']:.2g} {p['unit']},"
                       f" {p['pull']:+.1f} sigma from where the recording measured it ({p['prior']:.4g} +-"
                       f" {p['prior_std']:.2g}): the model and the recording disagree there; {held_where(p)},"
                       f" {p['held_at']:.4g} +- {p['held_std']:.2g}")
        elif p["conflict"]:
            out.append(f"{name} fitted at {p['value']:.4g} is {p['pull']:+.1f} sigma from what was known before"
                       f" the fit ({p['prior']:.4g} +- {p['prior_std']:.2g} {p['unit']}): the model and the recording"
                       " disagree there")
    return out


def _second_body_notes(fr, recording) -> list[str]:
    """What a sensor recording without engine accelerometers cannot tell of the engine."""
    if recording.sensor_test is None or "engine_vx_mps" in fr.measurement.channels:
        return []
    return ["no valid engine accelerometer in the recording: the engine's own motion is not measured, so the"
            " engine is not fitted as a second body; its impact on the barrier can only be inferred by discovery"
            " (engine_impact), with the engine's mass and gap from the vehicle file's estimates, and is reported"
            " as not identified where the motion barely narrows them"]


SECOND_BODY_BIC_GAIN = 10.0  # the cabin's BIC must fall this much for the second body to be borne out
MODEL_DISAGREEMENT = 2.0  # standard deviations (both fits' combined) beyond which a parameter depends on the model


def second_body_doubts(fr, one_body) -> tuple[str, dict[str, str]]:
    """What the base model's fit to the cabin alone (``one_body``: its engine assumed, on its
    mounts; the engine's channels shown, not fitted) says about the two-body fit ``fr``: a
    warning ('' when none) and {parameter: reason} for what is therefore not identified.

    - When the two-body fit does not explain the cabin's own channels better than the
      cabin-alone fit (BIC on those channels, one autocorrelation time per channel for both,
      the engine's parameters counted), a warning giving both values of k_compression, and
      every parameter of the second body itself is not identified: a second body the cabin's
      motion does not bear out describes the model's compromise (on reference world 300,
      whose engine never reaches the barrier, the two-body fit put the engine's mass at 445
      kg, prior 174 +- 52, and k_compression 17 % low with a cabin x RMS of 8.7 mm; the base
      model on the cabin alone, 4 % low with 0.8 mm, 1.9 combined sigma from it). ``identify.fit``
      then widens the two-body fit's standard deviations by how far the cabin-alone fit puts
      each parameter (``identify.discover.loop.with_model_choice``).
    - Every collision parameter on which the two fits disagree by more than
      MODEL_DISAGREEMENT combined standard deviations depends on which model is right, which
      the recording does not decide: not identified, with both values. This holds whichever
      model fits the cabin better: on 18 ISO-MME reference worlds the two-body fit (with the
      engine's forward stop) explained the cabin better than a rigid car and still put
      k_compression 3-14 % off with standard deviations of 1-2 % (z -2.3 to -8.2)."""
    from identify.discover.loop import bic, round_tau
    from identify.fitting.residuals import channel_chi2

    if one_body is None or "engine_vx_mps" not in fr.predictions:
        return "", {}
    tau = round_tau([one_body, fr])
    cabin = list(channel_chi2(one_body, tau))
    scores = [bic(f, tau, channels=cabin) for f in (one_body, fr)]
    borne_out = scores[1] <= scores[0] - SECOND_BODY_BIC_GAIN
    k1, k2 = one_body.values.get("k_compression"), fr.values.get("k_compression")
    engine_rms = fr.rms.get("engine_vx_mps", float("nan"))
    warning = "" if borne_out else (
        f"the engine fitted as a second body does not explain the cabin's motion better than the base model's"
        f" engine (typical, on its mounts) does (cabin BIC {scores[1]:.0f} against {scores[0]:.0f}; the engine's"
        f" velocity misses by {engine_rms:.2f} m/s RMS): the structure's stiffness depends on which model is right,"
        f" k_compression {k2:.4g} N/m^3 with two bodies, {k1:.4g} +-"
        f" {one_body.std.get('k_compression', float('nan')):.2g} N/m^3 with the cabin alone; the two-body fit's"
        f" standard deviations include how far apart the two are")
    disputed = {}
    for name in COLLISION_PARAMETERS:
        if name not in fr.values or name not in one_body.values:
            continue
        v2, v1 = fr.values[name], one_body.values[name]
        s = math.hypot(fr.std.get(name, math.nan), one_body.std.get(name, math.nan))
        if math.isfinite(s) and abs(v2 - v1) > MODEL_DISAGREEMENT * s:
            disputed[name] = (f"not identified: it depends on the model, not on the recording ({v2:.4g} with the engine"
                              f" as a second body, {v1:.4g} +- {one_body.std[name]:.2g} with the cabin alone,"
                              f" {abs(v2 - v1) / s:.1f} sigma apart; " +
                              ("the cabin's motion bears out the second body, but not this number)" if borne_out else
                               "the cabin's motion does not bear out the second body)"))
    if not borne_out:
        for name in fr.names:  # the second body's own parameters: the model's compromise, not the car's
            if name.startswith("engine_impact."):
                disputed[name] = ("not identified: the cabin's motion does not bear out the engine as a second body,"
                                  " so its fitted values describe the model's compromise, not the car")
    return warning, disputed


def _with_contact_held_as(rec, fr):
    """``rec`` with its measured first contact replaced by where fit ``fr`` held it, the
    measurement combined with where the fitted channels alone put it
    (``FitResult.held_measured``), so that the fits after it hold it there too; ``rec`` as it
    was when ``fr`` did not combine them."""
    contact = fr.held_measured.get("contact_time", {})
    if "held_at" not in contact:
        return rec
    m = dataclasses.replace(rec.measurement, contact_time_s=contact["held_at"], contact_time_sigma=contact["held_std"])
    return dataclasses.replace(rec, measurement=m)


def _cabin_alone(rec, veh, free, options, speed_mps, say):
    """The base model (its engine assumed, on its mounts) fitted to the cabin's channels
    alone, the engine's measured ones shown but not fitted, when the recording measured the
    engine (so the base model fits it as a second body) and has load cells to score both on;
    else None. Fitted with the recording's sigmas, as the two-body fit is
    (``identify.discover.loop.CANDIDATE_FIT``)."""
    from identify.discover.candidates import measured_effects
    from identify.discover.loop import fit_base

    m = rec.measurement
    if not measured_effects(m) or rec.sensor_test is None or not rec.sensor_test.barrier:
        return None
    engine = [c for c in m.channels if c.startswith("engine_") and c not in m.derived]
    cabin = dataclasses.replace(m, derived=(*m.derived, *engine))
    say("fitting the base model to the cabin alone (for the load-cell comparison)")
    return fit_base(cabin, veh, free=free, options=dataclasses.replace(options, misfit_weights=False),
                    speed_mps=speed_mps, progress=say)


def vehicle_label(name_or_path) -> str:
    """How messages name a vehicle: its name in ``data/vehicles/``, else its file's name."""
    p = Path(str(name_or_path))
    return p.stem if p.suffix == ".toml" else str(name_or_path)
