"""Shared by the tests of the Python module: where the sources and the command line are (CTest
sets MULTIBOND_SOURCE_DIR and MULTIBOND_CLI; PYTHONPATH points at the build tree's package)."""

import csv
import os
import pathlib
import subprocess

import numpy as np
import pytest

SOURCE = pathlib.Path(os.environ.get("MULTIBOND_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2]))
CLI = os.environ.get("MULTIBOND_CLI", str(SOURCE / "build/ci/apps/multibond"))


def example(name):
    return SOURCE / "examples" / name


def cli(*args):
    """Runs the command line; returns the completed process (check it yourself)."""
    return subprocess.run([CLI, *map(str, args)], capture_output=True, text=True, timeout=300)


def read_results_csv(path):
    """results.csv as (names, units, rows x columns array)."""
    with open(path, newline="") as f:
        header = next(csv.reader(f))
    names = [h.rsplit(" [", 1)[0] for h in header]
    units = [h.rsplit(" [", 1)[1][:-1] for h in header]
    return names, units, np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)


@pytest.fixture
def msd():
    import multibond

    return multibond.load(example("mass_spring_damper.yaml"), jit="off")
