"""``identify simulate`` and ``identify vehicles``: outputs as docs/interface.md fixes them,
bad input as one line and exit 2."""

import csv

import pytest

from identify.cli import main


def test_simulate_writes_the_interface_columns(tmp_path, capsys):
    out = tmp_path / "run.csv"
    code = main(["simulate", "--vehicle", "audi_a4", "--params", "paper_identified", "--block-front-wheels",
                 "--duration-ms", "150", "--out", str(out)])  # fmt: skip
    assert code == 0
    rows = list(csv.DictReader(out.open()))
    assert len(rows) == 151
    for col in ("t_ms", "x_m", "z_m", "pitch_rad", "crush_m", "force_N", "front_wheel_blocked", "rear_wheel_airborne"):
        assert col in rows[0]
    blocked = [int(r["front_wheel_blocked"]) for r in rows]
    assert blocked[40] == 0 and blocked[60] == 1
    assert "front_wheel_block" in capsys.readouterr().err


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--vehicle", "nope", "--params", "paper_identified"], "unknown vehicle 'nope'"),
        (["--vehicle", "audi_a4", "--params", "nope"], "unknown parameter set 'nope'"),
        (["--vehicle", "audi_a4", "--params", "paper_identified", "--speed", "-5"], "--speed"),
        (["--vehicle", "audi_a4", "--params", "paper_identified", "--out", "/no/such/dir/x.csv"], "does not exist"),
    ],
)
def test_simulate_bad_input_is_one_line(argv, message, capsys):
    assert main(["simulate", *argv]) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and len(err.splitlines()) == 1 and "Traceback" not in err


def test_vehicles_lists_what_ships(capsys):
    assert main(["vehicles"]) == 0
    out = capsys.readouterr().out
    assert "audi_a4" in out and "toyota_camry_2018" in out and "1670 kg" in out
