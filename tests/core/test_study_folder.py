"""The sampler study over a folder on Dask (core.study_folder): a local cluster of two workers runs every
(file, angle) task, gathers the rows, and reports a corrupt file's tasks without losing the others."""

from __future__ import annotations

import pytest

from core.brdf import make_brdf
from core.errors import FileFormatError
from core.rgl.export import ExportOptions, tabulate
from core.rgl.material import write_bsdf
from core.study import StudyConfig
from core.study_folder import material_files, run_folder_study

pytest.importorskip("dask.distributed")

SMALL = ExportOptions(
    n_theta_i=6, n_phi_quadrant=3, vndf=(16, 16), samples=(8, 8), ndf=(16, 16), sigma=(16, 16)
)


def test_two_workers_run_every_task_and_report_failures(tmp_path):
    write_bsdf(tmp_path / "phong.bsdf", tabulate(make_brdf("phong", {"n": 30.0}), SMALL))
    write_bsdf(tmp_path / "ward.bsdf", tabulate(make_brdf("ward", {"sx": 0.1, "sy": 0.3}), SMALL))
    (tmp_path / "broken.bsdf").write_bytes(b"tensor_file\0\1\0")
    (tmp_path / "notes.txt").write_text("not a material")
    config = StudyConfig(
        thetas=(30.0, 60.0),
        counts=(16,),
        batch=1 << 11,
        reference_samples=1 << 13,
        samplers=("cosine", "analytic"),
    )
    seen = []
    study = run_folder_study(tmp_path, config, workers=2, progress=lambda d, n, t, e: seen.append((d, n, e)))
    assert study.tasks == 6 and study.workers == 2
    assert [d for d, _, _ in seen] == list(range(1, 7))
    assert len(study.failures) == 2
    assert all("broken.bsdf" in f.task.path and "truncated" in f.error for f in study.failures)
    cases = {(r.material, r.theta_o, r.light, r.sampler) for r in study.rows}
    assert len(cases) == 2 * 2 * 3 * 2  # materials x angles x lights x samplers
    assert {r.material for r in study.rows} == {"rgl:phong", "rgl:ward"}
    assert all(abs(r.bias_z) < 6.0 for r in study.rows)


def test_empty_or_missing_folder_is_a_clear_error(tmp_path):
    with pytest.raises(FileFormatError, match="holds no measured file"):
        material_files(tmp_path)
    with pytest.raises(FileFormatError, match="does not exist"):
        material_files(tmp_path / "nowhere")
