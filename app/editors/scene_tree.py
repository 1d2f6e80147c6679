"""The scene tree: objects (each with a material chooser), materials, lights (and the environment) and the
camera; selection is the document's, both ways. Lights are added and deleted from the context menu.

Widths: only objects use the second column (their material choosers), so every other row spans both columns
and the first column is as wide as the objects' names; the choosers take the rest of the width and, when it
is short of the longest material name, show the current name elided at its end (whole in the tooltip and in
the chooser's list, which is as wide as the longest name). A material's model is in its row's tooltip."""

from __future__ import annotations

from PySide6.QtCore import Qt, Signal
from PySide6.QtWidgets import QAbstractItemView, QMenu, QTreeWidget, QTreeWidgetItem

from app.document import Document
from app.editors.combo import ElidedComboBox
from core.errors import BrdfStudioError
from core.scene import PointLight, QuadLight

ROLE_KIND = Qt.ItemDataRole.UserRole
ROLE_NAME = Qt.ItemDataRole.UserRole + 1


class MaterialChooser(ElidedComboBox):
    """A material chooser that fits the width it is given: it asks for room for :attr:`MIN_CHARS` characters
    only, shows the current name elided at its end when the name does not fit, and opens a list as wide as the
    longest name."""

    MIN_CHARS = 12

    def __init__(self, names: list[str], current: str):
        super().__init__(self.MIN_CHARS)
        self.addItems(names)
        self.setCurrentText(current)
        self.setToolTip(current)
        self.fit_list()


