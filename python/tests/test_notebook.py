"""The example notebooks run: every code cell of python/examples/*.ipynb executed in order in
one namespace (the notebook's JSON read with the json module; no Jupyter needed). Plotting
cells use Matplotlib's Agg backend when Matplotlib is installed and skip themselves otherwise."""

import json

import numpy as np
import pytest

EXAMPLES = "python/examples"


def code_cells(path):
    notebook = json.loads(path.read_text(encoding="utf-8"))
    assert notebook["nbformat"] == 4
    for k, cell in enumerate(notebook["cells"]):
        if cell["cell_type"] == "code":
            source = "".join(cell["source"])
            assert not cell.get("outputs"), f"{path.name} cell {k}: stored outputs (clear them)"
            # IPython magics and shell escapes are no Python; the notebooks use none.
            assert not any(line.lstrip().startswith(("%", "!")) for line in source.splitlines()), k
            yield k, source


def run_notebook(path):
    namespace = {"__name__": "__main__"}
    for k, source in code_cells(path):
        exec(compile(source, f"{path.name}, cell {k}", "exec"), namespace)
    return namespace


@pytest.fixture
def quiet_matplotlib(monkeypatch, tmp_path):
    """Agg backend (no window), and the working directory in a temporary folder."""
    monkeypatch.setenv("MPLBACKEND", "Agg")
    monkeypatch.chdir(tmp_path)
    yield
    try:
        import matplotlib.pyplot as plt
    except ImportError:
        return
    plt.close("all")


def test_every_notebook_is_tested(root):
    assert sorted(p.name for p in (root / EXAMPLES).glob("*.ipynb")) == ["quickstart.ipynb"]


def test_quickstart_notebook_runs(root, quiet_matplotlib):
    ns = run_notebook(root / EXAMPLES / "quickstart.ipynb")
    # What the notebook computed, checked here against the exact solution and SciPy.
    sim, report = ns["sim"], ns["report"]
    assert sim.time == 20.0 and sim.steps == len(report["step"]) > 100
    t = report["time"]
    v = report["momentum_x"] / report["mass"]
    exact = 0.2 / np.pi * np.cos(np.pi * t / 5.0)
    assert np.abs(v - exact).max() == ns["err_max"] < 5e-3
    assert ns["M"].shape == (ns["grid"].num_nodes,) * 2
    np.testing.assert_allclose(ns["M"].sum(axis=1), ns["m_L"], rtol=1e-12, atol=1e-15)
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        assert ns["plt"] is None
    else:
        assert ns["fig"] is not None
