"""Presence sensors: a light-beam box, with an object in the beam or not."""

from __future__ import annotations

from ._common import SingleCell


class Presence(SingleCell):
    name = "presence"
    words = ("present", "nothing in the beam")


TYPE = Presence()
