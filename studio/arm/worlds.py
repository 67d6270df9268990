"""The Arm page's New arm world: an arm world started from a robot config and a scene file."""

from __future__ import annotations

import asyncio

from nicegui import ui

from sim_runtime.errors import InputError
from sim_runtime.paths import config_path
from sim_tools.cli import executable_command
from studio.arm.page_base import ArmPageBase, arm_worlds
from studio.shell.app import Studio
from studio.shell.kit import stop_started_world
from studio.shell.processes import Child, clock_topic, namespace_args, yaml_string


def resolve_config(studio: Studio, name: str, what: str) -> str:
    """A robot config or scene file typed in the page: in the workspace, else a shipped one
    (``arm/irb120.yaml``); never a path outside both."""
    name = name.strip()
    path = studio.workspace.path(name)
    if path.is_file():
        return str(path)
    shipped = config_path(name)
    if ".." not in name.split("/") and shipped.is_file():
        return str(shipped)
    raise InputError(f"{name!r}: no {what} in the workspace {studio.workspace.root} nor among the shipped configs")


def arm_world_ros_args(ns: str, robot_config: str, scene_file: str, owns_clock: bool = False) -> list[str]:
    """``--ros-args`` of an arm world in namespace ``ns`` ('' = root), its clock on :func:`clock_topic`."""
    args = ["--ros-args", "-p", f"robot_config_file:={yaml_string(robot_config)}"]
    args += ["-p", f"scene_file:={yaml_string(scene_file)}"]
    return args + namespace_args(ns, owns_clock)


class ArmWorlds(ArmPageBase):
    """New arm world, and the end of any world the studio started that ended."""

    def build_world_panel(self) -> None:
        ws = self.studio.workspace
        with ui.expansion("New arm world", icon="add").classes("w-full border studio-new-arm-world"):
            self.world_config = ui.input(
                "robot config (workspace or shipped)", value="arm/irb120.yaml", autocomplete=ws.files((".yaml",))
            ).classes("w-full studio-arm-config")
            self.world_scene = ui.input("scene file (empty = none; e.g. arm/workcell.yaml)").classes(
                "w-full studio-arm-scene"
            )
            self.world_ns = ui.input("namespace", value=self.studio.free_namespace("arm")).classes("w-40 studio-arm-ns")
            with ui.row().classes("gap-2"):
                ui.button("Start arm world", on_click=self.start_world).props("dense").classes("studio-arm-start")
                ui.button("Stop arm world", on_click=self.stop_world).props("dense outline")
            self.world_label = ui.label("").classes("text-sm text-red-700 break-all studio-arm-world-error")

    async def start_world(self) -> None:
        studio = self.studio
        ns = (self.world_ns.value or "").strip().rstrip("/")
        if ns and not ns.startswith("/"):
            ns = "/" + ns
        self.world_label.set_text("")
        try:
            config = resolve_config(studio, self.world_config.value or "", "robot config")
            scene = (
                resolve_config(studio, self.world_scene.value, "scene file")
                if (self.world_scene.value or "").strip()
                else ""
            )
        except InputError as err:
            self.world_label.set_text(f"error: {err}")
            return
        ros = self.ros()
        refusal = studio.namespace_refusal(ns) or (
            f"an arm world already runs in {ns or '/'}: give another namespace"
            if ros is not None and ns in ros.arms
            else None
        )
        if refusal:
            self.world_label.set_text(f"error: {refusal}")
            return
        owns_clock = studio.clock_owner() is None
        child = Child(
            f"arm {ns or '/'}",
            executable_command("arm", arm_world_ros_args(ns, config, scene, owns_clock)),
            cwd=studio.workspace.root,
            clock=clock_topic(ns, owns_clock),
        )
        arm_worlds(studio)[ns] = child
        self.world_label.set_text(f"starting an arm world in {ns or '/'}…")
        for _ in range(400):
            await asyncio.sleep(0.05)
            if not child.running:
                self.endings_shown.add(child)
                self.world_label.set_text(f"{ns or '/'}: {child.error_line()}")
                return
            ros = self.ros()
            if ros is not None and ns in ros.arms:
                break
        else:
            return
        self.world_label.set_text("")
        self.selected = ns
        self.built_joints = ()
        if ns in self.arm_select.options:
            self.arm_select.set_value(ns)
        self.world_ns.set_value(studio.free_namespace("arm"))
        ui.notify(f"arm world started in {ns or '/'} (its clock: {child.clock})")

    async def stop_world(self) -> None:
        ns = self.selected or ""
        ros = self.ros()
        if ros is not None and ns in ros.arms:
            # The world node's namespace: a scene arm (/csa) belongs to the world in /.
            ns = ros.arms[ns].world_ns
        await stop_started_world(arm_worlds(self.studio), ns)
