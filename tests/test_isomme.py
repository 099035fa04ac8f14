"""ISO-MME reader and writer, on a small ISO-MME dataset written from NHTSA test 10146."""

import re
from pathlib import Path

import numpy as np
import pytest

from identify.errors import UserError
from identify.recordings import measurement_from_test, read_isomme, read_nhtsa, write_isomme
from identify.recordings.isomme import is_barrier_force, is_vehicle_motion, parse_info

DATA = Path(__file__).resolve().parents[1] / "data" / "nhtsa-10146"


@pytest.fixture(scope="module")
def nhtsa():
    return read_nhtsa(DATA / "v10146.EV5")


@pytest.fixture()
def iso(nhtsa, tmp_path):
    return write_isomme(nhtsa, tmp_path / "10146", number="10146")


def _edit(path: Path, key: str, value: str):
    text = path.read_text(encoding="latin-1")
    new, n = re.subn(rf"(?m)^({re.escape(key)}\s*:).*$", rf"\g<1>{value}", text)
    assert n == 1
    path.write_text(new, encoding="latin-1")


def test_layout_written(iso):
    root = iso.parent
    assert iso.name == "10146.mme"
    assert sorted(p.name for p in (root / "Channel").iterdir()) == [
        "10146.001", "10146.002", "10146.003", "10146.004", "10146.005", "10146.006", "10146.chn"]
    info, _ = parse_info((root / "Channel" / "10146.chn").read_text().splitlines(), root)
    assert info["number of channels"] == "6"
    assert info["name of channel 001"].startswith("10SECMLERE00ACXP / LEFT REAR SEAT")
    assert info["name of channel 005"].startswith("B0LOMA000000FOXP")
    assert info["name of channel 006"].startswith("10ENGNTO0000ACXP / TOP OF ENGINE X")  # after the barrier


def test_round_trip_matches_the_nhtsa_reading(nhtsa, iso):
    back = read_isomme(iso.parent)  # the folder works as well as the .mme
    assert back.impact_speed_mps == pytest.approx(nhtsa.impact_speed_mps, abs=1e-4)
    assert back.mass_kg == pytest.approx(1719.0)
    assert len(back.vehicle) == 4 and len(back.barrier) == 1
    for a, b in zip(nhtsa.vehicle, back.vehicle):
        np.testing.assert_allclose(b.t, a.t, atol=1e-9)
        np.testing.assert_allclose(b.values, a.values, rtol=1e-5, atol=1e-4)
    m1 = measurement_from_test(nhtsa)
    m2 = measurement_from_test(back)
    np.testing.assert_allclose(m2.t, m1.t)
    np.testing.assert_allclose(m2.channels["x_m"], m1.channels["x_m"], atol=1e-5)
    np.testing.assert_allclose(m2.channels["vx_mps"], m1.channels["vx_mps"], atol=1e-4)


def test_parse_info_keeps_colons_in_values():
    info, end = parse_info(["Title                :crash at 12:30", "", "Unit :g", "1.5", "2.5"], Path("x"))
    assert info == {"title": "crash at 12:30", "unit": "g"}
    assert end == 3


@pytest.mark.parametrize("code,kind", [
    ("10VEHCCG0000ACXP", "cg"), ("10SECMLERE00ACXP", "crossmember"), ("10SEATRIRE00ACXA", "crossmember"),
    ("10SECMLERE00ACZP", None), ("20SECMLERE00ACXP", None), ("11HEAD0000H3ACXA", None),
    ("10SECMLEFR00ACXP", None), ("10VEHCCG00ACXP", None)])
def test_vehicle_motion_codes(code, kind):
    assert is_vehicle_motion(code) == kind


def test_barrier_codes():
    assert is_barrier_force("B0LOMA010100FOXP")
    assert not is_barrier_force("B0LOMA010100FOYP") and not is_barrier_force("10LOMA010100FOXP")


def test_cg_channel_is_preferred(iso):
    chn = iso.parent / "Channel" / "10146.chn"
    _edit(chn, "Name of channel 002", "10VEHCCG0000ACXP / VEHICLE CG X")
    t = read_isomme(iso)
    assert [c.code for c in t.vehicle] == ["10VEHCCG0000ACXP"]


