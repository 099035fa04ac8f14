"""Property-based tests: whatever bytes a vehicle file, an EV5 test or an ISO-MME test holds,
reading it either works or ends in the one-line error the command line prints (UserError,
ConfigError), never in another exception (a traceback)."""

import tempfile
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("hypothesis")  # the `test` extra's; skipped, not an import error, where missing
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from identify.errors import UserError  # noqa: E402
from identify.recordings import measurement_from_test, read_isomme, read_nhtsa
from sim.errors import ConfigError
from sim.vehicle import VEHICLE_DIR, load_vehicle, vehicle_from_dict

SETTINGS = settings(max_examples=150, deadline=None, database=None,  # no .hypothesis/ folder in the project
                    suppress_health_check=[HealthCheck.too_slow])
EXPECTED = (UserError, ConfigError)

# text that looks like what these files hold, and what they should not
TOKENS = st.one_of(
    st.sampled_from(["", "0", "-1", "1e308", "nan", "inf", "-inf", "1e-300", "NOVALUE", "ok", "defect", "AM", "CF",
                     "G'S", "NWT", "g", "N", "kN", "|", ":", "/", "-----", "[", "]", "[1, 2]", '"x"', "true",
                     "99999999999999999999", "0x10", "1_000", "9" * 300, "1" * 5000, "\x00", "\xff", "é", "\t", "3.5", "  "]),
    st.text(max_size=12),
)


def _run(read, *args):
    try:
        out = read(*args)
    except EXPECTED:
        return None
    return out


def _motion(test):
    """The fit's next step after reading: it too must fail only with one line."""
    if test is not None:
        _run(measurement_from_test, test)


# ------------------------------------------------------------------ vehicle files

A4 = (VEHICLE_DIR / "audi_a4.toml").read_text()


@SETTINGS
@given(st.binary(max_size=600))
def test_vehicle_file_of_any_bytes(data):
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "car.toml"
        p.write_bytes(data)
        _run(load_vehicle, p)


@SETTINGS
@given(st.data())
def test_vehicle_file_with_a_line_changed(data):
    lines = A4.splitlines()
    i = data.draw(st.integers(0, len(lines) - 1))
    key = lines[i].split("=")[0].strip() if "=" in lines[i] else "x"
    how = data.draw(st.sampled_from(["value", "line", "bytes"]))
    if how == "value":
        lines[i] = f"{key} = {data.draw(TOKENS)}"
    elif how == "line":
        lines[i] = data.draw(TOKENS)
    text = "\n".join(lines).encode("utf-8", "surrogatepass") if how != "bytes" else None
    if how == "bytes":
        text = "\n".join(lines).encode() + data.draw(st.binary(max_size=40))
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "car.toml"
        p.write_bytes(text)
        _run(load_vehicle, p)


VALUES = st.recursive(
    st.one_of(st.none(), st.booleans(), st.integers(-10**30, 10**30), st.floats(allow_nan=True), st.text(max_size=5)),
    lambda inner: st.lists(inner, max_size=4),
    max_leaves=12,
)


@SETTINGS
@given(st.dictionaries(st.sampled_from(["mass", "length", "width", "height", "wheelbase", "front_overhang",
                                         "cg_height", "cg_to_front_axle", "pitch_inertia", "wheel_radius",
                                         "contact_area", "axle_stiffness", "axle_damping", "silhouette_side",
                                         "windscreen_top", "name"]), VALUES))
def test_vehicle_fields_of_any_type(fields):
    import tomllib

    base = tomllib.loads(A4)
    base.update(fields)
    _run(vehicle_from_dict, base, "car", "car.toml")


# ------------------------------------------------------------------ NHTSA EV5


def _ev5(n=1200, first=-100, rows=None):
    row = f"1|93|AC|NA|FLLR|XG|SEC|G'S|2800|MFG|12/APR/2017|800|21|57.09|{first}|{first + n - 1}|100|AM|P|LEFT REAR SEAT CROSSMEMBER X"
    cell = f"0|900|LC|NA|LCSUM|XG|SEC|NWT|2800|SUM|03/OCT/2017|300000|0|0.0|{first}|{first + n - 1}|100|AM|P|BARRIER SUM"
    header = ["----- EV5 -----", "----- TEST -----",
              "V5|TITLE|X|03/OCT/2017|MGA|X|X|NCA|VTB|CON|DRY|22|OTH|OTH|57.09|0|0|0|634|DAS",
              "----- VEHICLE -----", "1|16|03|2018|M|4S|VIN|4CIF|2.5|AF|1719" + "|0" * 30 + "|57.09",
              "----- INSTRUMENTATION -----", *(rows or [row, cell]), "----- END -----"]
    t = (first + np.arange(n)) * 1e-4
    acc = np.where(t > 0, -20.0 * np.sin(np.clip(t, 0, 0.1) * np.pi / 0.1), 0.0)
    channel = [f"{a:.6f}\t{b:.6f}" for a, b in zip(t, acc)]
    force = [f"{a:.6f}\t{-2e5 * max(0.0, -b) / 20:.3f}" for a, b in zip(t, acc)]
    return header, channel, force


def _write_ev5(d: Path, header, channel, force, raw=None):
    (d / "v1.EV5").write_bytes(raw if raw is not None else "\n".join(header).encode("latin-1", "replace"))
    (d / "v1.093").write_bytes("\n".join(channel).encode("latin-1", "replace"))
    (d / "v1.900").write_bytes("\n".join(force).encode("latin-1", "replace"))
    return d / "v1.EV5"


