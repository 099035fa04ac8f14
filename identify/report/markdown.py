"""The short human report of a fit (``report.md``), with the paper's Table 1 side by side."""

from __future__ import annotations

PARAMETER_ROWS = (
    ("k_compression", "body stiffness, compression phase", 1e-3, "kN/m^3"),
    ("k_restitution", "body stiffness, restitution phase", 1e-3, "kN/m^3"),
    ("restitution", "restitution coefficient", 1.0, ""),
    ("dz_contact", "lowering of the contact-force plane dz'", 1.0, "m"),
    ("mu_face", "friction of the crushed front on the barrier face", 1.0, ""),
)


# what a prior is, in the reader's units: the recording's measurements of the nuisances
MEASURED = {"impact_speed": ("impact speed", 3.6, "km/h"), "contact_time": ("first contact", 1e3, "ms"),
            "length_scale": ("the film's scale (its lengths over the true ones)", 1.0, "")}


def misfit_weights_sentence(widened: dict) -> str:
    """' Channels ... weighted by their own misfit (...)' for ``result.json``'s
    ``fit.sigma_widened_by_channel`` (channel -> the factor its sigma was multiplied by),
    '' when none was: which channels the model misses beyond their noise, and by how much
    less they counted in the fit than the tracker's sigmas say."""
    if not widened:
        return ""
    parts = ", ".join(f"{name} x{factor:.2g}" for name, factor in sorted(widened.items(), key=lambda kv: -kv[1]))
    return (f" Each channel was weighted by its own misfit, the model missing it beyond its noise: sigma {parts}"
            " (the channels the model follows decide what they measure).")


def model_choice_sentence(parameters: dict) -> str:
    """' ... moved ...' for the parameters whose ``model_choice_shift`` (result.json; how far
    the choice of model moved them: ``identify.discover.loop.with_model_choice``) counts in
    their std, '' when there is none."""
    moved = {n: p["model_choice_shift"] for n, p in parameters.items() if p.get("model_choice_shift")}
    if not moved:
        return ""
    parts = ", ".join(f"{n} by {v:.3g} {parameters[n].get('unit', '')}".rstrip() for n, v in moved.items())
    return (f" It also holds how far the choice of model moved each parameter ({parts}): the mechanisms discovery"
            f" added, against the base model's fit; the models discovery did not adopt that the recording does not"
            f" rule out (a candidate that fits better but failed a check, the unexplained force), weighted by how"
            f" well each fits; or a measured engine the cabin's motion does not bear out, against the base model on"
            f" the cabin alone. That choice is no measurement.")


def held_where(p: dict) -> str:
    """Where a held measurement (a ``priors`` entry with ``held``) was held: where the recording
    measured it (a film's scale), or where that and the fitted channels' estimate combined put
    it (the contact seen)."""
    measured = (p["held_at"], p["held_std"]) == (p["prior"], p["prior_std"])
    return "held where the recording measured it" if measured else "held at the two combined"


def prior_lines(priors: dict) -> list[str]:
    """One line per quantity known before the fit (``result.json``'s ``priors``): what was
    known, what the fit made of it and the pull (fitted - known) / sigma; the recording's
    own measurements (speed, contact) first, then the other priors (an engine's mass from
    the vehicle file). A measurement the fit held (the contact seen, a film's scale) is
    compared with where the fitted channels alone would put it."""
    out = []
    for name in sorted(priors, key=lambda n: (n not in MEASURED, n)):
        p = priors[name]
        label, scale, unit = MEASURED.get(name, (name, 1.0, p.get("unit", "")))
        u = f" {unit}" if unit else ""
        source = "measured" if name in MEASURED else "prior"
        flag = " **conflict: model and recording disagree**" if p["conflict"] else ""
        fitted = "the fitted channels alone" if p.get("held") else "fitted"
        held = f"; {held_where(p)}, {p['held_at'] * scale:.4g} +- {p['held_std'] * scale:.2g}{u}" if p.get("held") else ""
        if p.get("at_bound"):
            held = (f" **ran {p['at_bound']}: the channels alone cannot place it**; held where measured,"
                    f" {p['held_at'] * scale:.4g} +- {p['held_std'] * scale:.2g}{u}")
        out.append(f"{label}: {source} {p['prior'] * scale:.4g} +- {p['prior_std'] * scale:.2g}{u}, {fitted}"
                   f" {p['value'] * scale:.4g} +- {p['std'] * scale:.2g}{u} (pull {p['pull']:+.1f} sigma){held}{flag}")
    return out


