"""multibond.sweep: the mass-spring-damper study as a DataFrame that matches the closed forms and
the command line's sweep.csv; a bad study raises ModelError with located sweep.* diagnostics;
models run in parallel from Python threads and on a Dask cluster (dask.distributed) give the
same numbers as the sweep."""

import math
from concurrent.futures import ThreadPoolExecutor

import pytest

import multibond
from conftest import SOURCE, cli

STUDY = SOURCE / "examples" / "sweeps" / "mass_spring_damper.yaml"
MODEL = SOURCE / "examples" / "sweeps" / "mass_spring_damper_model.yaml"


def peak(k, m=1.0, c=2.0):
    zeta = c / (2 * math.sqrt(k * m))
    return (1 / k) * (1 + math.exp(-math.pi * zeta / math.sqrt(1 - zeta * zeta)))


def test_the_study_as_a_dataframe(tmp_path):
    df = multibond.sweep(STUDY, tmp_path / "py", threads=2, jit="off")
    assert list(df.columns[:5]) == ["run", "k", "status", "x_final", "x_max"]
    assert len(df) == 20 and (df.status == "ok").all()
    for k, xf, xm in zip(df.k, df.x_final, df.x_max):
        assert abs(xf - 1 / k) < 1e-8
        assert abs(xm - peak(k)) < 1e-3 * peak(k)
    # The same table, to the last bit, as the command line's.
    p = cli("sweep", STUDY, "-o", tmp_path / "cli", "--jit", "off", "--threads", "1")
    assert p.returncode == 0, p.stderr
    assert (tmp_path / "py" / "sweep.csv").read_bytes() == (tmp_path / "cli" / "sweep.csv").read_bytes()


def test_a_study_given_here_with_a_temporary_folder():
    df = multibond.sweep(MODEL, grid={"k": (100, 400, 3)}, keep={"x": "final:spring.q"}, t_end=1.0, jit="off")
    assert list(df.k) == [100.0, 250.0, 400.0]
    sampled = multibond.sweep(MODEL, sample={"k": ("uniform", 100, 200)}, samples=8, seed=5, keep={"x": "max:spring.q"},
                              t_end=0.5, jit="off", threads=2)
    again = multibond.sweep(MODEL, sample={"k": ("uniform", 100, 200)}, samples=8, seed=5, keep={"x": "max:spring.q"},
                            t_end=0.5, jit="off", threads=1)
    assert sampled.equals(again)
    assert ((sampled.k > 100) & (sampled.k < 200)).all()


def test_a_bad_study_raises_located_diagnostics():
    with pytest.raises(multibond.ModelError) as e:
        multibond.sweep(MODEL, grid={"kk": (10, 1, 5)}, keep={"x": "max:sprng.q"}, jit="off")
    codes = sorted(d.code for d in e.value.diagnostics)
    assert codes == ["sweep.keep", "sweep.range", "sweep.unknown_parameter"]
    hints = {d.code: d.hint for d in e.value.diagnostics}
    assert hints["sweep.unknown_parameter"] == "did you mean 'k'?"
    assert hints["sweep.keep"] == "did you mean 'spring.q'?"


def final_and_peak(k):
    """One run, as a worker of a pool or a cluster runs it."""
    r = multibond.load(MODEL, jit="off", k=k).run(t_end=30)
    x = r["spring.q"]
    return float(x[-1]), float(x.max())


def test_models_in_parallel_from_python_threads(tmp_path):
    ks = [10.0, 100.0, 1000.0]
    with ThreadPoolExecutor(max_workers=3) as pool:
        got = list(pool.map(final_and_peak, ks))
    df = multibond.sweep(MODEL, values={"k": ks}, keep={"x_final": "final:spring.q", "x_max": "max:spring.q"}, t_end=30, jit="off")
    assert [(a, b) for a, b in got] == list(zip(df.x_final, df.x_max))


def test_models_on_a_dask_cluster():
    distributed = pytest.importorskip("distributed")
    ks = [10.0, 100.0, 1000.0]
    model = str(MODEL)

    def work(k):  # defined here: sent to the workers by value (they cannot import this test file)
        import multibond as mb

        x = mb.load(model, jit="off", k=k).run(t_end=30)["spring.q"]
        return float(x[-1]), float(x.max())

    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        with distributed.Client(cluster) as client:
            got = client.gather(client.map(work, ks))
    expected = [final_and_peak(k) for k in ks]
    assert got == expected
    for k, (xf, xm) in zip(ks, got):
        assert abs(xf - 1 / k) < 1e-8 and abs(xm - peak(k)) < 1e-3 * peak(k)
