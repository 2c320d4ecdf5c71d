"""rworld's xacro expander against the ROS tool (the ``xacro`` package) on vendor packages.

Run:  .venv/bin/python bench/xacro_expand.py [--repeats 20]

The same files (tests/data: Yaskawa GP7, Staubli TX2-60, KUKA LBR iiwa 14, Universal Robots
UR5e and UR20), expanded by both in one process, alternately; the median of ``--repeats``
expansions each, and the ratio (the ROS tool's time / rworld's). The documents are compared
element by element first: a bench of two different outputs would mean nothing.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from rworld_cli.schema.xacro import expand_xacro_file, find_package  # noqa: E402

DATA = REPO / "tests" / "data"
CASES = [
    ("GP7", "motoman/motoman_gp7_support/urdf/gp7.xacro", "motoman", {}),
    ("TX2-60", "staubli/staubli_tx2_60_support/urdf/tx2_60.xacro", "staubli", {}),
    ("LBR iiwa 14", "kuka_iiwa/kuka_lbr_iiwa_support/urdf/lbr_iiwa_14_r820.xacro", "kuka_iiwa", {}),
    ("UR5e", "universal_robots/ur_description/urdf/ur.urdf.xacro", "universal_robots",
     {"ur_type": "ur5e", "name": "ur"}),
    ("UR20", "universal_robots/ur_description/urdf/ur.urdf.xacro", "universal_robots",
     {"ur_type": "ur20", "name": "ur"}),
]  # fmt: skip


def _canonical(data: bytes):
    """The document as nested tuples (tag, sorted attributes, text, children), comments out."""
    from lxml import etree

    root = etree.fromstring(data, etree.XMLParser(remove_comments=True, remove_blank_text=True))

    def walk(el):
        attrs = tuple(sorted((etree.QName(k).localname, v) for k, v in el.attrib.items()))
        children = tuple(walk(c) for c in el if isinstance(c.tag, str))
        return etree.QName(el).localname, attrs, (el.text or "").strip(), children

    return walk(root)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=20)
    repeats = parser.parse_args().repeats
    import xacro
    from xacro import substitution_args

    print(f"{'robot':<12} {'elements':>8} {'rworld ms':>10} {'ROS xacro ms':>13} {'ratio':>6}")
    for name, relative, packages, args in CASES:
        path, roots = DATA / relative, [DATA / packages]
        substitution_args._eval_find = lambda p, roots=roots: str(find_package(p, roots).resolve())

        def ours(path=path, roots=roots, args=args):
            return expand_xacro_file(path, str(path), roots, args).urdf

        def ros(path=path, args=args):
            return xacro.process_file(str(path), mappings=dict(args)).toxml(encoding="utf-8")

        mine, theirs = ours(), ros()
        assert _canonical(mine) == _canonical(theirs), name
        elements = mine.count(b"<") - 1
        times: dict[str, list[float]] = {"ours": [], "ros": []}
        for _ in range(repeats):
            for key, fn in (("ours", ours), ("ros", ros)):
                start = time.perf_counter()
                fn()
                times[key].append(time.perf_counter() - start)
        a, b = statistics.median(times["ours"]), statistics.median(times["ros"])
        print(f"{name:<12} {elements:>8} {a * 1e3:>10.1f} {b * 1e3:>13.1f} {b / a:>6.2f}")


if __name__ == "__main__":
    main()
