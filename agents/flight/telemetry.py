"""Attitude telemetry of a flown satellite, in the CSV export of the InnoCube mission's dashboard.

A maneuver folder holds four CSV files, one per quantity, each named for what it holds (the
name goes on with an export time stamp, spaces included)::

    Attitude quaternion...csv   Time, q0, q1, q2, q3   target-relative, scalar first, unitless
    Rates...csv                 Time, X, Y, Z          body rate, cells like "4.65 °/s"
    RW Speeds...csv             Time, X, Y, Z          wheel speed, cells like "-140 rpm"
    RW CMDs...csv               Time, X, Y, Z          commanded wheel acceleration, "15.8 RPM/s"

Time is UTC (``YYYY-MM-DD HH:MM:SS``, fractional seconds allowed), nominally every 2 s. Live
telemetry repeats rows and jitters the stamps by up to ±1 s; :func:`load_folder` drops the
repeated rows and puts every sample back on the 2 s grid, keeping the grid points that all four
files have. :func:`sub_maneuvers` cuts a folder where the target switches (the attitude error
jumps), so that each piece is one slew and hold from a logged start.

The quaternion is Hamilton, scalar first, body → target, as rbenv's ``q`` with the target as
reference. A file that breaks the format raises :class:`TelemetryError` naming the file, the row
(1 = the header) and the column.
"""

from __future__ import annotations

import csv
import itertools
import math
from dataclasses import dataclass
from datetime import datetime, timedelta
from pathlib import Path

import numpy as np
from rbenv.core.errors import RbenvValueError

__all__ = [
    "FILES",
    "SubManeuver",
    "Telemetry",
    "TelemetryError",
    "find_folders",
    "load",
    "load_folder",
    "sub_maneuvers",
    "write_folder",
]

GRID_S = 2.0  # s, the nominal sample period
# File-name prefix -> (field of Telemetry, column names after Time, unit in the cells).
FILES = {
    "Attitude quaternion": ("q", ("q0", "q1", "q2", "q3"), ""),
    "Rates": ("rate_dps", ("X", "Y", "Z"), "°/s"),
    "RW Speeds": ("wheel_rpm", ("X", "Y", "Z"), "rpm"),
    "RW CMDs": ("command_rpm_s", ("X", "Y", "Z"), "RPM/s"),
}
SWITCH_JUMP_DEG = 20.0  # a rise of the error beyond what the body rate explains: a new target
MAX_FILE_BYTES = 50_000_000


class TelemetryError(RbenvValueError):
    """A telemetry folder or file breaks the format (names the file, row and column)."""


@dataclass(frozen=True)
class Telemetry:
    """One maneuver folder on the 2 s grid: N samples, each array's first axis.

    time_s (N,): s since ``start_utc``, multiples of 2; q (N, 4) logged target-relative attitude
    (as logged, 3 digits, not renormalized); rate_dps (N, 3) body rate, deg/s; wheel_rpm (N, 3)
    wheel speed, rpm; command_rpm_s (N, 3) commanded wheel acceleration, RPM/s.
    dropped: rows left out (repeats, and grid points not in all four files).
    """

    folder: Path
    start_utc: datetime
    time_s: np.ndarray
    q: np.ndarray
    rate_dps: np.ndarray
    wheel_rpm: np.ndarray
    command_rpm_s: np.ndarray
    dropped: int = 0

    @property
    def error_deg(self) -> np.ndarray:
        """(N,) attitude error, deg: the rotation angle of the logged quaternion."""
        return error_angle_deg(self.q)


@dataclass(frozen=True)
class SubManeuver:
    """One slew and hold toward one target: the samples of a folder between target switches.

    t0: s since the folder's start; time_s (M,) s since t0 (time_s[0] == 0); the arrays as in
    :class:`Telemetry`. commanded_before: whether a command was logged earlier in the folder
    (the wheels are then past any start-up delay).
    """

    folder: Path
    index: int
    t0: float
    time_s: np.ndarray
    q: np.ndarray
    rate_dps: np.ndarray
    wheel_rpm: np.ndarray
    command_rpm_s: np.ndarray
    commanded_before: bool

    @property
    def duration_s(self) -> float:
        return float(self.time_s[-1])

    @property
    def controller_off(self) -> bool:
        """True when no logged command is a finite non-zero value: the flight controller was
        off (or logged nothing) and the satellite drifted; no policy flew this piece."""
        c = self.command_rpm_s
        return not bool(np.any(np.isfinite(c) & (c != 0.0)))

    @property
    def error_deg(self) -> np.ndarray:
        return error_angle_deg(self.q)