def assumed_lines(assumed: list[dict]) -> list[str]:
    """One line per part of the base model assumed, not fitted (``result.json``'s
    ``fit.assumed``: the engine on its mounts), with its values."""
    out = []
    for a in assumed:
        values = ", ".join(f"{n} {_fmt(p['value'], 1.0, 3)} {p['unit']}" for n, p in a["parameters"].items())
        out.append(f"Assumed, not fitted (`{a['effect']}`): {a['explanation']} ({values})")
    return out


def window_words(entry: dict) -> str:
    """The window of an effect the model shows (result.json ``shown_by_model``), in words:
    "47-120 ms", or "from 47 ms to the end of the recording (298 ms)"."""
    start, end = entry["window_ms"]
    if entry.get("to_end"):
        return f"from {start:.0f} ms to the end of the recording ({end:.0f} ms)"
    return f"{start:.0f}-{end:.0f} ms"


def discovery_values(d: dict) -> str:
    """A discovery's fitted parameters in one line, as the report and the console give them:
    "name value +- std unit, ..." (no "+-" where a parameter has no std)."""
    return ", ".join(f"{k} {_fmt(v['value'], 1.0, 4)}" + (f" +- {_fmt(v['std'], 1.0, 2)}" if v.get("std") is not None else "")
                     + f" {v['unit']}" for k, v in (d.get("parameters") or {}).items() if isinstance(v, dict) and "value" in v)


def _fmt(value, scale, digits=3):
    if value is None:
        return "-"
    v = value * scale
    return f"{v:.{digits}g}" if abs(v) < 1e4 else f"{v:.0f}"


