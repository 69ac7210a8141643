"""Linear analysis from Python: the same linear model as `multibond linearize` (linear.json), the
modes and the frequency response of the mass-spring-damper against their closed forms."""

import json

import numpy as np
import pytest

import multibond
from conftest import cli, example


def test_linearize_equals_the_command_lines_linear_json(tmp_path):
    m = multibond.load(example("mass_spring_damper.yaml"), jit="off")
    lm = m.linearize()
    # m x'' + c x' + k x = F with m = 1, c = 2, k = 100: lambda = -1 +/- i sqrt(99).
    np.testing.assert_allclose(sorted(lm.eigenvalues, key=lambda z: z.imag), [-1 - 99 ** 0.5 * 1j, -1 + 99 ** 0.5 * 1j], rtol=1e-12)
    assert lm["states"] == ["mass.p", "spring.q"] and lm.inputs == ["force"] and lm.outputs == ["velocity", "spring_force"]
    np.testing.assert_array_equal(lm.A, [[-2.0, -100.0], [1.0, 0.0]])
    done = cli("linearize", example("mass_spring_damper.yaml"), "-o", tmp_path, "--jit", "off", "-q")
    assert done.returncode == 0, done.stderr
    j = json.loads((tmp_path / "linear.json").read_text())
    for key in ("states", "inputs", "outputs", "state_units", "input_units", "output_units", "at", "steady"):
        assert lm[key] == j[key], key
    for key in ("A", "B", "C", "D"):
        np.testing.assert_array_equal(lm[key], np.array(j[key], dtype=float).reshape(lm[key].shape), err_msg=key)
    np.testing.assert_array_equal(lm.eigenvalues, [complex(re, im) for re, im in j["eigenvalues"]])


def test_linearize_at_a_time_and_steady(tmp_path):
    m = multibond.load(example("mass_spring_damper.yaml"), jit="off")
    lm = m.linearize(at=2.0)
    done = cli("linearize", example("mass_spring_damper.yaml"), "-o", tmp_path, "--jit", "off", "-q", "--at", 2)
    assert done.returncode == 0, done.stderr
    j = json.loads((tmp_path / "linear.json").read_text())
    assert lm.at == 2.0 == j["at"]
    np.testing.assert_array_equal(lm.x0, j["x0"])
    steady = m.linearize(steady=True)
    assert steady.steady
    # At rest under the 1 N step: x = F / k, no momentum.
    assert steady.x0[steady.full_states.index("spring.q")] == pytest.approx(0.01, rel=1e-12)
    assert abs(steady.x0[steady.full_states.index("mass.p")]) < 1e-14
    with pytest.raises(ValueError, match="outside the run"):
        m.linearize(at=50.0)


def test_modes_and_bode():
    m = multibond.load(example("mass_spring_damper.yaml"), jit="off")
    (mode,) = m.modes()
    assert mode["eigenvalue"] == pytest.approx(complex(-1, 99 ** 0.5), rel=1e-12)
    assert mode["frequency_hz"] == pytest.approx(10 / (2 * np.pi), rel=1e-12)
    assert mode["damping_ratio"] == pytest.approx(0.1, rel=1e-12)
    assert mode["participation"] == pytest.approx({"mass": 0.5, "spring": 0.5}, rel=1e-9)
    assert "mass 50%, spring 50%" in m.modes_table()
    f = np.array([0.1, 1.0, 1.59, 5.0])
    b = m.bode("force", "spring_force", f)
    w = 2 * np.pi * f
    g = 100 / (100 - w ** 2 + 2j * w)  # spring force per force: k / (k - m w^2 + j c w)
    np.testing.assert_allclose(b["response"], g, rtol=1e-12)
    np.testing.assert_allclose(b["magnitude_db"], 20 * np.log10(abs(g)), rtol=1e-12)
    np.testing.assert_array_equal(b["frequency_hz"], f)
    assert len(m.bode("force", "velocity")["frequency_hz"]) > 50  # the default grid
    with pytest.raises(ValueError, match="did you mean 'spring_force'"):
        m.bode("force", "spring_forc")
