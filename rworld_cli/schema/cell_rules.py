"""A cell's affixments and the calibration report's frame conditions as the loader reads them:
the tree's rules, cycles, the conditions' features."""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..errors import did_you_mean
from ..model import cell as wm
from ..model import rules

if TYPE_CHECKING:  # pydantic, the file models and YAML load when a file is checked
    pass

from .cellparts import (
    CONDITION_FEATURE_KINDS,
)


class RulesMixin:
    """The affixment and condition checks of the loader's builder (a mixin of
    ``loader._Builder``)."""

    # ------------------------------------------------------------------ affixments
    def _owner_kind(self, frame: str) -> str:
        decl = self.frames[frame]
        if decl.kind in ("world", "free"):
            return decl.kind
        return self.primitives[decl.owner][0]

    def _affixments(self) -> list[wm.AffixmentDecl]:
        out = []
        seen_child: dict[str, tuple] = {}
        for i, a in enumerate(self.cf.affixments):
            path = ("affixments", i)
            bad = False
            if a.parent not in self.frames:
                self.err(
                    path + ("parent",),
                    f"unknown frame '{a.parent}'{did_you_mean(a.parent, self.frames)}",
                )
                bad = True
            child_kind = self.primitives.get(a.child, (None,))[0]
            if child_kind is None:
                frame_hint = (
                    " (auxiliary frames belong to their owner and cannot be affixed)"
                    if a.child in self.frames
                    else ""
                )
                names = [n for n, (k, _) in self.primitives.items() if k != "free"]
                self.err(
                    path + ("child",),
                    "unknown object, sensor or device "
                    f"'{a.child}'{did_you_mean(a.child, names)}{frame_hint}",
                )
                bad = True
            elif child_kind == "free":
                self.err(
                    path + ("child",),
                    f"'{a.child}' is a free frame; give it a 'parent' in 'frames' instead of an "
                    "affixment",
                )
                bad = True
            if a.child in seen_child:
                self.err(
                    path + ("child",),
                    f"'{a.child}' is already affixed at line {self._line(seen_child[a.child])}; a "
                    "primitive has one parent (the affixments form a tree)",
                )
                bad = True
            if bad:
                continue
            seen_child[a.child] = path + ("child",)
            owner_kind = self._owner_kind(a.parent)
            parent_owner = self.frames[a.parent].owner
            problem = rules.hierarchy_problem(
                a.child, child_kind, a.parent, parent_owner, owner_kind
            )
            if problem:
                self.err(path + (problem[0],), problem[1])
                continue
            problem = rules.kind_problem(a.type, a.kind, child_kind, owner_kind)
            if problem:
                self.err(path + ("kind",), problem)
            out.append(wm.AffixmentDecl(a.parent, a.child, a.type, a.kind))
        return out

    def _check_cycles(self, affixments: list[wm.AffixmentDecl]):
        """Follow parents from every frame; report each cycle once, at an affixment that closes
        it.
        """
        parent = {n: d.parent for n, d in self.frames.items()}
        via: dict[str, int] = {}
        for i, a in enumerate(affixments):
            parent[a.child] = a.parent
            via[a.child] = i
        # each frame walked once: a walk stops at a frame an earlier one went through (it leads
        # to world, or into a cycle already reported) - linear in the frames, however deep
        walked: set[str] = set()
        for start in parent:
            path, on_path, node = [], set(), start
            while node is not None and node not in walked and node not in on_path:
                path.append(node)
                on_path.add(node)
                node = parent.get(node)
            walked.update(path)
            if node is None or node not in on_path:
                continue
            cycle = path[path.index(node) :]
            chain = " -> ".join(cycle + [cycle[0]])
            closing = [n for n in cycle if n in via]
            if closing:
                idx = self.cf.affixments.index(
                    next(a for a in self.cf.affixments if a.child == closing[-1])
                )
                self.err(
                    ("affixments", idx, "parent"),
                    f"the affixments form a cycle: {chain} (each frame must lead to world)",
                )
            else:
                self.err(
                    self.frame_paths[cycle[0]][:-1] + ("parent",), f"frames form a cycle: {chain}"
                )

    # ------------------------------------------------------------------ conditions
    def _conditions(self) -> list[wm.Condition]:
        out = []
        seen: dict[str, tuple] = {}
        for i, c in enumerate(self.cf.conditions):
            path = ("conditions", i)
            decl = self.frames.get(c.frame)
            if decl is None:
                self.err(
                    path + ("frame",),
                    f"unknown frame '{c.frame}'{did_you_mean(c.frame, self.frames)}",
                )
                continue
            if c.frame in seen:
                self.err(
                    path + ("frame",),
                    f"frame '{c.frame}' is already conditioned at line "
                    f"{self._line(seen[c.frame])}; a frame takes one condition",
                )
                continue
            seen[c.frame] = path + ("frame",)
            code = c.code
            natural = code in ("C1", "C2")
            if decl.kind in ("world", "free", "link"):
                what = {
                    "world": "the world frame",
                    "free": "a free frame",
                    "link": "a link frame (placed by the DH table)",
                }[decl.kind]
                self.err(
                    path + ("frame",),
                    f"'{c.frame}' is {what}; only frames owned by an object or device can be "
                    "conditioned by features",
                )
                continue
            if natural and decl.kind != "natural":
                self.err(
                    path + ("type",),
                    f"{c.type} ({code}) locates a natural frame; '{c.frame}' is an auxiliary "
                    "frame (use C3-C13)",
                )
                continue
            if not natural and decl.kind == "natural":
                self.err(
                    path + ("type",),
                    f"{c.type} ({code}) conditions an auxiliary frame; '{c.frame}' is a natural "
                    "frame (use C1 or C2)",
                )
                continue
            if self.primitives.get(decl.owner, ("",))[0] == "sensor":
                self.err(
                    path + ("frame",),
                    f"'{c.frame}' belongs to a sensor; features belong to objects and devices",
                )
                continue
            names = c.feature_names
            fpath = path + ("feature",) if c.feature is not None else path + ("features",)
            if not natural and len(names) != 1:
                self.err(
                    fpath,
                    f"an auxiliary frame is conditioned by exactly one feature, got {len(names)}",
                )
                continue
            if natural and not names:
                self.err(fpath, "give the features that locate this frame")
                continue
            resolved = []
            for k, fname in enumerate(names):
                p = fpath if c.feature is not None else fpath + (k,)
                qname = fname if "." in fname else f"{decl.owner}.{fname}"
                feat = self.features.get(qname)
                if feat is None:
                    own = [
                        f.split(".", 1)[1] for f in self.features if f.startswith(decl.owner + ".")
                    ]
                    self.err(
                        p,
                        f"'{decl.owner}' has no feature "
                        f"'{fname}'{did_you_mean(fname.split('.')[-1], own)}",
                    )
                    continue
                if feat.owner != decl.owner:
                    self.err(
                        p,
                        f"feature '{qname}' belongs to '{feat.owner}' but frame '{c.frame}' "
                        f"belongs to '{decl.owner}'; "
                        "a frame is conditioned only by features of its own object or device",
                    )
                    continue
                if feat.kind not in CONDITION_FEATURE_KINDS[code]:
                    allowed = " or ".join(sorted(CONDITION_FEATURE_KINDS[code]))
                    self.err(
                        p,
                        f"{c.type} ({code}) needs a {allowed} feature; '{qname}' is a {feat.kind}",
                    )
                    continue
                resolved.append(qname)
            if len(resolved) == len(names):
                out.append(wm.Condition(c.frame, code, c.type, tuple(resolved)))
        return out
