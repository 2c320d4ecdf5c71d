"""Measurement files: probe points per feature, in world coordinates.

YAML (``measurements/<cell>/*.yaml``)::

    units: {length: mm}
    date: 2026-11-21
    instrument: CMM
    probe_radius: 1.5          # ball radius, compensated (planes toward their outside, circles:
    holes probed inside)
    features:
      block.f1:
        points: [[x, y, z], ...]
        above: [x, y, z]       # planes, circles: a point on the outside of the object (orientation
        information)
      block.f5:
        points: [...]
        ordered: true          # lines: the first -> last order gives the direction

CSV (as CMM software exports): a header ``feature,x,y,z`` and one point per
row; an optional fifth column ``role`` marks ``above`` points, the feature's
``offset`` (owner frame), ``boss`` (coordinates ignored) and ``depth`` (in x).  The length
unit is stated, never defaulted: in the header (``x_mm``, ``x [mm]``), in a ``# units: mm``
line above it, or by the caller (``--csv-units``).  Read with the csv module
(:mod:`.csvtext`): a byte-order mark, ``;`` or tab delimiters and quoted fields are fine.
"""

from __future__ import annotations

import datetime as _dt
import hashlib
import re
from dataclasses import replace
from pathlib import Path
from typing import Annotated

import numpy as np
from annotated_types import Len
from pydantic import Field

from ..errors import Issue, UserError, did_you_mean
from ..fileio import atomic_write_text
from ..model.cell import CellModel
from ..model.measurements import FeatureProbes, Measurement, MeasurementSet
from ..units import LENGTH, MIN_POINTS
from .loader import validate_document
from .models import LengthUnits, NonNegative, Strict, Vec3
from .yamlio import comment_text, read_yaml, yaml_value


class FeaturePoints(Strict):
    points: Annotated[list[Vec3], Len(1)] = Field(
        description="Probe points (ball centres) in world coordinates [length unit]."
    )
    above: Vec3 | None = Field(
        None,
        description="Planes and circles: a point outside the object, giving the normal's side.",
    )
    ordered: bool = Field(
        False,
        description="Lines: the points are in probing order, first -> last along the direction.",
    )
    offset: Vec3 | None = Field(
        None,
        description="Lines touched at their edge by the ball: the ball centres' displacement "
        "from the edge at contact, in the feature owner's frame [length unit] (the ball radius "
        "along the approach). The solve uses the centres' distance from the line (the radius).",
    )
    boss: bool = Field(
        False, description="Circles: probed from outside (a boss or shaft), not inside a hole."
    )
    depth: NonNegative | None = Field(
        None,
        description="Circles probed on their wall, this far below the rim [length unit]: only "
        "the points' distance from the axis is used (a wall gives no position along it).",
    )


class MeasurementFile(Strict):
    """Probe points per feature, for calibration."""

    cell: str | None = Field(None, description="The cell these measurements are of (informative).")
    units: LengthUnits
    date: str | None = None
    instrument: str | None = None
    probe_radius: NonNegative = Field(
        0.0, description="Probe ball radius [length unit]; compensated."
    )
    sigma: Annotated[float, Field(gt=0)] | None = Field(
        None, description="Known probing noise (1 sigma) [length unit], if any."
    )
    features: dict[str, FeaturePoints]


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


_HEADER_UNIT = re.compile(r"^([a-z]+)\s*(?:_|\[|\(|/)\s*(mm|m)\s*[\])]?$")


