"""Loading and running a model from Python: the same numbers as `multibond run`, the results as
NumPy views, their units and run record, pandas."""

import math

import numpy as np
import pytest

import multibond
from conftest import cli, example, read_results_csv

MSD_TEXT = """
model: msd
domain: translation
parameters:
  k: {value: 100.0, unit: N/m}
  m: {value: 1.0, unit: kg}
elements:
  force:  {type: Se, effort: 1.0}
  mass:   {type: I, inertia: m}
  spring: {type: C, stiffness: k}
  damper: {type: R, resistance: 2.0}
  j:      {type: "1"}
bonds: [force -> j, j -> mass, j -> spring, j -> damper]
outputs:
  - {name: velocity, variable: j.f}
"""


def test_run_gives_the_command_lines_numbers(msd, tmp_path):
    done = cli("run", example("mass_spring_damper.yaml"), "-o", tmp_path, "--t-end", 2, "--dt", 0.01, "--jit", "off", "-q")
    assert done.returncode == 0, done.stderr
    names, units, table = read_results_csv(tmp_path / "results.csv")
    r = msd.run(t_end=2, dt=0.01)
    assert r.columns == names
    assert [r.units[n] for n in names] == units
    assert len(r) == table.shape[0] == 201
    for c, name in enumerate(names):
        np.testing.assert_array_equal(r[name], table[:, c], err_msg=name)  # the same doubles, bit for bit
    np.testing.assert_array_equal(r.array, table)


def test_results_are_read_only_views_of_one_buffer(msd):
    r = msd.run(t_end=0.5, dt=0.1)
    q = r["spring.q"]
    assert q.dtype == np.float64 and q.shape == (6,)
    assert not q.flags.writeable and not q.flags.owndata
    assert np.shares_memory(q, r.array) and np.shares_memory(r.time, r.array)
    assert q.strides == (8 * len(r.columns),)  # a strided view over the row-major rows
    with pytest.raises(ValueError):
        q[0] = 1.0
    del r  # the view keeps the results alive
    assert q[0] == 0.0 and q[-1] != 0.0


def test_units_meta_and_pandas(msd):
    r = msd.run(t_end=1, dt=0.01, rtol=1e-9, atol=1e-11)
    assert r.units["time"] == "s" and r.units["spring.q"] == "m" and r.units["mass.p"] == "N s"
    assert r.units["energy.work"] == "J"
    assert r.ok and r.status == "ok"
    meta = r.meta
    assert meta["status"] == "ok" and meta["t_reached"] == 1.0
    assert meta["model"]["name"] == "mass_spring_damper"
    assert meta["options"]["rtol"] == 1e-9 and meta["options"]["atol"] == 1e-11 and meta["options"]["solver"] == "bdf"
    assert meta["solver_stats"]["steps"] > 0
    df = r.to_pandas()
    assert list(df.columns) == r.columns and len(df) == 101
    assert df.attrs["units"]["spring.q"] == "m"
    np.testing.assert_array_equal(df["spring.q"].to_numpy(), r["spring.q"])
    with pytest.raises(KeyError, match="did you mean 'spring.q'"):
        r["spring.x"]


def test_file_settings_and_defaults(msd):
    # The file says t_end 5, dt 1e-3: 5001 rows, as `multibond run` without options.
    r = msd.run()
    assert len(r) == 5001 and r.time[-1] == 5.0


def test_loads_and_parameters():
    m = multibond.loads(MSD_TEXT, jit="off")
    assert m.name == "msd" and m.parameters == {"k": 100.0, "m": 1.0}
    r = m.run(t_end=20, dt=0.5)
    assert r["spring.q"][-1] == pytest.approx(1 / 100, rel=1e-6)  # static deflection F / k
    stiff = multibond.loads(MSD_TEXT, jit="off", k="4*100")  # a formula, as --set k=4*100
    assert stiff.parameters["k"] == 400.0
    assert stiff.run(t_end=20, dt=0.5)["spring.q"][-1] == pytest.approx(1 / 400, rel=1e-6)
    heavy = multibond.loads(MSD_TEXT, jit="off", parameters={"m": 4})
    # Period 2 pi sqrt(m / k): the velocity's first zero after the start at half a period.
    r = heavy.run(t_end=1.0, dt=1e-4, rtol=1e-10, atol=1e-12)
    v = r["velocity"]
    assert (v[1:] < 0).any()
    first_zero = r.time[1:][np.argmax(v[1:] < 0)]
    omega_d = math.sqrt(100 / 4 - (2 / (2 * 4)) ** 2)
    assert first_zero == pytest.approx(math.pi / omega_d, abs=2e-4)
    with pytest.raises(ValueError, match="did you mean 'k'"):
        multibond.loads(MSD_TEXT, kk=1.0)


def test_set_element_parameters_for_one_run_or_for_good(msd):
    # A constant force of 1 N on springs of 100 and 400 N/m: deflections F / k.
    soft = msd.run(t_end=30, dt=1.0)
    stiff = msd.run(t_end=30, dt=1.0, set={"spring": 400.0})
    assert soft["spring.q"][-1] == pytest.approx(1 / 100, rel=1e-6)
    assert stiff["spring.q"][-1] == pytest.approx(1 / 400, rel=1e-6)
    assert msd.run(t_end=30, dt=1.0)["spring.q"][-1] == pytest.approx(1 / 100, rel=1e-6)  # set= was for one run
    msd.set_parameter("force", 2.0)
    assert msd.run(t_end=30, dt=1.0)["spring.q"][-1] == pytest.approx(2 / 100, rel=1e-6)
    with pytest.raises(ValueError, match="did you mean 'spring'"):
        msd.run(set={"sprin": 1.0})
    with pytest.raises(ValueError, match="no parameter to set"):
        msd.run(set={"j": 1.0})


def test_bad_options_are_value_errors(msd):
    with pytest.raises(ValueError, match="unknown integration method"):
        msd.run(solver="euler")
    with pytest.raises(ValueError):
        msd.run(t_end=-1.0)


def test_check_and_equations(msd, tmp_path):
    c = msd.check()
    assert c["ok"] and [s for s, _ in c["states"]] == ["mass.p", "spring.q", "force.work", "damper.dissipated"]
    assert dict(c["states"])["spring.q"] == "m"
    done = cli("equations", example("mass_spring_damper.yaml"))
    assert done.returncode == 0
    assert msd.equations() == done.stdout
    rigid = multibond.load(example("rigid_gear_pair.yaml"), jit="off")
    c = rigid.check()
    assert not c["ok"] and not c["states"]
    assert "causality.derivative" in [d.code for d in c["conflicts"]]
    assert all(d.line > 0 for d in c["conflicts"] if d.code == "causality.derivative")


def test_events_of_a_bouncing_ball_follow_the_closed_form():
    model = multibond.load(example("events/bouncing_ball.yaml"))
    r = model.run(t_end=10.0, rtol=1e-10, atol=1e-12)
    impacts = [e for e in r.events if e["kind"] == "impact"]
    g, h0, e = 9.81, 1.0, 0.8
    v1 = math.sqrt(2 * g * h0)
    t = math.sqrt(2 * h0 / g)
    for k in range(5):  # t(k+1) = t(k) + 2 e^k v1 / g
        assert abs(impacts[k]["time"] - t) < 1e-8
        assert impacts[k]["element"] == "ground"
        t += 2 * e ** (k + 1) * v1 / g
    assert [x["kind"] for x in r.events].count("contact") == 1  # rest after the accumulation
    assert r.meta["events"]["count"] == len(r.events)
