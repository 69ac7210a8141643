"""examples/python/differential.ipynb runs from start to end (nbclient, the ipykernel kernel
`python3` of this interpreter) and its checks of the differential pass."""

import os
import sys

import nbformat
from jupyter_client.kernelspec import KernelSpecManager
from nbclient import NotebookClient

from conftest import SOURCE


def test_differential_notebook_runs_and_its_checks_pass():
    spec = KernelSpecManager().get_kernel_spec("python3")
    assert os.path.realpath(spec.argv[0]) == os.path.realpath(sys.executable), spec.argv  # Debian's python3, with NumPy
    path = SOURCE / "examples/python/differential.ipynb"
    nb = nbformat.read(path, as_version=4)
    # The kernel inherits this environment: PYTHONPATH names the build tree's package.
    NotebookClient(nb, kernel_name="python3", timeout=600, resources={"metadata": {"path": str(path.parent)}}).execute()
    text = [o.get("text", "") for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", []) if o.get("output_type") == "stream"]
    assert os.path.realpath(text[0].splitlines()[0]) == os.path.realpath(sys.executable)
    assert "all checks passed" in text[-1]
    assert sum("FAIL" in s for s in text) == 0
    images = [o for c in nb.cells for o in c.get("outputs", []) if "image/png" in o.get("data", {})]
    assert len(images) == 4
