"""A bad model raises ModelError with located diagnostics and their codes (the files of
tests/models/bad/, as tests/io/bad_models_test.cc checks them in C++); a failed run raises
SimulationError with the rows computed until then."""

import pathlib

import pytest

import multibond
from conftest import SOURCE, example


def headers(path):
    h = {}
    for line in path.read_text(encoding="utf-8", errors="replace").splitlines():
        if not line.startswith("#"):
            break
        key, _, value = line[1:].partition(":")
        h.setdefault(key.strip(), value.strip())
    return h


BAD = sorted(p for p in (SOURCE / "tests/models/bad").glob("*.yaml") if "code" in headers(p))


def test_there_are_bad_models_with_codes():
    assert len(BAD) >= 40


@pytest.mark.parametrize("path", BAD, ids=lambda p: p.name)
def test_bad_model_raises_model_error_with_its_code(path):
    h = headers(path)
    with pytest.raises(multibond.ModelError) as caught:
        m = multibond.load(path, jit="off")
        m.column_names()  # compiles and lays out the outputs
    e = caught.value
    assert isinstance(e, Exception)
    matching = [d for d in e.diagnostics if h["expect"] in d.text]
    assert matching, f"no diagnostic contains {h['expect']!r}: {[d.text for d in e.diagnostics]}"
    d = matching[0]
    assert d.code == h["code"]
    if int(h["line"]) != 0:
        assert d.line == int(h["line"])
    assert str(e)  # the message as the command line prints it


def catalogue():
    """The codes of the catalogue, as docs/model-format.md's table shows them (checked row for row
    against core/diagnostic_codes.h by tests/core/diagnostic_codes_test.cc)."""
    text = (SOURCE / "docs/model-format.md").read_text(encoding="utf-8")
    rows = text.split("| code | exit | problem |", 1)[1].splitlines()
    return {r.split("`")[1] for r in rows if r.startswith("| `")}


ALL_BAD = sorted((SOURCE / "tests/models/bad").glob("*.yaml"))


@pytest.mark.parametrize("path", ALL_BAD, ids=lambda p: p.name)
def test_every_diagnostic_of_a_bad_model_carries_its_catalogue_code(path):
    # Every error the loader and the compiler raise to Python has its code (#44: an unknown
    # element type, a missing key, a bad bond had none), and the code is the catalogue's.
    known = catalogue()
    try:
        multibond.load(path, jit="off").column_names()
    except multibond.ModelError as e:
        assert e.diagnostics
        for d in e.diagnostics:
            assert d.code, f"no code: {d.text}"
            assert d.code in known, f"{d.code!r} is not in the catalogue: {d.text}"
        assert e.code == e.diagnostics[0].code
    else:
        pytest.skip("loads (a model refused only by a command, such as run)")


def test_model_error_attributes():
    text = "model: m\nelements:\n  a: {type: Se, effort: 1}\n  b: {type: C, stiffness: -5}\nbonds: [a -> b]\n"
    with pytest.raises(multibond.ModelError) as caught:
        multibond.loads(text, file="spring.yaml").column_names()
    e = caught.value
    assert (e.file, e.line, e.code, e.element) == ("spring.yaml", 4, "param.range", "b")
    assert e.column > 0 and "stiffness" in e.message
    assert e.diagnostics[0].text.startswith("spring.yaml:4:")


def test_an_unknown_element_type_carries_its_code():
    # It had an empty code (the file, line and column were right).
    text = "model: m\nelements:\n  a: {type: Se, effort: 1}\n  b: {type: Ii, inertia: 1}\nbonds: [a -> b]\n"
    with pytest.raises(multibond.ModelError) as caught:
        multibond.loads(text, file="m.yaml").column_names()
    e = caught.value
    assert (e.file, e.line, e.code, e.element) == ("m.yaml", 4, "element.type", "b")
    assert "did you mean 'I'?" in e.diagnostics[0].text


def test_unreadable_file_is_a_model_error_with_an_io_code(tmp_path):
    with pytest.raises(multibond.ModelError) as caught:
        multibond.load(tmp_path / "missing.yaml")
    assert caught.value.code.startswith("io.")


def test_diverging_run_raises_simulation_error_with_partial_results():
    # RK4 with a step far beyond its stability limit (w h = 5): the state overflows.
    m = multibond.load(example("mass_spring_damper.yaml"), jit="off")
    with pytest.raises(multibond.SimulationError) as caught:
        m.run(solver="rk4", step=0.5, dt=0.5, t_end=500)
    e = caught.value
    assert "at t = " in str(e)
    r = e.results
    assert r.status == "failed" and not r.ok
    assert 0.0 < r.t_reached < 500.0
    assert len(r) > 2 and r.time[-1] <= r.t_reached
    assert r.meta["status"] == "failed"