def render_report(doc: dict, defaults: dict, figures: list[str]) -> str:
    """Return report.md's text.

    Parameters
    ----------
    doc : the result.json document.
    defaults : V-SIM default values by parameter name (the left column of Table 1).
    figures : file names of the PNGs in the results folder, in reading order.
    """
    fitinfo = doc["fit"]
    starts = f"{fitinfo['starts_at_best']} of {fitinfo['starts']} starting points reached the best fit"
    if fitinfo.get("starts_of") and fitinfo.get("model", "base") != "base":
        starts += f" of the {fitinfo['starts_of']}; the discovered effects were fitted from it"
    lines = [
        f"# Identification: {doc['vehicle_name']}",
        "",
    ]
    for warning in doc.get("warnings") or []:
        lines += [f"> **Warning:** {warning}", ""]
    lines += [
        f"Recording `{doc['recording']}` ({doc['recording_kind']}), impact speed"
        f" {doc['impact_speed_kmh']:.2f} km/h, model `{fitinfo['model']}`.",
        f"Fit: RMS {1e3 * fitinfo['rms_m']:.2f} mm in x, reduced chi-square {fitinfo['reduced_chi2']:.2f}"
        f" ({starts}).{misfit_weights_sentence(fitinfo.get('sigma_widened_by_channel') or {})}",
        *assumed_lines(fitinfo.get("assumed") or []),
        "",
        "## Parameters (the paper's Table 1, side by side)",
        "",
        "| parameter | V-SIM default | identified | std | std of the data alone | |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    for name, label, scale, unit in PARAMETER_ROWS:
        p = doc["parameters"].get(name)
        if p is None:
            continue
        u = f" {unit}" if unit else ""
        status = f"**{p['reason']}**" if not p.get("identified", True) else p.get("note", "")
        lines.append(
            f"| {label} | {_fmt(defaults.get(name), scale)}{u} | {_fmt(p['value'], scale, 4)}{u} |"
            f" {_fmt(p.get('std'), scale, 2)}{u} | {_fmt(p.get('std_data'), scale, 2)}{u} | {status} |"
        )
    lines += ["", "The std adds to the data's the model's own error (`identify/fitting/model_error.py`):"
              " how far the model's simplifications moved each parameter on recordings it did not make."
              + model_choice_sentence(doc["parameters"])]
    known = prior_lines(doc.get("priors") or {})
    if known:
        lines += ["", "## What was known before the fit", ""] + [f"- {k}" for k in known]
    lines += ["", "Strongest correlations between fitted parameters:", ""]
    corr = doc.get("correlation", {})
    names = corr.get("names", [])
    pairs = sorted(
        ((abs(corr["matrix"][i][j]), names[i], names[j], corr["matrix"][i][j])
         for i in range(len(names)) for j in range(i + 1, len(names))),
        reverse=True,
    )[:3]  # fmt: skip
    lines += [f"- {a} / {b}: {r:+.2f}" for _, a, b, r in pairs] or ["- (none)"]
    lines += ["", "## Fit quality by channel", "", "| channel | RMS residual |", "| --- | --- |"]
    lines += [f"| {k} | {v:.4g} |" for k, v in fitinfo["rms_by_channel"].items()]
    events = doc.get("events_ms") or {}
    model_events = doc.get("model_events_ms") or {}
    if events or model_events:
        lines += ["", "## Events (ms after first contact)", "", "| event | recording | fitted model |", "| --- | --- | --- |"]
        for key in sorted(set(events) | set(model_events)):
            rec, mod = events.get(key), model_events.get(key)
            lines.append(f"| {key} | {_fmt(rec, 1.0, 4)} | {_fmt(mod, 1.0, 4)} |")
    lines += ["", "## Missing physics", ""]
    lines.append(doc.get("discovery_status", "nothing discovered"))
    for d in doc.get("discoveries") or []:
        fitted = discovery_values(d)
        lines += ["", f"- **{d['effect']}** ({d['window_ms'][0]:.0f}-{d['window_ms'][1]:.0f} ms"
                  + (f", {d['phase']}" if d.get("phase") else "") + f"): {d['explanation']}"]
        if fitted:
            lines.append(f"  {fitted}")
        lines.append(f"  x RMS {d['rms_before_m'] * 1e3:.2f} -> {d['rms_after_m'] * 1e3:.2f} mm")
        if d.get("evidence"):
            lines.append(f"  Evidence: {d['evidence']}")
    for e in doc.get("shown_by_model") or []:
        lines += ["", f"- **{e['effect']}**, shown by the base model itself (no mechanism added), {window_words(e)}:"
                  f" {e['explanation']}"]
        if e.get("evidence"):
            lines.append(("  Contradicted by the recording: " if e.get("contradicted") else "  Evidence: ") + e["evidence"])
    check = doc.get("force_check")
    if check:
        lines += _force_check_lines(check, doc)
    if doc.get("notes"):
        lines += ["", "## Notes", ""] + [f"- {n}" for n in doc["notes"]]
    lines += ["", "## Figures", ""] + [f"![{f}]({f})" for f in figures]
    return "\n".join(lines) + "\n"


def _force_check_lines(check: dict, doc: dict) -> list[str]:
    """The report's section on the barrier load cells (``doc["force_check"]``): the measured
    force, then each prediction scored against it (the fitted model, the base model before
    discovery, a rigid car moving exactly as measured), then the recording's own consistency."""
    model = doc["fit"]["model"]
    lines = [
        "",
        "## Barrier load cells vs the fitted model (an independent check: the fit saw only the motion)",
        "",
        f"Measured: peak {check['peak_measured_N'] / 1e3:.0f} kN at {check['peak_time_measured_ms']:.0f} ms,"
        f" impulse {check['impulse_measured_Ns'] / 1e3:.2f} kN s (CFC {check['cfc']}).",
        "",
        "| force | peak | peak error | impulse error | RMS error / peak | ISO 18571 (1 = identical) |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    rows = [(f"fitted model (`{model}`)", check)]
    if "base_model" in check:
        rows.append((check["base_model"].get("label", "base model, before discovery"), check["base_model"]))
    if "rigid_body" in check:
        rows.append(("a rigid car moving exactly as measured (test mass x measured deceleration)", check["rigid_body"]))
    two = check.get("two_body", {})
    if "nrmse" in two:
        rows.append((f"a cabin and an engine moving exactly as measured (engine {two['engine_mass_kg']:.0f} kg,"
                     f" {two['engine_mass_source']})", two))
    for label, c in rows:
        lines.append(f"| {label} | {c['peak_predicted_N'] / 1e3:.0f} kN at {c['peak_time_predicted_ms']:.0f} ms |"
                     f" {100 * c['peak_error']:+.1f} % | {100 * c['impulse_error']:+.1f} % |"
                     f" {100 * c['nrmse']:.1f} % |"
                     f" {c['iso18571']['overall']:.3f} |")
    lines.append("")
    turn = (doc.get("model_events_ms") or {}).get("compression_end")
    k_r = doc["parameters"].get("k_restitution", {})
    if turn is not None and abs(check["peak_time_predicted_ms"] - turn) < 3.0 and not k_r.get("identified", True):
        lines.append(f"- the fitted model's peak is where its force jumps from the loading curve to the unloading"
                     f" line ({turn:.0f} ms); the jump's height depends on k_restitution, which this recording"
                     " does not identify: its peak error says little")
    two_body = "engine_impact" in model
    if "rigid_body" in check and not two_body:
        lines.append("- a model whose engine never reaches the barrier gives a force close to its mass times its"
                     " cabin's deceleration (the engine rides on its mounts), so a model that fits the"
                     " motion better moves its force towards the rigid car's row: what separates that row from the"
                     " load cells is the car's own deformation (its engine and cabin stop at different times),"
                     " not the force law")
    if two_body:
        lines.append("- the fitted model has two bodies, the cabin and the engine (`engine_impact`): its barrier force"
                     " is the structure's plus the engine block's, which a one-body model's (its mass times the"
                     " cabin's deceleration) cannot be; force vs crush shows each body's own curve")
    if "nrmse" in two:
        fitted = doc["parameters"].get("engine_impact.engine_mass")
        fitted = (f" (the fit, from the motion alone: {fitted['value']:.0f} +- {fitted['std']:.0f} kg)"
                  if fitted and fitted.get("std") is not None else "")
        lines.append(f"- a model of a cabin and an engine that fits both measured motions exactly predicts the"
                     f" two-body row's curve for its engine mass; the engine mass that brings that curve nearest"
                     f" the load cells is {two['best_engine_mass_kg']:.0f} kg{fitted}, and even then its RMS"
                     f" error is {100 * two['best_nrmse']:.1f} % of the peak: no two-body model fitting the"
                     f" motion comes nearer")
    elif "not_computed" in two:
        lines.append(f"- no two-body reference: {two['not_computed']}")
    if "momentum_check" in check:
        mc = check["momentum_check"]
        each = mc.get("per_accelerometer", {})
        spread = (f" (each accelerometer alone: {100 * min(each.values()):+.1f} to"
                  f" {100 * max(each.values()):+.1f} %)" if len(each) > 1 else "")
        lines.append(f"- the recording's own consistency: barrier impulse vs m * change of velocity"
                     f" {100 * mc['error']:+.1f} %{spread}")
    return lines
