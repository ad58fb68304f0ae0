"""rbenv.agents.flight.telemetry: the dashboard's CSV format, read back from files these tests write
(the flight data has no license, so none of it is in the repository)."""

from __future__ import annotations

from datetime import datetime

import numpy as np
import pytest
from rbenv.agents.flight.telemetry import (
    Telemetry,
    TelemetryError,
    error_angle_deg,
    find_folders,
    load,
    load_folder,
    sub_maneuvers,
    write_folder,
)

START = datetime(2025, 12, 15, 21, 50, 8)


def quaternion(angle_deg, axis=(0.0, 0.0, 1.0)):
    half = np.radians(np.asarray(angle_deg, float)) / 2.0
    return np.column_stack([np.cos(half), *(np.sin(half) * a for a in axis)])


def two_slews(n1=20, n2=15) -> Telemetry:
    """A slew from 100° decaying, a target switch to 120°, and a second slew; 2 s samples."""
    t = 2.0 * np.arange(n1 + n2)
    angle = np.concatenate([100.0 * np.exp(-t[:n1] / 10.0), 120.0 * np.exp(-t[:n2] / 10.0)])
    rate = np.column_stack([0.01 * np.ones_like(t), -0.02 * np.ones_like(t), -angle / 10.0])
    wheel = np.column_stack([t, -t, 3 * t])
    cmd = np.zeros((len(t), 3))
    cmd[3:] = [1.5, -100.0, 12.25]
    return Telemetry(folder=None, start_utc=START, time_s=t, q=quaternion(angle),
                     rate_dps=rate, wheel_rpm=wheel, command_rpm_s=cmd)


def files(folder):
    return {p.name.split("-data")[0]: p for p in folder.glob("*.csv")}


def test_a_written_folder_reads_back_on_the_grid_with_units_stripped(tmp_path):
    tm = two_slews()
    write_folder(tmp_path / "15.12.2025 21.50-22.05", tm)
    back = load_folder(tmp_path / "15.12.2025 21.50-22.05")
    assert back.start_utc == START
    np.testing.assert_array_equal(back.time_s, tm.time_s)
    np.testing.assert_allclose(back.q, tm.q, rtol=5e-3, atol=1e-12)  # 3 significant digits
    np.testing.assert_allclose(back.rate_dps, tm.rate_dps, rtol=5e-3)
    np.testing.assert_allclose(back.wheel_rpm, tm.wheel_rpm, rtol=5e-3)
    assert back.command_rpm_s[5].tolist() == [1.5, -100.0, 12.2]  # "12.2 RPM/s" (3 digits)
    assert back.dropped == 0
    raw = files(tmp_path / "15.12.2025 21.50-22.05")["Rates"].read_bytes()
    assert raw.startswith(b"\xef\xbb\xbf\"Time\"") or raw.startswith(b"\xef\xbb\xbfTime")
    assert b"\r\n" in raw and "°/s".encode() in raw


def test_sub_maneuvers_are_cut_at_the_target_switch(tmp_path):
    parts = sub_maneuvers(two_slews(20, 15))
    assert [(p.index, p.t0, len(p.time_s)) for p in parts] == [(0, 0.0, 20), (1, 40.0, 15)]
    assert parts[1].time_s[0] == 0.0 and parts[1].duration_s == 28.0
    assert parts[1].error_deg[0] == pytest.approx(120.0)
    assert not parts[0].commanded_before and parts[1].commanded_before


def test_a_fast_turn_is_not_a_switch():
    """The error rising by what the body rate turns (a tumbling start) is one maneuver."""
    t = 2.0 * np.arange(8)
    angle = 10.0 + 12.0 * t  # 12 °/s away from the target, 24° per sample, to 178°
    zeros = np.zeros((8, 3))
    tm = Telemetry(None, START, t, quaternion(angle), np.tile([0.0, 0.0, 12.0], (8, 1)),
                   zeros, zeros)
    assert len(sub_maneuvers(tm)) == 1
    still = Telemetry(None, START, t, quaternion(angle), zeros, zeros, zeros)
    assert len(sub_maneuvers(still)) == 8  # the same rise with no rate: every step a switch


def test_error_angle_is_the_rotation_angle_either_sign():
    q = quaternion([0.0, 90.0, 179.0])
    np.testing.assert_allclose(error_angle_deg(q), [0.0, 90.0, 179.0], atol=1e-9)
    np.testing.assert_allclose(error_angle_deg(-q), [0.0, 90.0, 179.0], atol=1e-9)
    np.testing.assert_allclose(error_angle_deg(2.0 * q), [0.0, 90.0, 179.0], atol=1e-9)


def live_rows(folder, rows):
    """Rewrite every file of ``folder`` with the data rows ``rows(lines) -> lines``."""
    for path in files(folder).values():
        text = path.read_bytes().decode("utf-8-sig").split("\r\n")
        header, body = text[0], [line for line in text[1:] if line]
        path.write_text("\r\n".join([header, *rows(body)]) + "\r\n", encoding="utf-8-sig")


def test_live_telemetry_repeats_and_jitter_go_back_to_the_2s_grid(tmp_path):
    tm = two_slews()
    write_folder(tmp_path / "live", tm)

    def jitter(lines):
        out = []
        for i, line in enumerate(lines):
            stamp, rest = line.split(",", 1)
            t = datetime.strptime(stamp, "%Y-%m-%d %H:%M:%S")
            shift = {3: 1, 4: -1, 7: 1, 8: 1, 11: -1}.get(i, 0)  # ±1 s, two stamps meeting
            t = t.replace(second=t.second + shift) if 0 <= t.second + shift < 60 else t
            out.append(f"{t:%Y-%m-%d %H:%M:%S},{rest}")
            if i in (5, 9):
                out.append(out[-1])  # a repeated row
        return out

    live_rows(tmp_path / "live", jitter)
    back = load_folder(tmp_path / "live")
    np.testing.assert_array_equal(back.time_s, tm.time_s)
    np.testing.assert_allclose(back.rate_dps, tm.rate_dps, rtol=5e-3)
    assert back.dropped == 2 * 4