class SceneTree(QTreeWidget):
    """Emits ``error(str)`` for edits the document refuses."""

    error = Signal(str)

    def __init__(self, document: Document, parent=None):
        super().__init__(parent)
        self.document = document
        self.setColumnCount(2)
        self.setHeaderLabels(["Scene", "Material"])
        self.setSelectionMode(QAbstractItemView.SelectionMode.SingleSelection)
        self.setContextMenuPolicy(Qt.ContextMenuPolicy.CustomContextMenu)
        self.customContextMenuRequested.connect(self._context_menu)
        self.roots = {}
        for key, label in (
            ("objects", "Objects"),
            ("materials", "Materials"),
            ("lights", "Lights"),
            ("camera", "Camera"),
        ):
            item = QTreeWidgetItem([label])
            item.setFlags(item.flags() & ~Qt.ItemFlag.ItemIsSelectable)
            item.setData(0, ROLE_KIND, f"root:{key}")
            self.addTopLevelItem(item)
            item.setFirstColumnSpanned(True)
            self.roots[key] = item
        self.combos: dict[str, MaterialChooser] = {}
        self.itemSelectionChanged.connect(self._selection_from_tree)
        ev = document.events
        ev.meshes.connect(lambda _items: self.rebuild())
        ev.materials.connect(lambda items: self.rebuild() if items is None else self._relabel_materials())
        for name in ("lights", "environment", "camera"):
            ev[name].connect(lambda _items: self._rebuild_scene_items())
        document.selection_changed.connect(self._selection_from_document)
        self.rebuild()

    def rebuild(self) -> None:
        doc = self.document
        self.blockSignals(True)
        for key in ("objects", "materials"):
            self.roots[key].takeChildren()
        self.combos.clear()
        for o in doc.objects():
            item = QTreeWidgetItem([o.name, ""])
            item.setData(0, ROLE_KIND, "object")
            item.setData(0, ROLE_NAME, o.name)
            self.roots["objects"].addChild(item)
            combo = MaterialChooser(doc.material_names(), o.material)
            combo.activated.connect(lambda i, n=o.name, c=combo: self._assign(n, c.itemText(i)))
            self.setItemWidget(item, 1, combo)
            self.combos[o.name] = combo
        for m in doc.scene.materials:
            item = QTreeWidgetItem([m.name, ""])
            item.setData(0, ROLE_KIND, "material")
            item.setData(0, ROLE_NAME, m.name)
            self.roots["materials"].addChild(item)
            item.setFirstColumnSpanned(True)
        self._add_scene_items()
        for root in self.roots.values():
            root.setExpanded(True)
        self._relabel_materials()
        self.blockSignals(False)
        self._selection_from_document()
        self.setColumnWidth(0, self.names_width())  # the objects' names whole; the choosers take the rest

    def names_width(self) -> int:
        """The first column's width: the objects' names whole (the other rows span both columns)."""
        fm = self.fontMetrics()
        names = [fm.horizontalAdvance(o.name) for o in self.document.objects()]
        return max([self.header().sectionSizeHint(0), *(n + 2 * self.indentation() + 12 for n in names)])

    def _rebuild_scene_items(self) -> None:
        """Only the lights, environment and camera (their edits leave objects and materials alone)."""
        self.blockSignals(True)
        self._add_scene_items()
        self.blockSignals(False)
        self._selection_from_document()

    def _add_scene_items(self) -> None:
        doc = self.document
        for key in ("lights", "camera"):
            self.roots[key].takeChildren()
        for i, light in enumerate(doc.scene.lights):
            item = QTreeWidgetItem([light_label(light, i), ""])
            item.setData(0, ROLE_KIND, "light")
            item.setData(0, ROLE_NAME, i)
            self.roots["lights"].addChild(item)
            item.setFirstColumnSpanned(True)
        env = doc.scene.environment
        item = QTreeWidgetItem([f"environment ({env.type if env else 'none'})", ""])
        item.setData(0, ROLE_KIND, "environment")
        item.setData(0, ROLE_NAME, 0)
        self.roots["lights"].addChild(item)
        item.setFirstColumnSpanned(True)
        cam_item = QTreeWidgetItem([f"pinhole, fov {doc.scene.camera.fov_deg:.3g} deg", ""])
        cam_item.setData(0, ROLE_KIND, "camera")
        cam_item.setData(0, ROLE_NAME, 0)
        self.roots["camera"].addChild(cam_item)
        cam_item.setFirstColumnSpanned(True)

    def _relabel_materials(self) -> None:
        doc = self.document
        root = self.roots["materials"]
        for i in range(root.childCount()):
            item = root.child(i)
            name = item.data(0, ROLE_NAME)
            try:
                label = doc.brdf(name).model.label
            except (BrdfStudioError, KeyError):
                label = "?"
            item.setToolTip(0, f"{name}: {label}")

    def item_for(self, kind: str, name: str | int = 0) -> QTreeWidgetItem | None:
        """The item of an ``object`` or ``material`` (by name), a ``light`` (by index), the ``camera`` or
        the ``environment``."""
        root = self.roots[
            {"object": "objects", "material": "materials", "camera": "camera"}.get(kind, "lights")
        ]
        for i in range(root.childCount()):
            child = root.child(i)
            if child.data(0, ROLE_KIND) == kind and child.data(0, ROLE_NAME) == name:
                return child
        return None

    def _assign(self, obj: str, material: str) -> None:
        try:
            self.document.assign_material(obj, material)
        except BrdfStudioError as exc:
            self.error.emit(str(exc))

    def _selection_from_tree(self) -> None:
        items = self.selectedItems()
        if not items:
            return
        kind, name = items[0].data(0, ROLE_KIND), items[0].data(0, ROLE_NAME)
        if kind == "object":
            self.document.select_object(name)
        elif kind == "material":
            self.document.select_object(None)
            self.document.select_material(name)
        elif kind in ("light", "camera", "environment"):
            self.document.select_item(kind, int(name))

    def _selection_from_document(self) -> None:
        doc = self.document
        item = None
        if doc.selected_item is not None:
            item = self.item_for(*doc.selected_item)
        elif doc.selected_object:
            item = self.item_for("object", doc.selected_object)
        elif doc.current_material:
            item = self.item_for("material", doc.current_material)
        self.blockSignals(True)
        self.clearSelection()
        if item is not None:
            item.setSelected(True)
            self.scrollToItem(item)
        self.blockSignals(False)

    def _context_menu(self, pos) -> None:
        item = self.itemAt(pos)
        if item is None or item.data(0, ROLE_KIND) is None:
            return
        kind, name = item.data(0, ROLE_KIND), item.data(0, ROLE_NAME)
        menu = QMenu(self)
        if kind in ("root:lights", "light", "environment"):
            menu.addAction("Add point light", lambda: self._guard(self.document.add_light, "point"))
            menu.addAction("Add quad light", lambda: self._guard(self.document.add_light, "quad"))
            if kind == "light":
                menu.addAction("Delete light", lambda: self._guard(self.document.remove_light, int(name)))
        elif kind.startswith("root:") or kind == "camera":
            return
        elif kind == "object":
            assign = menu.addMenu("Assign material")
            for m in self.document.material_names():
                assign.addAction(m, lambda m=m: self._assign(name, m))
            menu.addAction("Delete object", lambda: self._guard(self.document.remove_object, name))
        else:
            menu.addAction("Rename material ...", lambda: self._rename(name))
            menu.addAction("Delete material", lambda: self._guard(self.document.remove_material, name))
        menu.exec(self.viewport().mapToGlobal(pos))

    def _rename(self, name: str) -> None:
        from PySide6.QtWidgets import QInputDialog

        new, ok = QInputDialog.getText(self, "Rename material", "New name:", text=name)
        if ok:
            self._guard(self.document.rename_material, name, new)

    def _guard(self, fn, *args) -> None:
        try:
            fn(*args)
        except (BrdfStudioError, KeyError) as exc:
            self.error.emit(str(exc))

    def content_width(self) -> int:
        """The width that shows every name and chooser whole (the dock's width on first open)."""
        fm = self.fontMetrics()
        spanned = max(
            (fm.horizontalAdvance(root.child(i).text(0)) + 2 * self.indentation() + 12
             for root in self.roots.values() for i in range(root.childCount())),
            default=0,
        )  # fmt: skip
        choosers = max((c.width_for_all() for c in self.combos.values()), default=0)
        return max(spanned, self.names_width() + choosers) + 2 * self.frameWidth() + 8


def light_label(light: PointLight | QuadLight, index: int) -> str:
    """How the tree names a light: its type and number (lights have no names in the scene format)."""
    return f"{light.type} light {index + 1}"