def _read_csv(path: str, length_unit: str | None) -> tuple[dict, list[Issue]]:
    """Probe points of a CSV file (module docstring): the header names the columns and, in
    them or in a ``# units: mm`` comment, the length unit; ``length_unit`` (``--csv-units``)
    stands in when the file states none and must agree when it does."""
    from .csvtext import read_csv_table

    table = read_csv_table(path, "feature,x_mm,y_mm,z_mm[,role]")
    issues: list[Issue] = []
    names, units = [], set()
    for h in table.header:
        m = _HEADER_UNIT.match(h.lower())
        names.append(m.group(1) if m else h.lower())
        if m:
            units.add(m.group(2))
    at_header = lambda message: Issue(path, table.header_line, 1, "(header)", message)  # noqa: E731
    if names[:4] != ["feature", "x", "y", "z"] or len(names) > 5 or names[4:] not in ([], ["role"]):
        raise UserError(
            f"{path}: bad header",
            [
                at_header(
                    f"the header is '{table.delimiter.join(table.header)[:60]}'; expected "
                    "'feature,x,y,z' (fields separated by ',', ';' or a tab) with the unit (x_mm "
                    "or 'x [mm]', or a '# units: mm' line above), and optionally ',role'"
                )
            ],
        )
    stated, stated_line = table.stated("units")
    if stated is not None and stated not in LENGTH:
        return {}, [
            Issue(path, stated_line, 1, "(units)", f"unknown length unit '{stated}'; use mm or m")
        ]
    if stated is not None:
        units.add(stated)
    if len(units) > 1:
        return {}, [at_header(f"the file states two length units: {', '.join(sorted(units))}")]
    unit = next(iter(units), None)
    if unit is not None and length_unit is not None and unit != length_unit:
        return {}, [
            at_header(
                f"the file states its points in {unit}, but --csv-units says {length_unit}; "
                "drop --csv-units or correct the file"
            )
        ]
    unit = unit or length_unit
    if unit is None:
        return {}, [
            at_header(
                "the file does not state its length unit, and rworld never guesses one: name "
                "it in the header (feature,x_mm,y_mm,z_mm or 'x [m]'), add a '# units: mm' line "
                "above it, or pass --csv-units mm|m"
            )
        ]
    scale = LENGTH[unit]
    data: dict[str, dict] = {}
    for lineno, fields, columns in table.rows:
        if len(fields) not in (4, 5):
            issues.append(
                Issue(
                    path,
                    lineno,
                    1,
                    "(row)",
                    f"{len(fields)} field(s) separated by '{table.delimiter}'; expected "
                    "feature,x,y,z[,role]",
                )
            )
            continue
        try:
            xyz = [float(v) * scale for v in fields[1:4]]
        except ValueError:
            bad = next(k for k in (1, 2, 3) if not _is_number(fields[k]))
            hint = (
                " (a decimal comma? use '.' or separate the fields with ';')"
                if "," in fields[bad] or re.fullmatch(r"-?\d+,\d+", fields[bad])
                else ""
            )
            issues.append(
                Issue(
                    path,
                    lineno,
                    columns[bad],
                    "(row)",
                    f"coordinate '{fields[bad]}' is not a number{hint}",
                )
            )
            continue
        if not np.all(np.isfinite(xyz)):
            issues.append(Issue(path, lineno, columns[1], "(row)", "coordinates must be finite"))
            continue
        entry = data.setdefault(
            fields[0],
            {"points": [], "above": None, "ordered": True, "line": lineno, "offset": None},
        )
        entry.setdefault("boss", False)
        entry.setdefault("depth", None)
        role = fields[4].lower() if len(fields) == 5 else ""
        if role == "above":
            entry["above"] = xyz
        elif role == "offset":
            entry["offset"] = xyz
        elif role == "boss":
            entry["boss"] = True
        elif role == "depth":
            entry["depth"] = xyz[0]
        elif role in ("", "point"):
            entry["points"].append(xyz)
        else:
            issues.append(
                Issue(
                    path,
                    lineno,
                    columns[4],
                    "(row)",
                    f"unknown role '{fields[4]}'; use 'above', 'offset', 'boss' or 'depth' "
                    "(in x), or leave it empty",
                )
            )
    return data, issues


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def load_measurements(
    paths: list[str], cell: CellModel, csv_units: str | None = None
) -> MeasurementSet:
    """Read measurement files (YAML or CSV) and check them against the cell.

    Raises
    ------
    UserError
        Located problems: syntax, unknown features, too few points, a feature measured twice.
    """
    issues: list[Issue] = []
    out: dict[str, Measurement] = {}
    files = []
    sigmas = []
    for path in paths:
        if path.lower().endswith(".csv"):
            data, csv_issues = _read_csv(path, csv_units)
            issues += csv_issues
            radius, meta = 0.0, {}
            entries = {
                name: (
                    e["points"],
                    e["above"],
                    True,
                    ("line", e["line"]),
                    np.array(e["offset"]) if e["offset"] is not None else None,
                    e["boss"],
                    e["depth"],
                )
                for name, e in data.items()
            }
            locate = lambda key: Issue(path, entries[key][3][1], 1, f"feature '{key}'", "")  # noqa: E731
        else:
            doc = read_yaml(path)
            try:
                mf = validate_document(doc, MeasurementFile)
            except UserError as exc:
                issues += exc.issues
                continue
            L = LENGTH[mf.units.length]
            radius = mf.probe_radius * L
            if mf.sigma:
                sigmas.append(mf.sigma * L)
            meta = {"date": mf.date, "instrument": mf.instrument}
            entries = {
                name: (
                    [list(np.array(p) * L) for p in f.points],
                    list(np.array(f.above) * L) if f.above else None,
                    f.ordered,
                    None,
                    np.array(f.offset, dtype=float) * L if f.offset is not None else None,
                    f.boss,
                    f.depth * L if f.depth is not None else None,
                )
                for name, f in mf.features.items()
            }
            locate = lambda key, doc=doc: doc.issue(("features", key), "", prefer="key")  # noqa: E731
        files.append({"path": path, "sha256": _digest(Path(path)), **meta})
        for name, (points, above, ordered, _, offset, boss, depth) in entries.items():
            where = locate(name)
            feature = cell.features.get(name)
            if feature is None:
                issues.append(
                    replace(
                        where,
                        message=f"unknown feature '{name}'{did_you_mean(name, cell.features)}",
                    )
                )
                continue
            wrong = [
                key
                for key, given, kind in (
                    ("boss", boss, "circle"),
                    ("depth", depth is not None, "circle"),
                    ("offset", offset is not None, "line"),
                )
                if given and feature.kind != kind
            ]
            if wrong:
                issues.append(
                    replace(
                        where,
                        message=f"'{wrong[0]}' applies to "
                        f"{'circles' if wrong[0] != 'offset' else 'lines'}; '{name}' is a "
                        f"{feature.kind}",
                    )
                )
                continue
            if name in out:
                issues.append(
                    replace(
                        where, message=f"'{name}' is measured again (first in {out[name].source})"
                    )
                )
                continue
            pts = np.array(points, dtype=float).reshape(-1, 3)
            need = MIN_POINTS[feature.kind]
            if len(pts) < need:
                issues.append(
                    replace(
                        where,
                        message=f"a {feature.kind} needs at least {need} point(s), got {len(pts)}",
                    )
                )
                continue
            out[name] = Measurement(
                name,
                pts,
                np.array(above, float) if above is not None else None,
                bool(ordered),
                radius,
                path,
                offset,
                bool(boss),
                depth,
            )
    if issues:
        raise UserError(
            f"{len(issues)} problem(s) in the measurements",
            sorted(issues, key=lambda i: (i.file, i.line, i.column)),
        )
    return MeasurementSet(out, files, float(np.mean(sigmas)) if sigmas else None)


