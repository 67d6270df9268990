"""A workspace holding links out of it and dangling links, as a student's folder may: every page
is served (over HTTP, as the browser asks for it), lists the real files and none of the links,
and opening a link by name is refused with a sentence.

One studio process serves the module; no browser is needed to see what a page lists (the
pickers' choices are in the page as served).
"""

from __future__ import annotations

import urllib.error
import urllib.request
from pathlib import Path

import pytest
from studio_browser_support import studio_domain

from sim_runtime.errors import InputError
from studio.shell.workspace import Workspace

STUDIO_DOMAIN = studio_domain(60)  # the other studio modules use 50-55
OUTSIDE = "/etc/hostname"


@pytest.fixture(scope="module")
def workspace(tmp_path_factory) -> Path:
    ws = tmp_path_factory.mktemp("studio_links_ws")
    (ws / "good.map").write_text("wall 0 0 1 1\n")
    (ws / "good.cfg").write_text("")
    (ws / "good.yaml").write_text("a: 1\n")
    (ws / "good.m").write_text("x = 1;\n")
    (ws / "bags" / "run1").mkdir(parents=True)
    (ws / "bags" / "run1" / "run1_0.mcap").write_bytes(b"")
    for suffix in (".map", ".cfg", ".yaml", ".mcap", ".m"):
        (ws / f"out{suffix}").symlink_to(OUTSIDE)
        (ws / f"dangling{suffix}").symlink_to(ws / f"gone{suffix}")
    (ws / "outside_folder").symlink_to("/etc")  # a link to a folder out of the workspace
    return ws


def get(url: str) -> tuple[int, str]:
    try:
        with urllib.request.urlopen(url, timeout=30.0) as response:
            return response.status, response.read().decode()
    except urllib.error.HTTPError as err:
        return err.code, err.read().decode(errors="replace")


@pytest.mark.parametrize(
    ("page", "listed"),
    [
        ("/", ["good.map", "good.cfg", "good.m"]),  # New world's map and config, the program list
        ("/arm", ["good.yaml"]),
        ("/replay", ["bags/run1"]),
        ("/simrobot/editor", ["good.m"]),  # the robot form's algorithm list
        ("/map", []),
        ("/config", []),
        ("/simrobot", []),
    ],
)
def test_every_page_serves_a_workspace_with_links_out_and_dangling_links_listing_neither(studio_url, page, listed):
    status, html = get(studio_url + page)
    assert status == 200, html[-2000:]
    for name in listed:
        assert name in html
    for stem in ("out", "dangling", "gone", "hostname", "outside_folder"):
        assert f"{stem}." not in html and "outside_folder/" not in html


def test_a_link_out_or_dangling_is_not_listed_and_opening_it_by_name_says_why(workspace):
    ws = Workspace(workspace)
    assert ws.files((".map", ".yaml", ".mcap", ".m", ".cfg")) == [
        "good.cfg", "good.m", "good.map", "good.yaml", "bags/run1/run1_0.mcap"
    ]  # fmt: skip
    with pytest.raises(InputError, match="outside the workspace"):
        ws.read_text("out.map", "map")
    with pytest.raises(InputError, match="map file not found in the workspace"):
        ws.read_text("dangling.map", "map")
    (workspace / "inner.map").symlink_to(workspace / "good.map")  # a link inside: listed by its own name
    try:
        assert "inner.map" in ws.files((".map",))
    finally:
        (workspace / "inner.map").unlink()
