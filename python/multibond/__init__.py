"""multibond from Python: load a bond-graph model (YAML), run it, analyse it.

    import multibond
    model = multibond.load("examples/mass_spring_damper.yaml")
    r = model.run(t_end=5, dt=1e-3)
    r.time, r["spring.q"]           # NumPy views of the results (no copy)
    r.to_pandas()                   # a DataFrame
    model.linearize()["A"]          # the linear model about the initial state

The simulation runs in C++ (the multibond library) with the GIL released, so threads can run
models in parallel; Ctrl-C stops a run on the main thread and raises KeyboardInterrupt (its
``results`` attribute holds the rows computed).
"""

import sys as _sys

try:
    import numpy as _np
except ImportError as _e:  # an interpreter without NumPy (a pyenv or venv one, often first on PATH)
    raise ImportError(
        f"multibond needs NumPy, which this Python ({_sys.executable}, {_sys.version.split()[0]}) does not have: "
        "run it with Debian's /usr/bin/python3 (apt-get install python3-numpy; scripts/install-deps does), "
        "or install NumPy into this interpreter") from _e

from ._errors import Diagnostic, ModelError, SimulationError

try:
    from ._multibond import Model, Results, __version__, _sweep
except ImportError as _e:  # the extension was built for another interpreter
    import pathlib as _pathlib
    _built = sorted(p.name for p in _pathlib.Path(__file__).parent.glob("_multibond*.so"))
    raise ImportError(
        f"multibond's compiled module {', '.join(_built) or '(none found)'} does not load into this Python "
        f"({_sys.executable}, {_sys.version.split()[0]}): it is built for the interpreter CMake found "
        "(Debian's /usr/bin/python3 when there is one); run that interpreter, "
        f"e.g. PYTHONPATH={_pathlib.Path(__file__).parent.parent} /usr/bin/python3 ({_e})") from _e

__all__ = ["load", "loads", "sweep", "Model", "Results", "LinearModel", "ModelError", "SimulationError", "Diagnostic", "__version__"]


def _parameter_values(parameters):
    values = []
    for name, value in (parameters or {}).items():
        if isinstance(value, bool) or not isinstance(value, (int, float, str)):
            raise TypeError(f"parameter {name!r}: a number or a formula (str), not {type(value).__name__}")
        values.append((name, value if isinstance(value, str) else repr(float(value))))
    return values


def load(path, *, jit="auto", constraints=None, algebraic_loops=None, parameters=None, **more_parameters):
    """Loads a model file. Keyword arguments give the file's top-level parameters their values
    (numbers or formula strings), as ``multibond run --set NAME=VALUE``; a parameter called like
    one of the options goes in ``parameters={...}``. ``jit``: "auto", "on", "off" (the right-hand
    side as generated C++, or the plan interpreter); ``constraints``: "ideal" or "compliant";
    ``algebraic_loops``: "solve" or "error" (over the file's settings).
    Raises ModelError for a bad model, ValueError for a parameter the file does not declare."""
    values = _parameter_values({**(parameters or {}), **more_parameters})
    return Model._load(str(path), values, jit, constraints, algebraic_loops)


def loads(yaml_text, *, file="<string>", jit="auto", constraints=None, algebraic_loops=None, parameters=None, **more_parameters):
    """Loads a model from its YAML text; ``file`` names it in diagnostics. As load()."""
    values = _parameter_values({**(parameters or {}), **more_parameters})
    return Model._loads(yaml_text, file, values, jit, constraints, algebraic_loops)


def _spec(value):
    """A grid, list or distribution as the command line writes it: "10:1000:log:20", "1,2,5", "uniform:1:2"."""
    if isinstance(value, str):
        return value
    return ":".join(str(v) if isinstance(v, str) else repr(float(v)) for v in value)


def sweep(study, out=None, *, grid=None, values=None, sample=None, keep=None, samples=None, seed=None, method=None,
          parameters=None, threads=0, resume=False, jit="auto", t_end=None, dt=None, solver=None, rtol=None, atol=None,
          results=False):
    """Runs a parameter sweep or Monte Carlo study (docs/sweeps.md), as ``multibond sweep``, on
    ``threads`` threads (0: every core) with the GIL released, and returns sweep.csv as a pandas
    DataFrame (one row per run: run, the swept parameters, status, the kept quantities, reason).

    ``study``: a study file, or a model file with the study given here: ``grid={"k": (10, 1000,
    "log", 20)}`` (or "10:1000:log:20"), ``values={"c": [1, 2]}``, ``sample={"m": ("normal", 1,
    0.1)}`` with ``samples`` and ``seed``, ``keep={"x_max": "max:spring.q"}``; ``parameters``
    fixes others for every run. ``out``: the folder of sweep.csv, sweep.json and the plots (a
    temporary one, removed, when None). Raises ModelError for a bad study (every problem, located)."""
    import tempfile

    import pandas as pd

    grids = [f"{n}={_spec(v)}" for n, v in (grid or {}).items()]
    lists = [f"{n}=" + (v if isinstance(v, str) else ",".join(repr(float(x)) for x in v)) for n, v in (values or {}).items()]
    samples_of = [f"{n}={_spec(v)}" for n, v in (sample or {}).items()]
    keeps = [f"{n}={v}" for n, v in (keep or {}).items()]
    set_values = _parameter_values(parameters)

    def run(folder):
        csv = _sweep(str(study), str(folder), grids, lists, samples_of, keeps, samples, seed, method, set_values, int(threads),
                     bool(resume), jit, t_end, dt, solver, rtol, atol, bool(results))
        return pd.read_csv(csv, float_precision="round_trip", keep_default_na=False, na_values=["nan"])

    if out is not None:
        return run(out)
    with tempfile.TemporaryDirectory(prefix="multibond-sweep-") as folder:
        return run(folder)


