"""What the map maker and the config maker share: a file in the workspace, a message line, and the
running worlds a saved file can be applied to."""

from __future__ import annotations

from sim_runtime.errors import InputError
from studio.app import Studio


class FilePage:
    """Base of a page that edits one workspace file. Subclasses build ``file_name``, ``overwrite``,
    ``world_select`` and ``message`` widgets and set ``message_class``."""

    message_class = ""

    def __init__(self, studio: Studio) -> None:
        self.studio = studio
        self.own_file = ""  # the workspace file this page last loaded or saved: the one that may be applied

    def say(self, text: str, error: bool = False) -> None:
        self.message.set_text(text)
        self.message.classes(
            replace=f"text-sm break-all {self.message_class} " + ("text-red-700" if error else "text-green-800")
        )

    def save_text(self, text: str) -> bool:
        """Write ``text`` to the file named in the page (refusing to overwrite unless asked)."""
        name = (self.file_name.value or "").strip()
        try:
            path = self.studio.workspace.write_text(name, text, overwrite=self.overwrite.value)
        except (InputError, OSError) as err:
            self.say(f"error: {err}", error=True)
            return False
        self.own_file = name
        self.say(f"saved {self.studio.workspace.relative(path)}")
        return True

    def refresh_worlds(self) -> None:
        ros = self.studio.ros
        names = ros.namespaces() if ros is not None else []
        if names != list(self.world_select.options):
            value = self.studio.default_robot(names, self.world_select.value)
            self.world_select.set_options({ns: ns or "/" for ns in names}, value=value)