def measurement_text(
    features: dict[str, FeatureProbes],
    cell: str,
    comments: list[str],
    *,
    sigma: float | None = None,
    probe_radius: float = 0.0,
    instrument: str | None = None,
    date: str | None = None,
    digits: int | None = None,
) -> str:
    """A measurement file (mm) for ``features`` (SI, world): the format :func:`load_measurements`
    reads.

    ``digits``: decimals of the mm values (None: round-trip exact).
    """

    def mm(values) -> str:
        return (
            "["
            + ", ".join(
                repr(float(x) * 1000) if digits is None else f"{float(x) * 1000:.{digits}f}"
                for x in values
            )
            + "]"
        )

    lines = [f"# {comment_text(c)}" for c in comments]
    lines += [f"cell: {yaml_value(cell)}", "units: {length: mm}"]
    if date is not None:
        lines.append(f"date: {yaml_value(date)}")
    if instrument is not None:
        lines.append(f"instrument: {yaml_value(instrument)}")
    if sigma is not None:
        lines.append(f"sigma: {sigma * 1000!r}")
    lines.append(f"probe_radius: {probe_radius * 1000:g}")
    lines.append("features:")
    for name, f in features.items():
        lines.append(
            f"  {yaml_value(name)}:" + (f"   # {comment_text(f.comment)}" if f.comment else "")
        )
        lines.append("    points:")
        lines += ["      - " + mm(p) for p in f.points]
        if f.above is not None:
            lines.append("    above: " + mm(f.above))
        if f.ordered:
            lines.append("    ordered: true")
        if f.offset is not None:
            lines.append("    offset: " + mm(f.offset) + "   # ball centres from the edge, owner's")
        if f.boss:
            lines.append("    boss: true")
        if f.depth is not None:
            lines.append(f"    depth: {f.depth * 1000!r}   # probed on the wall, below the rim")
    return "\n".join(lines) + "\n"


def write_measurements(
    path: str, features: dict[str, FeatureProbes], cell: str, comments: list[str], **fields
) -> None:
    """Write :func:`measurement_text` to ``path`` atomically."""
    atomic_write_text(path, measurement_text(features, cell, comments, **fields))


def today() -> str:
    return _dt.date.today().isoformat()
