"""Mesh URIs: ``package://robot_sims/…`` where the ament index finds the installed package and
its copy of the mesh, ``file://`` otherwise."""

from __future__ import annotations

import io
import shutil
import sys
from pathlib import Path
from urllib.parse import unquote, urlparse

import pytest
import yourdfpy
from ament_index_python.packages import get_package_share_directory

from arm_sim.robot_config import load_robot_config
from arm_sim.urdf import arm_urdf
from sim_runtime.paths import config_path, mesh_path, mesh_uri

MESH = "arm/meshes/irb120/IRB120_base.stl"


def make_prefix(root: Path, *, with_package: bool, meshes: tuple[str, ...] = ()) -> Path:
    """An install prefix as ament sees it: the package marker and ``share/robot_sims/config``."""
    index = root / "share" / "ament_index" / "resource_index" / "packages"
    index.mkdir(parents=True)
    if with_package:
        (index / "robot_sims").write_text("")
        for relative in meshes:
            target = root / "share" / "robot_sims" / "config" / relative
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(config_path(relative), target)
    return root


@pytest.fixture
def installed(tmp_path, monkeypatch) -> Path:
    """robot_sims installed (with the IRB120's meshes) in a prefix on AMENT_PREFIX_PATH."""
    config = load_robot_config(config_path("arm/irb120.yaml"))
    meshes = tuple(str(e.mesh.relative_to(config_path(""))) for link in config.links for e in link)
    prefix = make_prefix(tmp_path / "install", with_package=True, meshes=meshes)
    monkeypatch.setenv("AMENT_PREFIX_PATH", str(prefix))
    return prefix


def test_a_shipped_mesh_installed_in_the_package_share_gets_a_package_uri(installed):
    assert mesh_uri(config_path(MESH)) == f"package://robot_sims/config/{MESH}"


def test_a_mesh_inside_the_package_share_gets_a_package_uri(installed):
    assert mesh_uri(installed / "share/robot_sims/config" / MESH) == f"package://robot_sims/config/{MESH}"


def test_without_the_package_in_the_ament_index_meshes_get_file_uris(tmp_path, monkeypatch):
    monkeypatch.setenv("AMENT_PREFIX_PATH", str(make_prefix(tmp_path / "other", with_package=False)))
    assert mesh_uri(config_path(MESH)) == config_path(MESH).resolve().as_uri()


def test_a_user_mesh_outside_the_package_gets_a_file_uri(installed, tmp_path):
    mine = tmp_path / "mine.stl"
    shutil.copyfile(config_path(MESH), mine)
    assert mesh_uri(mine) == mine.resolve().as_uri()


def test_an_installed_copy_that_differs_from_the_checkouts_file_is_not_used(installed):
    (installed / "share/robot_sims/config" / MESH).write_bytes(b"solid other\nendsolid other\n")
    assert mesh_uri(config_path(MESH)).startswith("file://")


def test_an_installed_arms_urdf_uses_package_uris_a_ros_tool_resolves_to_the_same_meshes(installed):
    text = arm_urdf(load_robot_config(config_path("arm/irb120.yaml")))

    def resolve(fname: str) -> str:
        # As RViz does: package://<name>/<path> is <name>'s share directory + path.
        uri = urlparse(fname)
        assert uri.scheme == "package" and uri.netloc == "robot_sims", fname
        return str(Path(get_package_share_directory(uri.netloc)) / unquote(uri.path).lstrip("/"))

    urdf = yourdfpy.URDF.load(io.StringIO(text), load_meshes=True, filename_handler=resolve)
    assert len(urdf.scene.geometry) == 7


def test_mesh_path_reads_back_both_kinds_of_uri(installed, tmp_path, monkeypatch):
    installed_mesh = installed / "share/robot_sims/config" / MESH
    assert mesh_path(mesh_uri(config_path(MESH))) == installed_mesh
    mine = tmp_path / "my mesh.stl"
    assert mesh_path(mesh_uri(mine)) == mine.resolve()
    assert mesh_path("package://no_such_package/x.stl") is None
    assert mesh_path("https://example.org/x.stl") is None


def test_without_ros_at_all_meshes_get_file_uris(installed, monkeypatch):
    monkeypatch.setitem(sys.modules, "ament_index_python.packages", None)  # as where ROS is not installed
    assert mesh_uri(config_path(MESH)) == config_path(MESH).resolve().as_uri()
    assert mesh_path(f"package://robot_sims/config/{MESH}") is None