def error_angle_deg(q: np.ndarray) -> np.ndarray:
    """Rotation angle (deg) of quaternions (..., 4), scalar first; normalized first."""
    q = np.asarray(q, dtype=float)
    norm = np.linalg.norm(q, axis=-1)
    vec = np.linalg.norm(q[..., 1:], axis=-1)
    return np.degrees(2.0 * np.arctan2(vec, np.abs(q[..., 0]))) * (norm > 0)


def find_folders(root) -> list[Path]:
    """Every folder under ``root`` (itself included) holding one file of each kind, sorted."""
    root = Path(root)
    if not root.is_dir():
        raise TelemetryError(f"telemetry path {str(root)!r} is not a folder")
    folders = sorted({p.parent for p in root.rglob("*.csv") if _kind(p) is not None})
    found = [f for f in folders if all(_kinds(f).get(k) for k in FILES)]
    if not found:
        raise TelemetryError(
            f"no maneuver folder under {str(root)!r}: a folder must hold one CSV file whose "
            f"name starts with each of {list(FILES)}")
    return found


def load(root) -> list[SubManeuver]:
    """The sub-maneuvers of every maneuver folder under ``root``, folder by folder."""
    return [m for folder in find_folders(root) for m in sub_maneuvers(load_folder(folder))]


def load_folder(folder) -> Telemetry:
    """The four files of one maneuver folder, joined on the 2 s grid."""
    folder = Path(folder)
    kinds = _kinds(folder)
    for kind in FILES:
        if len(kinds.get(kind, [])) != 1:
            raise TelemetryError(
                f"folder {str(folder)!r} must hold exactly one file whose name starts with "
                f"{kind!r}, found {len(kinds.get(kind, []))}")
    series = {kind: _read(kinds[kind][0], *FILES[kind][1:]) for kind in FILES}
    stamps, rows, dropped = _join(series)
    if not stamps:
        raise TelemetryError(f"folder {str(folder)!r}: the four files share no time stamp")
    grid = _on_grid(stamps)
    keep = [i for i, n in enumerate(grid) if n is not None]
    dropped += len(stamps) - len(keep)
    arrays = {FILES[kind][0]: np.array([rows[i][j] for i in keep])
              for j, kind in enumerate(FILES)}
    return Telemetry(folder=folder, start_utc=stamps[0],
                     time_s=GRID_S * np.array([grid[i] for i in keep], float),
                     dropped=dropped, **arrays)


def sub_maneuvers(tm: Telemetry, jump_deg: float = SWITCH_JUMP_DEG) -> list[SubManeuver]:
    """``tm`` cut before each target switch: where the error rises between two samples by more
    than ``jump_deg`` beyond what the larger logged body rate turns in that time."""
    err = tm.error_deg
    rate = np.linalg.norm(tm.rate_dps, axis=1)
    dt = np.diff(tm.time_s)
    rise = np.diff(err) - np.maximum(rate[:-1], rate[1:]) * dt
    cuts = [0, *(np.flatnonzero(rise > jump_deg) + 1).tolist(), len(err)]
    commanded = np.cumsum(np.any(tm.command_rpm_s != 0.0, axis=1))
    out = []
    for i, (a, b) in enumerate(itertools.pairwise(cuts)):
        t0 = float(tm.time_s[a])
        out.append(SubManeuver(
            folder=tm.folder, index=i, t0=t0, time_s=tm.time_s[a:b] - t0, q=tm.q[a:b],
            rate_dps=tm.rate_dps[a:b], wheel_rpm=tm.wheel_rpm[a:b],
            command_rpm_s=tm.command_rpm_s[a:b],
            commanded_before=bool(a > 0 and commanded[a - 1] > 0)))
    return out


