"""The job runner (typed jobs in lanes: one at a time, the latest request next, stale results dropped,
cancel) and the action table (every action calls a method the window has; one line adds an action)."""

from __future__ import annotations

import threading
import time

import pytest

from app.actions import ACTIONS, ActionSpec, install_actions
from app.jobs import Job, JobRunner

pytestmark = pytest.mark.gui


def test_a_lane_runs_the_latest_request_and_drops_stale_results(qtbot):
    runner = JobRunner()
    gate = threading.Event()
    shown: list[int] = []

    def slow(x: int) -> int:
        gate.wait(5.0)
        return x

    lane = runner.lane("work")
    for x in (1, 2, 3):  # 1 runs; 2 waits and is replaced by 3
        lane.submit(Job(slow, (x,), key=x, done=shown.append))
    assert not runner.idle("work")
    gate.set()
    qtbot.waitUntil(lambda: runner.idle("work"), timeout=5000)
    assert shown == [3]  # 1 finished while 3 was asked for: stale, never shown; 2 never ran
    runner.shutdown()


def test_failures_progress_and_cancel(qtbot):
    runner = JobRunner()
    failures: list[str] = []
    progress: list[int] = []
    from core.errors import ParameterError

    def bad() -> None:
        raise ParameterError("kd is outside its allowed range")

    runner.submit("a", Job(bad, key=1, failed=failures.append))
    qtbot.waitUntil(lambda: runner.idle("a"), timeout=5000)
    assert failures == ["kd is outside its allowed range"] and runner.errors() == {"a": failures[0]}

    def counting():
        for i in range(1000):
            time.sleep(0.01)
            yield i

    runner.submit("b", Job(counting, key=2, progress=progress.append))
    qtbot.waitUntil(lambda: len(progress) >= 3, timeout=5000)
    runner.lane("b").cancel()
    qtbot.waitUntil(lambda: runner.idle("b"), timeout=5000)
    assert len(progress) < 1000  # stopped at a yield
    runner.shutdown()


def test_every_action_calls_a_window_method_or_a_dialog(window):
    import importlib

    for spec in ACTIONS:
        if ":" in spec.method:  # a dialog in a module of its own, called with the window
            module, _, function = spec.method.partition(":")
            assert callable(getattr(importlib.import_module(module), function, None)), spec.method
        else:
            assert callable(getattr(window, spec.method, None)), spec.method
        if spec.attribute:
            assert getattr(window, spec.attribute).text().startswith(spec.text)  # Undo adds what it undoes
    titles = [a.text() for a in window.menuBar().actions()]
    assert titles[:4] == ["&File", "&Edit", "&Render", "&View"]


def test_one_line_adds_an_action(qtbot):
    from PySide6.QtWidgets import QMainWindow

    class Window(QMainWindow):
        calls: list[str] = []

        def fit(self, what: str) -> None:
            self.calls.append(what)

    w = Window()
    qtbot.addWidget(w)
    menus = install_actions(
        w, [ActionSpec("&Tools", "&Fit ...", "fit", ("measured",), attribute="fit_action")]
    )
    assert "&Tools" in menus
    w.fit_action.trigger()
    assert w.calls == ["measured"]