def _run(self, t_end=None, dt=None, solver=None, rtol=None, atol=None, set=None, *, step=None, max_step=None,
         coordinates=None, jacobian="auto", project=True, all_variables=False):
    """Runs the model from 0 to ``t_end`` with output every ``dt``; unset options take the model
    file's ``simulation:`` values, else the defaults (1 s, 1e-3 s, bdf, 1e-8, 1e-10), as
    ``multibond run``. ``set``: {element: value} for this run only (I inertia, C stiffness, R
    resistance, TF/GY ratio, a source's constant value; a number, a vector or a matrix), as the
    C++ API's SetParameter; ``Model.set_parameter`` keeps a value for every later run.
    Returns Results; raises SimulationError (with the partial results) when the run fails,
    KeyboardInterrupt on Ctrl-C."""
    return self._run(t_end, dt, solver, rtol, atol, step, max_step, coordinates, jacobian, project, all_variables, set)


class LinearModel(dict):
    """The linear model dz/dt = A z + B u, y = C z + D u (linear.json's keys: states, inputs,
    outputs, A, B, C, D as NumPy arrays, at, eigenvalues as a complex array, units, basis, x0...).
    Items are also attributes (lm.A)."""

    def __getattr__(self, name):
        try:
            return self[name]
        except KeyError:
            raise AttributeError(name) from None


def _matrix(rows, n_rows, n_cols):
    return _np.array(rows, dtype=float).reshape(n_rows, n_cols) if rows else _np.zeros((n_rows, n_cols))


def _linearize(self, at=None, steady=False, *, t_end=None, solver=None, rtol=None, atol=None):
    """The linear model about the state at ``at`` [s] (a run from the start; default: the initial
    state), or with ``steady`` the steady state found from there, as ``multibond linearize``."""
    j = LinearModel(self._linearize(at, steady, t_end, solver, rtol, atol))
    n, m, p = len(j["states"]), len(j["inputs"]), len(j["outputs"])
    for key, shape in (("A", (n, n)), ("B", (n, m)), ("C", (p, n)), ("D", (p, m))):
        j[key] = _matrix(j[key], *shape)
    j["eigenvalues"] = _np.array([complex(re, im) for re, im in j.get("eigenvalues", [])], dtype=complex)
    if "basis" in j:
        j["basis"] = _matrix(j["basis"], len(j["full_states"]), n)
    if "x0" in j:
        j["x0"] = _np.array(j["x0"], dtype=float)
    return j


def _modes(self, at=None, steady=False, *, t_end=None):
    """The modes of the linear model (as ``multibond modes``): a list of dicts (eigenvalue as a
    complex, frequency_hz, damping_ratio, time_constant_s, participation...), in frequency order.
    ``Model.modes_table(...)`` gives the table the command line prints."""
    modes = self._modes(at, steady, t_end)["modes"]
    for mode in modes:
        mode["eigenvalue"] = complex(*mode["eigenvalue"])
        for key in ("shape", "motion"):
            mode[key] = {k: complex(*v) for k, v in mode.get(key, {}).items()}
    return modes


def _modes_table(self, at=None, steady=False, *, t_end=None):
    return self._modes(at, steady, t_end)["table"]


def _bode(self, input, output, freqs=None, *, at=None, steady=False, t_end=None):
    """The frequency response from ``input`` (a source component) to ``output`` (a declared
    output) at ``freqs`` [Hz] (default: a log grid around the modes), as ``multibond bode``: a dict
    of NumPy arrays frequency_hz, magnitude_db, phase_deg, response (complex)."""
    return self._bode(input, output, None if freqs is None else [float(f) for f in freqs], at, steady, t_end)


def _to_pandas(self):
    """The results as a pandas DataFrame (a copy): one column per result column, "time" first;
    the units in ``df.attrs["units"]``."""
    import pandas as pd

    df = pd.DataFrame(_np.array(self.array), columns=self.columns)
    df.attrs["units"] = self.units
    return df


Model.run = _run
Model.linearize = _linearize
Model.modes = _modes
Model.modes_table = _modes_table
Model.bode = _bode
Results.to_pandas = _to_pandas
Results.keys = lambda self: list(self.columns)
