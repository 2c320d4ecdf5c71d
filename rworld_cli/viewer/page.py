"""One self-contained HTML page that plays a run: the animated .glb, the viewer's panel data and
three.js (vendored, MIT; docs/dependencies.md), all inside the file, so it opens offline from
disk or as a CI artifact, with no CDN.

three.js and its add-ons are ES modules.  Each is embedded as a ``data:`` URL in the page's import
map (the add-ons' relative imports rewritten to the map's names), and the viewer's own module
imports them by name.  The .glb is embedded in base64, the panel data as JSON.
"""

from __future__ import annotations

import base64
import json
import re
from importlib import resources

from ..jsonvalues import finite

THREE_VERSION = "0.169.0"

# import-map name -> vendored file; the add-ons import 'three' and each other by these names
_MODULES = {
    "three": "three.module.min.js",
    "three/addons/utils/BufferGeometryUtils.js": "BufferGeometryUtils.js",
    "three/addons/loaders/GLTFLoader.js": "GLTFLoader.js",
    "three/addons/controls/OrbitControls.js": "OrbitControls.js",
    "three/addons/renderers/CSS2DRenderer.js": "CSS2DRenderer.js",
}
_RELATIVE = {"'../utils/BufferGeometryUtils.js'": "'three/addons/utils/BufferGeometryUtils.js'"}


def _asset(*parts: str) -> str:
    return resources.files("rworld_cli.viewer").joinpath("assets", *parts).read_text("utf-8")


def _import_map() -> str:
    imports = {}
    for name, file in _MODULES.items():
        source = _asset("three", file)
        for relative, absolute in _RELATIVE.items():
            source = source.replace(f"from {relative}", f"from {absolute}")
        encoded = base64.b64encode(source.encode("utf-8")).decode("ascii")
        imports[name] = f"data:text/javascript;base64,{encoded}"
    return json.dumps({"imports": imports})


def _script_json(payload) -> str:
    """JSON safe inside a <script> element, and still JSON: ``<``, ``>`` and ``&`` as ``\\u``
    escapes (no ``</script>`` or ``<!--`` can form), and the line separators JavaScript once
    refused in strings."""
    text = json.dumps(finite(payload), separators=(",", ":"), allow_nan=False)
    for ch in "<>&\u2028\u2029":
        text = text.replace(ch, f"\\u{ord(ch):04x}")
    return text


def viewer_page(glb: bytes, info: dict) -> str:
    """The HTML text of the viewer of one scene.

    Parameters
    ----------
    glb : bytes
        The scene (``schema.gltf.scene_glb``).
    info : dict
        The panel data (``simulate.scene.RunScene.info``): title, times, devices' joint values
        and steps, timeline marks, labels, bodies without geometry.
    """
    from html import escape

    fields = {
        # the page is UTF-8: a lone surrogate (a file name's undecodable byte) becomes '?'
        "TITLE": escape(str(info.get("title", "rworld"))).encode("utf-8", "replace").decode(),
        "STYLE": _asset("viewer.css"),
        "IMPORTMAP": _import_map(),
        "INFO": _script_json(info),
        "GLB": base64.b64encode(glb).decode("ascii"),
        "APP": _asset("viewer.js"),
    }
    return re.sub(r"\{\{(\w+)\}\}", lambda m: fields[m.group(1)], _asset("page.html"))
