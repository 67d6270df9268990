"""The Submit page (``/submit``): hand in a controller of the workspace for an assignment.

The button calls :func:`sim_tools.classroom.submit.submit`, as ``robot_sims classroom submit``
does, for the file chosen (a Python module or an m-file of the workspace) and says what happened
in a sentence: the receipt, or why it was refused (the deadline, the form, no folder of yours).
The course is ``$ROBOT_SIMS_COURSE`` (the hub sets it); ``$ROBOT_SIMS_ASSIGNMENT`` fills in the
assignment's name.
"""

from __future__ import annotations

import os

from nicegui import ui

from sim_runtime.errors import InputError
from sim_tools.classroom.submit import COURSE_ENV, submit
from studio.shell.app import Studio
from studio.shell.kit import nav
from studio.shell.workspace import Workspace

ASSIGNMENT_ENV = "ROBOT_SIMS_ASSIGNMENT"


def submit_file(workspace: Workspace, assignment: str, name: str) -> tuple[bool, str]:
    """Submit the workspace's file ``name`` for ``assignment``: (whether it was taken, the sentence)."""
    if not assignment.strip():
        return False, "give the assignment's name (your teacher gave it)"
    if not name:
        return False, "choose the controller to hand in"
    try:
        receipt = submit(assignment.strip(), workspace.path(name))
    except (InputError, OSError) as error:
        return False, str(error)
    return True, receipt.sentence()


def register(studio: Studio) -> None:
    @ui.page("/submit")
    def submit_page() -> None:
        SubmitPage(studio)


class SubmitPage:
    def __init__(self, studio: Studio) -> None:
        self.studio = studio
        nav("/submit")
        with ui.column().classes("p-4 gap-2"):
            ui.label("Hand in a controller of your workspace (the latest one you submit is graded)")
            course = os.environ.get(COURSE_ENV)
            if not course:
                ui.label(f"no course set (${COURSE_ENV}): ask your teacher").classes("text-orange-700")
            self.assignment = ui.input("assignment", value=os.environ.get(ASSIGNMENT_ENV, "")).classes(
                "w-64 studio-submit-assignment"
            )
            files = studio.workspace.files((".py", ".m"))
            self.file = ui.select(files, label="controller", value=files[0] if files else None).classes(
                "w-96 studio-submit-file"
            )
            ui.button("Submit", on_click=self.send).classes("studio-submit-button")
            self.message = ui.label("").classes("studio-submit-message")

    def send(self) -> None:
        ok, text = submit_file(self.studio.workspace, str(self.assignment.value or ""), str(self.file.value or ""))
        self.message.text = text
        self.message.classes(replace="studio-submit-message " + ("text-green-700" if ok else "text-red-700"))
