"""examples/quickstart.ipynb runs top to bottom in a real Jupyter kernel (nbclient + ipykernel),
without ``%matplotlib inline``, and its figures and results display as a user would see them."""

from __future__ import annotations

from pathlib import Path

import pytest

NOTEBOOK = Path(__file__).resolve().parents[1] / "examples" / "quickstart.ipynb"


def test_quickstart_notebook_executes_and_displays(tmp_path) -> None:
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")

    nb = nbformat.read(NOTEBOOK, as_version=4)
    assert not any("%matplotlib" in c.source for c in nb.cells), "must work without magics"
    client = nbclient.NotebookClient(nb, timeout=300, kernel_name="python3",
                                     resources={"metadata": {"path": str(tmp_path)}})
    client.execute()
    code = [c for c in nb.cells if c.cell_type == "code"]
    for cell in code:
        errors = [o for o in cell.outputs if o.output_type == "error"]
        assert not errors, f"{cell.source[:60]!r}: {errors[0].get('ename')}"
    figures = [c for c in code if "plots." in c.source]
    assert len(figures) == 2
    for cell in figures:
        pngs = [o for o in cell.outputs if "image/png" in o.get("data", {})]
        assert len(pngs) == 1, f"{cell.source[:40]!r}: {len(pngs)} images (want exactly one)"
        assert pngs[0]["data"]["image/png"].startswith("iVBOR")  # base64 of a PNG header
    html = [o["data"]["text/html"] for c in code for o in c.outputs
            if o.output_type == "execute_result" and "text/html" in o.get("data", {})]
    assert any("<code>ScenarioResult</code>" in h and "<table" in h for h in html)
    assert any("<code>SweepOutcome</code>" in h for h in html)
    overrides = next(c for c in code if "formation.followers" in c.source)
    assert overrides.outputs[0]["data"]["text/plain"] == "(20.0, 3)"
    # the scenario it loads is the one it runs (no load left unused)
    loads = next(c for c in code if "load_scenario(" in c.source and "=" in c.source)
    name = loads.source.split("=", 1)[0].strip()
    assert any(f"run_scenario({name}" in c.source for c in code)


#: Ways a user shows a figure, each of which must show it exactly once (no %matplotlib magic).
DISPLAY_CELLS = {
    "value": "plots.response_histogram(v)",
    "assigned, then the value": "fig = plots.response_histogram(v); fig",
    "assigned only": "fig = plots.response_histogram(v)",
    "plt.show()": "fig = plots.response_histogram(v)\nplt.show()",
    "display()": "fig = plots.response_histogram(v)\ndisplay(fig)",
    "scenario figure, plt.show()": "plots.plot_speed(df)\nplt.show()",
}


def test_figures_show_exactly_once_however_called(tmp_path) -> None:
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")

    setup = ("import numpy as np\nimport matplotlib.pyplot as plt\nfrom rtsim import plots\n"
             "from rtsim.coupling import run_scenario\n"
             "v = np.random.default_rng(0).normal(200.0, 5.0, 300)\n"
             "df = run_scenario('test1', duration_s=3, record_jobs=False).windows")
    saved = "plots.save_figure(plots.response_histogram(v), 'h.png')"  # written, not shown
    cells = [setup, *DISPLAY_CELLS.values(), saved]
    nb = nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell(c) for c in cells])
    nbclient.NotebookClient(nb, timeout=300, kernel_name="python3",
                            resources={"metadata": {"path": str(tmp_path)}}).execute()
    shown = [sum("image/png" in o.get("data", {}) for o in c.outputs) for c in nb.cells]
    assert shown == [0, *([1] * len(DISPLAY_CELLS)), 0], dict(zip(["setup", *DISPLAY_CELLS,
                                                                  "saved"], shown,
                                                                 strict=True))
    assert (tmp_path / "h.png").read_bytes().startswith(b"\x89PNG")
