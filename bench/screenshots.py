"""Save a screenshot of every panel of the desktop app to docs/screenshots/ (PNG).

    .venv/bin/python bench/screenshots.py [--out docs/screenshots]

Opens the app on the bundled demo scene (under Xvfb when there is no display), drives it to a meaningful
state (a glossy material at 45 degrees, the sampler view, a short side-by-side render) and grabs each panel
from the screen, so the OpenGL views are captured too.
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


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "screenshots")
    parser.add_argument("--material", default="polished copper")
    parser.add_argument("--render-b", default="analytic", help="the render panel's second strategy")
    args = parser.parse_args()
    ensure_display()
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
        top_left = widget.mapToGlobal(widget.rect().topLeft())
        rect = QRect(top_left, widget.size())
        pixmap = widget.screen().grabWindow(0, rect.x(), rect.y(), rect.width(), rect.height())
        args.out.mkdir(parents=True, exist_ok=True)
        path = args.out / f"{name}.png"
        pixmap.save(str(path), "PNG")
        print(
            f"wrote {path.relative_to(ROOT) if path.is_relative_to(ROOT) else path} ({rect.width()}x{rect.height()})"
        )

    if args.material in doc.material_names():
        doc.select_material(args.material)
    doc.set_direction(45.0, 0.0)
    window.refresh_now()
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

    window.tabs.setCurrentWidget(window.sampling_panel)
    settle(0.5, until=lambda: window.jobs_idle("sampling") and window.sampling_view.snapshot is not None)
    grab(window.sampling_panel, "sampling")

    window.tabs.setCurrentWidget(window.scene_panel)
    objects = [o.name for o in doc.data.objects]
    if objects:
        doc.select_object(objects[min(1, len(objects) - 1)])
    settle(0.5)
    grab(window.scene_panel, "scene")

    if hasattr(window, "render_view"):
        # The render panel on a small scene of models with analytic samplers: the demo scene's measured and
        # anisotropic materials need adaptive tables built first (minutes on a loaded 2-core machine).
        demo_dir = demo_scene_path().parent
        window.new_project()
        doc.add_material("lambert", name="floor", params={"kd": 0.6})
        window.import_mesh(demo_dir / "floor.obj")
        doc.add_material("phong", name="glossy")
        window.import_mesh(demo_dir / "torus.obj")
        window.tabs.setCurrentWidget(window.scene_panel)
        settle(0.3)
        cam = window.viewport.plotter.camera
        cam.position, cam.focal_point, cam.up = (0.0, 1.6, 4.5), (0.0, 0.3, 0.0), (0.0, 1.0, 0.0)
        panel = window.render_view
        panel.width_box.setValue(240)
        panel.height_box.setValue(160)
        panel.spp.setValue(8)
        panel.strategy_a.setCurrentText("uniform")
        panel.strategy_b.setCurrentText(args.render_b)
        window.start_render()
        settle(0.5, until=lambda: not panel.running, timeout=600)
        grab(window.render_panel, "render")
    window.close()
    from app.workers import exit_if_abandoned

    return exit_if_abandoned(0)


if __name__ == "__main__":
    sys.exit(main())