def test_the_small_ev5_reads():
    with tempfile.TemporaryDirectory() as d:
        test = read_nhtsa(_write_ev5(Path(d), *_ev5()))
        assert len(test.vehicle) == 1 and len(test.barrier) == 1


@SETTINGS
@given(st.binary(max_size=800))
def test_ev5_header_of_any_bytes(data):
    with tempfile.TemporaryDirectory() as d:
        h, c, f = _ev5()
        _motion(_run(read_nhtsa, _write_ev5(Path(d), h, c, f, raw=data)))


@SETTINGS
@given(st.data())
def test_ev5_with_a_field_or_line_changed(data):
    header, channel, force = _ev5(n=data.draw(st.sampled_from([1, 2, 30, 1200])), first=data.draw(st.sampled_from([-100, -3, 0])))
    which = data.draw(st.sampled_from(["header_field", "header_line", "channel_line", "channel_bytes"]))
    if which == "header_field":
        i = data.draw(st.integers(0, len(header) - 1))
        fields = header[i].split("|")
        j = data.draw(st.integers(0, len(fields) - 1))
        fields[j] = data.draw(TOKENS)
        header[i] = "|".join(fields)
    elif which == "header_line":
        i = data.draw(st.integers(0, len(header) - 1))
        header[i] = data.draw(TOKENS)
    elif which == "channel_line":
        i = data.draw(st.integers(0, len(channel) - 1))
        channel[i] = data.draw(TOKENS) + data.draw(st.sampled_from(["", "\t1", "\t", " 2 3"]))
    with tempfile.TemporaryDirectory() as d:
        path = _write_ev5(Path(d), header, channel, force)
        if which == "channel_bytes":
            (Path(d) / "v1.093").write_bytes(data.draw(st.binary(max_size=300)))
        _motion(_run(read_nhtsa, path))


# ------------------------------------------------------------------ ISO-MME


def _iso(n=1200):
    mme = ["Data format edition number  :1.6", "Laboratory test ref. number :T1", "Title                       :x",
           "Velocity test object 1      :15.86", "Mass test object 1          :1719"]
    chn = ["Number of channels          :2", "Name of channel 001         :10SECMLERE00ACXP / LEFT",
           "Name of channel 002         :B0LOMA000000FOXP / BARRIER"]
    t0 = -0.01
    acc = [f"{-20.0 * np.sin(min(max(t0 + k * 1e-4, 0), 0.1) * np.pi / 0.1):.6f}" for k in range(n)]
    force = [f"{2e5 * np.sin(min(max(t0 + k * 1e-4, 0), 0.1) * np.pi / 0.1):.3f}" for k in range(n)]

    def head(name, code, unit):
        return [f"Name of the channel         :{name}", f"Channel code                :{code}",
                f"Unit                        :{unit}", "Data status                 :ok",
                f"Time of first sample        :{t0}", "Sampling interval           :0.0001",
                f"Number of samples           :{n}"]

    return {"T1.mme": mme, "Channel/T1.chn": chn,
            "Channel/T1.001": head("LEFT", "10SECMLERE00ACXP", "g") + acc,
            "Channel/T1.002": head("BARRIER", "B0LOMA000000FOXP", "N") + force}


def _write_iso(d: Path, files, raw=None):
    (d / "Channel").mkdir(exist_ok=True)
    for name, lines in files.items():
        data = raw[name] if raw and name in raw else "\n".join(lines).encode("latin-1", "replace")
        (d / name).write_bytes(data)
    return d / "T1.mme"


def test_the_small_isomme_reads():
    with tempfile.TemporaryDirectory() as d:
        test = read_isomme(_write_iso(Path(d), _iso()))
        assert len(test.vehicle) == 1 and len(test.barrier) == 1
        measurement_from_test(test)


@SETTINGS
@given(st.sampled_from(["T1.mme", "Channel/T1.chn", "Channel/T1.001", "Channel/T1.002"]), st.binary(max_size=500))
def test_isomme_file_of_any_bytes(name, data):
    with tempfile.TemporaryDirectory() as d:
        _motion(_run(read_isomme, _write_iso(Path(d), _iso(), raw={name: data})))


@SETTINGS
@given(st.data())
def test_isomme_with_a_line_changed(data):
    files = _iso(n=data.draw(st.sampled_from([1, 2, 30, 1200])))
    name = data.draw(st.sampled_from(sorted(files)))
    lines = files[name]
    i = data.draw(st.integers(0, len(lines) - 1))
    if data.draw(st.booleans()) and ":" in lines[i]:
        lines[i] = lines[i].split(":", 1)[0] + ":" + data.draw(TOKENS)
    else:
        lines[i] = data.draw(TOKENS)
    with tempfile.TemporaryDirectory() as d:
        _motion(_run(read_isomme, _write_iso(Path(d), files)))


# ------------------------------------------------------------------ tracks.csv


@SETTINGS
@given(st.data())
def test_tracks_csv_with_a_line_changed(data):
    from identify.recordings.measurement import measurement_from_tracks_csv

    lines = ["t_ms,x_m,x_sigma_m,pitch_rad"] + [f"{t},{0.01 * t:.4f},0.001,0.0" for t in range(-5, 20)]
    i = data.draw(st.integers(0, len(lines) - 1))
    lines[i] = data.draw(st.sampled_from([data.draw(TOKENS), ",".join(data.draw(st.lists(TOKENS, max_size=6)))]))
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "tracks.csv"
        p.write_bytes("\n".join(lines).encode("utf-8", "replace") + data.draw(st.binary(max_size=8)))
        _run(measurement_from_tracks_csv, p)
