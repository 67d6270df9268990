"""The studio's Submit page in headless Chromium hands in the workspace's controller, as
``robot_sims classroom submit`` does."""

from __future__ import annotations

import json
import stat
from pathlib import Path

import pytest
from studio_browser_support import (
    click_text,
    find,
    new_browser,
    open_page,
    running_studio,
    studio_domain,
    type_into,
    wait,
)

from sim_tools.classroom.submit import current_user

DOMAIN = studio_domain(70)  # the other studio modules use 50-62


def test_the_submit_button_hands_in_the_chosen_controller_and_says_so(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    course, workspace = tmp_path / "course", tmp_path / "work"
    drop = course / "submissions" / "lab1"
    (drop / current_user()).mkdir(parents=True, mode=0o700)
    public = {"name": "lab1", "deadline": "2099-01-01T00:00:00+00:00", "late": "refuse", "form": "python"}
    (drop / "assignment.json").write_text(json.dumps({**public, "suffix": ".py"}))
    workspace.mkdir()
    (workspace / "wander.py").write_text("def main():\n    pass\n")
    monkeypatch.setenv("ROBOT_SIMS_COURSE", str(course))
    with running_studio(workspace, DOMAIN) as url, new_browser() as driver:
        open_page(driver, f"{url}/submit")
        type_into(driver, ".studio-submit-assignment", "lab1")
        click_text(driver, "Submit")
        message = find(driver, ".studio-submit-message")
        wait(driver, lambda d: message.text.startswith("submitted"), timeout=30)
        assert message.text.startswith(f"submitted controller.py for lab1 as {current_user()} at ")
        stored = drop / current_user() / "controller.py"
        assert stored.read_text() == "def main():\n    pass\n" and stat.S_IMODE(stored.stat().st_mode) == 0o600
        type_into(driver, ".studio-submit-assignment", "lab2")
        click_text(driver, "Submit")
        wait(driver, lambda d: message.text.startswith("no assignment 'lab2'"), timeout=30)