def write_folder(folder, tm: Telemetry, digits: int = 3, stamp: str = "2000-01-01 00_00_00"
                 ) -> Path:
    """Write ``tm`` as a maneuver folder of the dashboard's format (four CSV files, UTF-8 with
    a byte-order mark, CRLF lines, units in the cells, ``digits`` significant digits), e.g. to
    put a simulation beside flight data. The files are named ``<kind>-data-as-joinbyfield-
    <stamp>.csv``."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    stamps = [(tm.start_utc + timedelta(seconds=float(t))).strftime("%Y-%m-%d %H:%M:%S")
              for t in tm.time_s]
    for kind, (name, columns, unit) in FILES.items():
        path = folder / f"{kind}-data-as-joinbyfield-{stamp}.csv"
        values = np.asarray(getattr(tm, name), float)
        with path.open("w", encoding="utf-8-sig", newline="") as f:
            w = csv.writer(f, lineterminator="\r\n")
            w.writerow(["Time", *columns])
            for t, row in zip(stamps, values, strict=True):
                w.writerow([t, *(f"{v:.{digits}g}" + (f" {unit}" if unit else "")
                                 for v in row)])
    return folder


def _kind(path: Path):
    """The file kind (a key of FILES) its name starts with, or None."""
    return next((k for k in FILES if path.name.startswith(k)), None)


def _kinds(folder: Path) -> dict:
    found: dict = {}
    for p in sorted(folder.glob("*.csv")):
        kind = _kind(p)
        if kind is not None:
            found.setdefault(kind, []).append(p)
    return found


def _read(path: Path, columns: tuple, unit: str):
    """(times as datetimes, values (n, k), path) of one file, in file order; named errors."""
    if path.stat().st_size > MAX_FILE_BYTES:
        raise TelemetryError(f"{path}: larger than {MAX_FILE_BYTES} bytes")
    try:
        with path.open(encoding="utf-8-sig", newline="") as f:
            rows = list(csv.reader(f))
    except UnicodeDecodeError as e:
        raise TelemetryError(f"{path}: not UTF-8 text ({e.reason} at byte {e.start})") from None
    except csv.Error as e:
        raise TelemetryError(f"{path}: not CSV ({e})") from None
    want = ["Time", *columns]
    if not rows or [c.strip() for c in rows[0]] != want:
        raise TelemetryError(
            f"{path}: row 1 (the header) must be {want}, got {rows[0] if rows else 'nothing'}")
    times, values = [], []
    for r, row in enumerate(rows[1:], start=2):
        if not any(c.strip() for c in row):
            continue  # a blank line
        if len(row) != len(want):
            raise TelemetryError(
                f"{path}: row {r} has {len(row)} cells, the header {len(want)}")
        times.append(_time(path, r, row[0]))
        if len(times) > 1 and times[-1] < times[-2]:
            raise TelemetryError(f"{path}: row {r}, column 'Time': {times[-1]} is before the "
                                 f"previous row's {times[-2]}")
        values.append([_number(path, r, name, cell, unit)
                       for name, cell in zip(columns, row[1:], strict=True)])
    if not times:
        raise TelemetryError(f"{path}: no data rows")
    return times, np.array(values, float), path


def _time(path, r: int, cell: str) -> datetime:
    text = cell.strip()
    for fmt in ("%Y-%m-%d %H:%M:%S", "%Y-%m-%d %H:%M:%S.%f"):
        try:
            return datetime.strptime(text, fmt)
        except ValueError:
            pass
    raise TelemetryError(
        f"{path}: row {r}, column 'Time': {text!r} is not a time 'YYYY-MM-DD HH:MM:SS'")


def _number(path, r: int, column: str, cell: str, unit: str) -> float:
    text = cell.strip()
    number, _, got = text.partition(" ")
    if got.strip() != unit:
        raise TelemetryError(
            f"{path}: row {r}, column {column!r}: {text!r} must carry the unit "
            f"{unit or 'none'!r}, got {got.strip() or 'none'!r}")
    try:
        value = float(number)
    except ValueError:
        value = math.nan
    if not math.isfinite(value):
        raise TelemetryError(f"{path}: row {r}, column {column!r}: {text!r} is not a finite "
                             f"number{' with unit ' + repr(unit) if unit else ''}")
    return value


def _join(series: dict) -> tuple[list, list, int]:
    """The samples all four files have: (stamps, rows of one value array per file, rows left
    out). Files join on equal stamps, the k-th row of a stamp with the k-th of the others; a
    sample equal in every file to the one before it at the same stamp is a repeat, left out."""
    by_stamp = []
    for times, values, _ in series.values():
        d: dict = {}
        for t, v in zip(times, values, strict=True):
            d.setdefault(t, []).append(v)
        by_stamp.append(d)
    shared = sorted(set.intersection(*(set(d) for d in by_stamp)))
    stamps, rows = [], []
    for t in shared:
        previous = None
        for k in range(min(len(d[t]) for d in by_stamp)):
            sample = [d[t][k] for d in by_stamp]
            if previous is not None and all(np.array_equal(a, b)
                                            for a, b in zip(sample, previous, strict=True)):
                continue  # a repeated row
            stamps.append(t)
            rows.append(sample)
            previous = sample
    total = sum(len(times) for times, _, _ in series.values())
    return stamps, rows, total - len(stamps) * len(series)


def _on_grid(stamps: list) -> list:
    """The 2 s grid index of each sample (stamps in order; None: left out): its stamp's nearest
    point from the first (halfway, the earlier), or the point after the previous sample's when
    that one is taken (a jittered stamp); None when that lies more than 3 s from its stamp."""
    out, last = [], -1
    for t in stamps:
        x = (t - stamps[0]).total_seconds() / GRID_S
        n = max(math.ceil(x - 0.5), last + 1)  # halfway: the earlier point, if free
        if n - x > 1.5:
            out.append(None)
            continue
        out.append(n)
        last = n
    return out