def test_fractional_seconds_and_gaps(tmp_path):
    tm = two_slews()
    keep = np.r_[0:5, 8:len(tm.time_s)]  # a 8 s gap, as offline telemetry has
    gap = Telemetry(None, START, tm.time_s[keep], tm.q[keep], tm.rate_dps[keep],
                    tm.wheel_rpm[keep], tm.command_rpm_s[keep])
    write_folder(tmp_path / "f", gap)
    live_rows(tmp_path / "f", lambda lines: [line.replace(",", ".655,", 1) for line in lines])
    back = load_folder(tmp_path / "f")
    np.testing.assert_array_equal(back.time_s, gap.time_s)


def test_folders_are_found_recursively_with_spaces_in_names(tmp_path):
    for name in ("pd/15.12.2025 21.50-22.05", "pd/15.12.2025 22.30-22.48", "agent/a b"):
        write_folder(tmp_path / name, two_slews(), stamp="2025-12-20 12_11_53")
    (tmp_path / "notes").mkdir()
    (tmp_path / "notes" / "Rates only.csv").write_text("x")
    found = find_folders(tmp_path)
    assert [f.relative_to(tmp_path).as_posix() for f in found] == [
        "agent/a b", "pd/15.12.2025 21.50-22.05", "pd/15.12.2025 22.30-22.48"]
    assert len(load(tmp_path / "pd")) == 4  # two folders, two slews each


def test_an_empty_or_missing_folder_is_a_named_error(tmp_path):
    with pytest.raises(TelemetryError, match="no maneuver folder"):
        find_folders(tmp_path)
    with pytest.raises(TelemetryError, match="is not a folder"):
        find_folders(tmp_path / "nowhere")
    write_folder(tmp_path / "m", two_slews())
    files(tmp_path / "m")["RW CMDs"].unlink()
    with pytest.raises(TelemetryError, match=r"exactly one file whose name starts with 'RW CMDs'"):
        load_folder(tmp_path / "m")


def break_cell(folder, kind, row, column, text):
    """Replace the cell (row: 1 the header; column index) of one file."""
    path = files(folder)[kind]
    lines = path.read_bytes().decode("utf-8-sig").split("\r\n")
    cells = lines[row - 1].split(",")
    cells[column] = text
    lines[row - 1] = ",".join(cells)
    path.write_text("\r\n".join(lines), encoding="utf-8-sig")
    return path.name


@pytest.mark.parametrize("kind, row, column, text, message", [
    ("Rates", 4, 2, "0.5 rpm", r"row 4, column 'Y': '0.5 rpm' must carry the unit '°/s', "
                               r"got 'rpm'"),
    ("RW Speeds", 7, 3, "12", r"row 7, column 'Z': '12' must carry the unit 'rpm', got 'none'"),
    ("Attitude quaternion", 5, 1, "0.5 °/s", r"row 5, column 'q0'.*unit 'none'"),
    ("RW CMDs", 3, 1, "abc RPM/s", r"row 3, column 'X': 'abc RPM/s' is not a finite number"),
    ("RW CMDs", 3, 1, "nan RPM/s", r"row 3, column 'X': 'nan RPM/s' is not a finite number"),
    ("Rates", 6, 0, "15.12.2025 21:50", r"row 6, column 'Time': '15.12.2025 21:50' is not a "
                                        r"time"),
    ("Rates", 1, 2, '"Q"', r"row 1 \(the header\) must be \['Time', 'X', 'Y', 'Z'\]"),
])
def test_a_broken_cell_names_file_row_and_column(tmp_path, kind, row, column, text, message):
    write_folder(tmp_path / "m", two_slews())
    name = break_cell(tmp_path / "m", kind, row, column, text)
    with pytest.raises(TelemetryError, match=message) as err:
        load_folder(tmp_path / "m")
    assert name in str(err.value)


def test_a_short_row_or_time_going_back_is_a_named_error(tmp_path):
    write_folder(tmp_path / "m", two_slews())
    path = files(tmp_path / "m")["RW Speeds"]
    lines = path.read_bytes().decode("utf-8-sig").split("\r\n")
    lines[4] = lines[4].rsplit(",", 1)[0]
    path.write_text("\r\n".join(lines), encoding="utf-8-sig")
    with pytest.raises(TelemetryError, match=r"RW Speeds.*row 5 has 3 cells, the header 4"):
        load_folder(tmp_path / "m")
    write_folder(tmp_path / "n", two_slews())
    break_cell(tmp_path / "n", "Rates", 8, 0, "2025-12-15 21:50:00")
    with pytest.raises(TelemetryError, match=r"Rates.*row 8, column 'Time'.*before the "
                                             r"previous row"):
        load_folder(tmp_path / "n")


def test_a_file_that_is_not_text_is_a_named_error(tmp_path):
    write_folder(tmp_path / "m", two_slews())
    files(tmp_path / "m")["Rates"].write_bytes(b"\xff\xfe\x00binary")
    with pytest.raises(TelemetryError, match=r"Rates.*not UTF-8 text"):
        load_folder(tmp_path / "m")
