"""Touch sensors: the box meets an object or not, and which."""

from __future__ import annotations

from ._common import SingleCell


class Touch(SingleCell):
    name = "touch"
    words = ("touching", "no contact")


TYPE = Touch()
