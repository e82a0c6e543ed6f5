"""bhr traverse: designs x anatomical colons, locally and on a real Dask LocalCluster, its outputs and page: the tests that use outside parts."""
from __future__ import annotations

import json

from bhr._studies.traverse import build_study, run_study
from tests.cli.test_sweep import dask_cluster  # noqa: F401 - the real LocalCluster fixture
from tests.unit.test_traverse import PNG, SMALL, run_cli, small_study  # noqa: F401


def test_dask_cluster_gives_the_local_study(dask_cluster, small_study):  # noqa: F811
    cwd, _ = small_study
    proc = run_cli("traverse", *SMALL, "--no-plots", "--out", "dask", "--scheduler", dask_cluster.scheduler_address,
                   cwd=cwd)
    assert proc.returncode == 0, proc.stderr
    assert f"on dask {dask_cluster.scheduler_address}" in proc.stdout
    for name in ("designs.csv", "runs.csv"):
        assert (cwd / "dask" / name).read_bytes() == (cwd / "study" / name).read_bytes()
    doc = json.loads((cwd / "dask" / "study.json").read_text())
    assert doc["runner"] == f"dask {dask_cluster.scheduler_address}" and doc["workers"] == 2


def test_library_study_on_dask_equals_local(dask_cluster):  # noqa: F811
    study = build_study([("module_length", (6, 8))], "1-3")
    seen = []
    remote = run_study(study, scheduler=dask_cluster.scheduler_address, progress=lambda d, t: seen.append(d))
    local = run_study(study, jobs=1)
    assert remote.runs == local.runs and remote.designs == local.designs
    assert seen[-1] == 6


def test_page_loads_in_chromium_without_console_errors(small_study, tmp_path):
    from tests.integration.test_report_browser import Browser, need_chromium

    cwd, _ = small_study
    b = Browser(need_chromium())
    try:
        b.load((cwd / "study" / "index.html").as_uri())
        assert b.console_errors() == []
        assert b.evaluate("document.querySelector('h1').textContent") == "bhr traverse"
        assert "best: design #" in b.evaluate("document.querySelector('#answer').textContent")
        sizes = b.evaluate("Promise.all([...document.images].map(i => i.decode().then(() => "
                           "[i.naturalWidth, i.naturalHeight])))")
        assert len(sizes) == 2 and all(w > 300 and h > 200 for w, h in sizes)
        assert b.evaluate("document.querySelectorAll('#designs tbody tr').length") == 4
        assert b.evaluate("document.querySelectorAll('#designs tbody tr.meets').length") >= 1
        from tests.integration.test_report_browser import check_fits

        check_fits(b)  # the page fits a 1280 px window (tables scroll inside it)
        assert b.screenshot(tmp_path / "page.png")[:8] == PNG
    finally:
        b.close()
