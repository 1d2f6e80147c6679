"""Save a screenshot of every panel of the desktop app to docs/screenshots/ (PNG).

    .venv/bin/python bench/screenshots.py [--out docs/screenshots] [--only render,scene,...]

Opens the app on the bundled demo scene (under Xvfb when there is no display), drives it to a meaningful
state (a glossy material at 45 degrees, the sampler view, the demo scene's reference made in the app with
*Make reference*, then uniform against adaptive sampling at equal time with the live RMSE/relMSE plot and the
verdict) and grabs each panel from the screen, so the OpenGL views are captured too. The whole window is also
shot as large as common screens leave it (:data:`SCREENS`, ``window_<W>x<H>.png``), as
``tests/app/test_layout.py`` checks it.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _display import ensure_display  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SCREENS = ((1366, 768), (1600, 1000), (1920, 1080))
DESKTOP_PX = 70
"""What a desktop takes from a screen's height: a window manager's title bar and a panel."""
SCREEN_SHOTS = tuple(f"window_{w}x{h}" for w, h in SCREENS)
EXPLORE_SHOTS = (
    "window", "explore", "lobe", "polar", "albedo", "lit_sphere", "direction", "material_editor", "scene_tree",
    *SCREEN_SHOTS,
)  # fmt: skip


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "screenshots")
    parser.add_argument("--material", default="polished copper")
    parser.add_argument("--render-a", default="uniform", help="the render panel's first strategy")
    parser.add_argument("--render-b", default="adaptive_warp", help="the render panel's second strategy")
    parser.add_argument("--render-seconds", type=float, default=20.0, help="equal time of each strategy")
    parser.add_argument("--reference-spp", type=int, default=512, help="samples per pixel of the reference")
    parser.add_argument("--render-size", default="288x192", help="render size, WIDTHxHEIGHT")
    parser.add_argument(
        "--only", default="", help="comma-separated screenshot names to write (default: all of them)"
    )
    args = parser.parse_args()
    only = {name.strip() for name in args.only.split(",") if name.strip()}
    width, height = (int(v) for v in args.render_size.lower().split("x"))
    ensure_display("1920x1080x24")  # room for the largest of SCREENS
    os.environ.setdefault("BRDF_STUDIO_CONFIG_DIR", tempfile.mkdtemp(prefix="brdf-studio-shots-"))

    from PySide6.QtCore import QRect
    from PySide6.QtWidgets import QApplication, QWidget

    from app.main_window import MainWindow, demo_scene_path

    app = QApplication.instance() or QApplication([])
    window = MainWindow(warm_up=False)
    window.ask_unsaved = lambda: "discard"
    window.resize(1500, 950)
    window.show()
    window.start(demo_scene_path(), restore="no")
    doc = window.document

    def settle(seconds: float = 0.5, until=None, timeout: float = 300.0) -> None:
        end = time.monotonic() + timeout
        stop = time.monotonic() + seconds
        while time.monotonic() < stop or (until is not None and not until() and time.monotonic() < end):
            app.processEvents()
            time.sleep(0.02)
        window.refresh_now()
        app.processEvents()

    def grab(widget: QWidget, name: str) -> None:
        if only and name not in only:
            return
        top_left = widget.mapToGlobal(widget.rect().topLeft())
        rect = QRect(top_left, widget.size())
        pixmap = widget.screen().grabWindow(0, rect.x(), rect.y(), rect.width(), rect.height())
        args.out.mkdir(parents=True, exist_ok=True)
        path = args.out / f"{name}.png"
        pixmap.save(str(path), "PNG")
        print(
            f"wrote {path.relative_to(ROOT) if path.is_relative_to(ROOT) else path} ({rect.width()}x{rect.height()})"
        )

    def wanted(*names: str) -> bool:
        return not only or bool(only & set(names))

    if args.material in doc.material_names():
        doc.select_material(args.material)
    doc.set_direction(45.0, 0.0)
    window.refresh_now()
    if wanted(*EXPLORE_SHOTS, "sampling"):
        window.flush_slow_jobs()
        settle(1.0, until=lambda: window.jobs_idle("albedo", "adaptive"))
    window.tabs.setCurrentWidget(window.explore)
    settle(0.5)
    grab(window, "window")
    grab(window.explore, "explore")
    grab(window.lobe_view, "lobe")
    grab(window.polar_view, "polar")
    grab(window.albedo_view, "albedo")
    grab(window.sphere_view, "lit_sphere")
    grab(window.direction_editor, "direction")
    grab(window.material_dock, "material_editor")
    grab(window.tree_dock, "scene_tree")
    if wanted(*SCREEN_SHOTS):
        size = window.size()
        for (w, h), name in zip(SCREENS, SCREEN_SHOTS, strict=True):
            window.resize(w, h - DESKTOP_PX)
            settle(0.5)
            window.size_docks_to_content()
            settle(0.5, until=lambda: window.jobs_idle())
            grab(window, name)
        window.resize(size)
        settle(0.5)
        window.size_docks_to_content()

    if wanted("sampling"):
        window.tabs.setCurrentWidget(window.sampling_panel)
        settle(0.5, until=lambda: window.jobs_idle("sampling") and window.sampling_view.snapshot is not None)
        grab(window.sampling_panel, "sampling")

    window.tabs.setCurrentWidget(window.scene_panel)
    objects = [o.name for o in doc.objects()]
    if objects:
        doc.select_object(objects[min(1, len(objects) - 1)])
    settle(0.5)
    grab(window.scene_panel, "scene")

    if hasattr(window, "render_view") and wanted("render"):
        # The demo scene as saved (its camera, all its materials), each strategy to the same few spp. The
        # adaptive sampler's tables come from the table cache when an earlier run built them; the first run
        # builds them in the render process (a minute or more on a loaded 2-core machine).
        window.open_project(demo_scene_path(), confirm=False, remember=False)
        window.tabs.setCurrentWidget(window.scene_panel)
        settle(0.5)
        panel = window.render_view
        panel.width_box.setValue(width)
        panel.height_box.setValue(height)
        from app import reference

        reference.TARGET_SPP = args.reference_spp
        t0 = time.monotonic()
        window.make_reference()
        runner = panel.reference_runner
        settle(0.5, until=lambda: not runner.wanted, timeout=7200)
        done = runner.reference.spp if runner.reference is not None else 0
        print(f"reference: {done} spp ({time.monotonic() - t0:.0f} s with preparation)")
        panel.mode.setCurrentIndex(panel.mode.findData("time"))
        panel.seconds.setValue(args.render_seconds)
        panel.strategy_a.setCurrentText(args.render_a)
        panel.strategy_b.setCurrentText(args.render_b)
        t0 = time.monotonic()
        window.start_render()
        settle(0.5, until=lambda: not panel.running, timeout=3600)
        print(f"render: {panel.status_text} ({time.monotonic() - t0:.0f} s with preparation)")
        print(f"verdict: {panel.error_plot.verdict}")
        if window.errors:
            print("errors: " + "; ".join(window.errors))
        grab(window.render_panel, "render")
    window.close()
    from app.workers import exit_if_abandoned

    return exit_if_abandoned(0)


if __name__ == "__main__":
    sys.exit(main())
