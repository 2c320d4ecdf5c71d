"""One simulated run of paper_fig9 transfer, its scene, .glb files and viewer page, shared by the
viewer tests (the simulation takes seconds)."""

from __future__ import annotations

import pytest


@pytest.fixture(scope="session")
def fig9_run(example_run):
    return example_run("paper_fig9", "transfer")


@pytest.fixture(scope="session")
def fig9_scene(fig9_run):
    from rworld_cli.simulate.scene import run_scene

    loaded, result = fig9_run
    return run_scene(loaded.cell, result)


@pytest.fixture(scope="session")
def fig9_page(fig9_scene, tmp_path_factory):
    from rworld_cli.schema.gltf import scene_glb
    from rworld_cli.viewer.page import viewer_page

    path = tmp_path_factory.mktemp("viewer") / "fig9.html"
    path.write_text(viewer_page(scene_glb(fig9_scene), fig9_scene.info), encoding="utf-8")
    return path