def test_defect_channel_is_skipped(iso):
    _edit(iso.parent / "Channel" / "10146.001", "Data status", "defect")
    t = read_isomme(iso)
    assert len(t.vehicle) == 3
    assert any("channel 001" in n and "'defect'" in n for n in t.notes)


def test_compression_negative_file_is_turned_positive(iso):
    f = iso.parent / "Channel" / "10146.005"
    lines = f.read_text().splitlines()
    k = next(i for i, s in enumerate(lines) if ":" not in s)
    f.write_text("\n".join(lines[:k] + [f"{-float(s):.6g}" for s in lines[k:]]) + "\n")
    t = read_isomme(iso)
    assert t.barrier[0].values.max() > 6e5
    assert any("turned positive" in n for n in t.notes)


def test_units_are_converted(iso, nhtsa):
    f = iso.parent / "Channel" / "10146.005"
    lines = f.read_text().splitlines()
    k = next(i for i, s in enumerate(lines) if ":" not in s)
    f.write_text("\n".join(lines[:k] + [f"{float(s) / 1e3:.9g}" for s in lines[k:]]) + "\n")
    _edit(f, "Unit", "kN")
    t = read_isomme(iso)
    np.testing.assert_allclose(t.barrier[0].values, nhtsa.barrier[0].values, rtol=1e-5, atol=1e-2)


@pytest.mark.parametrize("value", ["1e300", "-2e5"])
def test_a_value_beyond_any_crash_is_a_damaged_file(iso, value, recwarn):
    # channel 001 is in g: 1e300 g overflows to inf on conversion, -2e5 g stays finite and
    # would overflow the motion's squares; both are one clear error, and numpy warns of nothing
    f = iso.parent / "Channel" / "10146.001"
    lines = f.read_text().splitlines()
    k = next(i for i, s in enumerate(lines) if ":" not in s) + 100
    f.write_text("\n".join(lines[:k] + [value] + lines[k + 1:]) + "\n")
    with pytest.raises(UserError, match=r"10146\.001: channel 001 .* reaches .* m/s\^2, beyond any crash recording's 1e\+05"):
        read_isomme(iso)
    assert not [w for w in recwarn if issubclass(w.category, RuntimeWarning)]


def test_missing_channel_file(iso):
    (iso.parent / "Channel" / "10146.003").unlink()
    with pytest.raises(UserError, match=r"missing channel file Channel/10146\.003 for channel 003"):
        read_isomme(iso)


def test_no_vehicle_channels(iso):
    chn = iso.parent / "Channel" / "10146.chn"
    for k in (1, 2, 3, 4):
        _edit(chn, f"Name of channel {k:03d}", f"11HEAD0000H3ACX{k} / HEAD")
    with pytest.raises(UserError, match="no vehicle X acceleration"):
        read_isomme(iso)


def test_mismatched_sample_rates(iso):
    _edit(iso.parent / "Channel" / "10146.002", "Sampling interval", "0.0002")
    t = read_isomme(iso)
    with pytest.raises(UserError, match="mismatched sample rates"):
        measurement_from_test(t)


def test_sample_count_disagrees_with_header(iso):
    _edit(iso.parent / "Channel" / "10146.004", "Number of samples", "3000")
    with pytest.raises(UserError, match="has 3500 samples, its header announces 3000"):
        read_isomme(iso)


def test_no_speed(iso):
    _edit(iso, "Velocity test object 1", "NOVALUE")
    with pytest.raises(UserError, match="Velocity test object 1"):
        read_isomme(iso)


def test_writer_never_overwrites(nhtsa, iso):
    with pytest.raises(UserError, match="exists already"):
        write_isomme(nhtsa, iso.parent)
    assert (iso.parent / "Channel" / "10146.001").exists()
    assert not any(p.name.startswith(".isomme-") for p in iso.parent.parent.iterdir())


def test_read_recording_dispatches_by_file_type(iso, tmp_path):
    from identify.recordings import is_recording, read_recording

    assert is_recording(iso) and is_recording(iso.parent) and is_recording(DATA / "v10146.EV5")
    frames = tmp_path / "frames"
    frames.mkdir()
    (frames / "0001.png").write_bytes(b"")
    assert not is_recording(frames)
    assert len(read_recording(iso.parent).vehicle) == 4
    assert read_recording(DATA / "v10146.EV5").vehicle[0].code == "93"
    with pytest.raises(UserError, match="not a sensor recording"):
        read_recording(frames)
