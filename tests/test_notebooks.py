"""The tutorial notebooks (examples/notebooks/) run from a clean kernel, and show pictures.

Each is executed with nbclient in a new kernel; every cell must run without error and the
notebook must show images that are not blank. The executed copies (with their pictures) are
kept in the test's temporary folder."""
from __future__ import annotations

import base64
import io
import re
import time
from pathlib import Path

import numpy as np
import pytest

nbformat = pytest.importorskip("nbformat", reason="nbformat is not installed (pip install 'lift-gl[test]')")
nbclient = pytest.importorskip("nbclient", reason="nbclient is not installed (pip install 'lift-gl[test]')")
pytest.importorskip("ipykernel", reason="the notebook extra is not installed (pip install 'lift-gl[notebook]')")
pytest.importorskip("anywidget", reason="the notebook extra is not installed (pip install 'lift-gl[notebook]')")

NOTEBOOKS = Path(__file__).resolve().parent.parent / "examples" / "notebooks"
TUTORIALS = ("first_render", "estimators", "denoiser", "viewer")


def execute(name: str, out: Path):
    book = nbformat.read(NOTEBOOKS / f"{name}.ipynb", as_version=4)
    start = time.perf_counter()
    nbclient.NotebookClient(book, timeout=600, kernel_name="python3",
                            resources={"metadata": {"path": str(NOTEBOOKS)}}).execute()
    seconds = time.perf_counter() - start
    out.mkdir(parents=True, exist_ok=True)
    nbformat.write(book, out / f"{name}.ipynb")
    return book, seconds


def pictures(book) -> list[np.ndarray]:
    from PIL import Image

    found = []
    for cell in book.cells:
        for output in cell.get("outputs", []):
            data = output.get("data", {})
            encoded = [data["image/png"]] if "image/png" in data else []
            # compare's result: its plot inside the HTML
            encoded += re.findall(r"data:image/png;base64,([A-Za-z0-9+/=]+)", "".join(data.get("text/html", "")))
            found += [np.asarray(Image.open(io.BytesIO(base64.b64decode(e))).convert("RGB")) for e in encoded]
    return found


def widgets(book) -> list[str]:
    return [output["data"]["application/vnd.jupyter.widget-view+json"]["model_id"]
            for cell in book.cells for output in cell.get("outputs", [])
            if "application/vnd.jupyter.widget-view+json" in output.get("data", {})]


@pytest.fixture(scope="module")
def executed(tmp_path_factory):
    return tmp_path_factory.mktemp("notebooks")


@pytest.mark.parametrize("name", TUTORIALS)
def test_notebook_runs_and_shows_pictures(name, executed):
    book, seconds = execute(name, executed)
    print(f"{name}: {seconds:.1f} s")
    images = pictures(book)
    if name == "viewer":   # a widget, no picture: test_notebook_browser.py looks at it in a browser
        assert widgets(book)
        return
    assert images, f"{name} shows no picture"
    for image in images:
        assert image.shape[0] >= 32 and image.shape[1] >= 32
        assert image.std() > 5, f"{name}: a blank picture"    # not one flat colour
    if name == "first_render":
        # the renders: pt, the template plugin, and the edited plugin (tinted, direct light only)
        assert len(images) >= 4
        pt, mine, edited = images[0].astype(float), images[2].astype(float), images[3].astype(float)
        assert abs(pt.mean() - mine.mean()) < 0.15 * pt.mean()        # the template converges to pt
        assert edited[..., 2].mean() / edited[..., 0].mean() > pt[..., 2].mean() / pt[..., 0].mean()  # blue tint
        assert widgets(book), "render(progress=True) showed no notebook progress bar"
    if name == "estimators":
        assert len(images) == 2   # compare's plot, and the one drawn from its rows
        html = "".join(o["data"]["text/html"] for c in book.cells for o in c.get("outputs", [])
                       if "text/html" in o.get("data", {}))
        for label in ("pt", "template", "bdpt"):
            assert f"<code>{label}</code>" in html   # the table's rows
