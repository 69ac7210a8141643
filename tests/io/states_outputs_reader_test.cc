// Signals and the states of signals (io/states_outputs_reader.cc): 'signals' into the graph's
// signals, integral states with a 'rate', lag and PID states with their checks, and the names that
// formulas read bare (a signal, a state, a parameter) kept apart.

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "multibond/compile/compiled_model.h"
#include "multibond/io/model_loader.h"
#include "support/load_errors.h"

namespace multibond {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;

using testing::LoadErrors;

/// "element: message [code]" of each diagnostic.
std::vector<std::string> Said(const std::vector<Diagnostic>& ds) {
  std::vector<std::string> out;
  for (const Diagnostic& d : ds) out.push_back(d.element + ": " + d.message + (d.code.empty() ? "" : " [" + d.code + "]"));
  return out;
}

std::vector<std::string> NamesOf(const Formula& f) {
  std::vector<std::string> out;
  for (const expr::Node* n : expr::Names(*f.root)) out.push_back(n->name);
  return out;
}

/// A motor with a shaft; `extra` adds top-level sections (signals, states).
std::string Motor(const std::string& extra) {
  return "model: motor\n"
         "parameters: {w_ref: 10.0, K: 0.5}\n"
         "elements:\n"
         "  torque: {type: Se, effort: \"u.u\"}\n"
         "  shaft:  {type: \"1\", domain: rotation}\n"
         "  J:      {type: I, inertia: 0.01}\n"
         "bonds: [torque -> shaft, shaft -> J]\n" +
         extra;
}

TEST(StatesOutputsReader, SignalsAreAddedWithTheirFormulasAndUnits) {
  const LoadedModel lm = LoadModelString(Motor("signals:\n"
                                               "  error: \"w_ref - shaft.f\"\n"
                                               "  demand: {value: \"K*error\", unit: N m, description: torque asked}\n"
                                               "  one: 1\n"),
                                         "m.yaml");
  const auto& s = lm.graph.signals();
  ASSERT_EQ(s.size(), 3u);
  EXPECT_EQ(s[0].name, "error");
  EXPECT_EQ(expr::Format(*s[0].value.root), "10 - shaft.f");
  EXPECT_EQ(s[0].where.line, 9);
  EXPECT_EQ(s[0].value.where.line, 9);
  EXPECT_EQ(s[0].value.where.column, 11);
  EXPECT_EQ(s[1].unit, "N m");
  EXPECT_THAT(NamesOf(s[1].value), ElementsAre("error"));
  EXPECT_EQ(s[1].value.text, "K*error");
  EXPECT_EQ(expr::Format(*s[2].value.root), "1");
  EXPECT_EQ(lm.graph.FindSignal("demand"), 1);
}

TEST(StatesOutputsReader, SignalStatesRateLagAndPid) {
  const LoadedModel lm = LoadModelString(Motor("signals: {error: \"w_ref - shaft.f\"}\n"
                                               "states:\n"
                                               "  angle: {kind: integral, rate: shaft.f, unit: rad, initial: 0.5}\n"
                                               "  smooth: {kind: lag, input: error, time_constant: 0.2, initial: 1}\n"
                                               "  u: {kind: pid, input: error, kp: 2*K, ki: 1, kd: 0.01, tf: 0.001, min: -1, max: 1}\n"),
                                         "m.yaml");
  const auto& aux = lm.graph.aux_states();
  const AuxState& angle = aux[lm.graph.FindAux("angle")];
  EXPECT_EQ(angle.kind, AuxState::Kind::kIntegral);
  EXPECT_TRUE(angle.of.empty());
  EXPECT_THAT(NamesOf(angle.rate), ElementsAre("shaft.f"));
  EXPECT_EQ(angle.unit, "rad");
  EXPECT_EQ(angle.initial(0, 0), 0.5);
  const AuxState& smooth = aux[lm.graph.FindAux("smooth")];
  EXPECT_EQ(smooth.kind, AuxState::Kind::kLag);
  EXPECT_THAT(NamesOf(smooth.input), ElementsAre("error"));
  EXPECT_EQ(smooth.time_constant, 0.2);
  EXPECT_EQ(smooth.initial(0, 0), 1.0);
  const AuxState& u = aux[lm.graph.FindAux("u")];
  EXPECT_EQ(u.kind, AuxState::Kind::kPid);
  EXPECT_EQ(u.pid.kp, 1.0);
  EXPECT_EQ(u.pid.ki, 1.0);
  EXPECT_EQ(u.pid.kd, 0.01);
  EXPECT_EQ(u.pid.tf, 0.001);
  EXPECT_EQ(u.pid.tt, 0.0);
  EXPECT_EQ(u.pid.u_min, -1.0);
  EXPECT_EQ(u.pid.u_max, 1.0);
  // Unbounded without min and max.
  const LoadedModel free = LoadModelString(Motor("states: {u: {kind: pid, input: \"w_ref - shaft.f\", kp: 1}}\n"), "m.yaml");
  EXPECT_EQ(free.graph.aux_states()[0].pid.u_min, -HUGE_VAL);
  EXPECT_EQ(free.graph.aux_states()[0].pid.u_max, HUGE_VAL);
}

TEST(StatesOutputsReader, SignalStatesAreChecked) {
  const auto ds = LoadErrors(Motor("states:\n"
                                   "  a: {kind: integral, rate: shaft.f, of: shaft}\n"
                                   "  b: {kind: integral}\n"
                                   "  c: {kind: lag, input: 1.0}\n"
                                   "  d: {kind: lag, input: 1.0, time_constant: -0.1}\n"
                                   "  e2: {kind: pid, kp: 1}\n"
                                   "  f2: {kind: pid, input: 1, kp: -1}\n"
                                   "  g: {kind: pid, input: 1}\n"
                                   "  h: {kind: pid, input: 1, kd: 0.1}\n"
                                   "  i: {kind: pid, input: 1, kp: 1, min: 2, max: 1}\n"
                                   "  k: {kind: pid, input: 1, kp: 1, tf: -1, tt: -2}\n"
                                   "  l: {kind: lag, input: 1, time_constant: 1, initial: [1, 2]}\n"
                                   "  m: {kind: lagg, input: 1}\n"
                                   "  n: {kind: pid, input: 1, kp: 1, of: shaft}\n"));
  EXPECT_THAT(Said(ds),
              ElementsAre("a: give 'of' (a flow to integrate) or 'rate' (a formula), not both [key.conflict]",
                          "b: state needs 'of': the 1-junction or one-port whose flow it integrates (or 'rate': a formula) [state.of]",
                          "c: a lag needs 'time_constant' [s] [key.missing]",
                          "d: time_constant must be > 0 (got -0.1) [param.range]",
                          "e2: a pid state needs 'input': the formula of the signal it controls (the error) [key.missing]",
                          "f2: kp must be >= 0 (got -1) [param.range]",
                          "g: a PID needs a gain: kp, ki or kd > 0 [param.range]",
                          "h: a derivative part (kd > 0) needs its filter time constant tf > 0 [param.range]",
                          "i: max must be > min (got min 2, max 1) [param.range]",
                          "k: tf must be >= 0 (got -1) [param.range]",
                          "k: tt must be >= 0 (got -2) [param.range]",
                          "l: the state is scalar: its initial value is one number (got 2) [param.range]",
                          "m: unknown state kind 'lagg' [value.unknown]",
                          "n: unknown key 'of' [key.unknown]"));
  EXPECT_EQ(ds[12].hint, "did you mean 'lag'?");
}

TEST(StatesOutputsReader, InitialValuesOfSignalStatesAreNumbersOrFormulasOfParameters) {
  const std::string states =
      "states:\n"
      "  angle: {kind: integral, rate: shaft.f, initial: \"w_ref/2\"}\n"
      "  smooth: {kind: lag, input: shaft.f, time_constant: 0.2, initial: 2*w_ref}\n"
      "  u: {kind: pid, input: \"w_ref - shaft.f\", kp: 1, ki: 4, initial: \"K*w_ref/4\"}\n"
      "  v: {kind: pid, input: \"w_ref - shaft.f\", kp: 1, ki: 4, initial: -1.5}\n"
      "  pos: {kind: integral, of: shaft, initial: \"-K\"}\n";
  for (const bool set : {false, true}) {
    const std::vector<ParameterOverride> overrides =
        set ? std::vector<ParameterOverride>{{"w_ref", "20"}, {"K", "2*w_ref"}} : std::vector<ParameterOverride>{};
    const LoadedModel lm = LoadModelString(Motor(states), "m.yaml", {}, overrides);
    const double w_ref = set ? 20.0 : 10.0, K = set ? 40.0 : 0.5;
    const auto& aux = lm.graph.aux_states();
    EXPECT_EQ(aux[lm.graph.FindAux("angle")].initial(0, 0), w_ref / 2);
    EXPECT_EQ(aux[lm.graph.FindAux("smooth")].initial(0, 0), 2 * w_ref);
    const AuxState& u = aux[lm.graph.FindAux("u")];
    ASSERT_EQ(u.initial.size(), 1);
    EXPECT_EQ(u.initial(0, 0), K * w_ref / 4);  // the integral state u.i's initial value
    EXPECT_EQ(aux[lm.graph.FindAux("v")].initial(0, 0), -1.5);
    EXPECT_EQ(aux[lm.graph.FindAux("pos")].initial(0, 0), -K);
    // They are the initial state: u.i and v.i are the pids' integral states.
    const auto model = CompiledModel::Compile(lm.graph, lm.compile);
    const Eigen::VectorXd x0 = model->MakeInitialState();
    const std::vector<std::string>& names = model->state_names();
    auto at = [&](const std::string& name) {
      const auto it = std::find(names.begin(), names.end(), name);
      EXPECT_NE(it, names.end()) << name;
      return it == names.end() ? NAN : x0(it - names.begin());
    };
    EXPECT_EQ(at("angle"), w_ref / 2);
    EXPECT_EQ(at("smooth"), 2 * w_ref);
    EXPECT_EQ(at("u.i"), K * w_ref / 4);
    EXPECT_EQ(at("v.i"), -1.5);
    EXPECT_EQ(at("pos"), -K);
  }
}

TEST(StatesOutputsReader, AnInitialValueIsAConstantSaidAtItsCharacter) {
  // Line 9 onwards (Motor's text has 7 lines, then 'states:'); the columns are those of the name
  // in the formula.
  const auto ds = LoadErrors(Motor("states:\n"
                                   "  a: {kind: pid, input: \"w_ref - shaft.f\", ki: 1, initial: \"w_ref + t\"}\n"
                                   "  b: {kind: lag, input: shaft.f, time_constant: 1, initial: \"2*shaft.f\"}\n"
                                   "  c: {kind: integral, rate: shaft.f, initial: \"a\"}\n"
                                   "  d: {kind: pid, input: \"w_ref - shaft.f\", ki: 1, initial: [1, 2]}\n"
                                   "  e2: {kind: pid, input: \"w_ref - shaft.f\", kp: 1, initial: 0.5}\n"
                                   "  f2: {kind: pid, input: \"w_ref - shaft.f\", kp: 1, initial: 0}\n"
                                   "  g: {kind: pid, input: \"w_ref - shaft.f\", ki: 1, initial: \"w_reff\"}\n"));
  EXPECT_THAT(Said(ds),
              ElementsAre("a: an initial value is a constant: a number or a formula of parameters ('t' is time) [expr.not_constant]",
                          "b: an initial value is a constant: a number or a formula of parameters ('shaft.f' is a variable of the model) "
                          "[expr.not_constant]",
                          "c: an initial value is a constant: a number or a formula of parameters ('a' is a variable of the model) "
                          "[expr.not_constant]",
                          "d: a PID's initial value is that of its integral state 'd.i': one number (got 2) [param.range]",
                          "e2: a PID without ki has no integral action: its integral state 'e2.i' has no effect, so its initial value "
                          "must be 0 (got 0.5) [param.range]",
                          "g: unknown parameter 'w_reff' [param.unknown]"));
  ASSERT_EQ(ds.size(), 6u);
  EXPECT_EQ(ds[0].where.file, "m.yaml");
  EXPECT_EQ(ds[0].where.line, 9);
  EXPECT_EQ(ds[0].where.column, 69);  // the 't'
  EXPECT_EQ(ds[1].where.line, 10);
  EXPECT_EQ(ds[1].where.column, 64);  // the 's' of shaft.f
  EXPECT_EQ(ds[2].where.line, 11);
  EXPECT_EQ(ds[2].where.column, 48);
  EXPECT_EQ(ds[3].hint, "to start at a steady output u0 with zero error, initial: u0/ki");
  EXPECT_EQ(ds[5].hint, "did you mean 'w_ref'?");
}

TEST(StatesOutputsReader, NamesThatFormulasReadBareAreKeptApart) {
  const auto ds = LoadErrors(Motor("signals: {K: \"2*t\", J: \"1\", angle: \"t\", q: \"t\"}\n"
                                   "states: {angle: {kind: integral, of: shaft}, w_ref: {kind: integral, of: shaft}}\n"));
  EXPECT_THAT(Said(ds), ElementsAre("angle: a state may not be named like a signal ('angle') [name.duplicate]",
                                    "w_ref: a state may not be named like a parameter ('w_ref') [name.duplicate]",
                                    "K: a signal may not be named like a parameter ('K') [name.duplicate]",
                                    "J: a signal may not be named like an element ('J') [name.duplicate]",
                                    "q: a signal may not be named 'q': in formulas it names an element's own variable in its law [name.invalid]"));
}

TEST(StatesOutputsReader, ASignalsFormulaIsReadLikeALaw) {
  // "  x: \"sinn(t)\"": the function at column 7; "  y: {value: \"3*kk\"}": 'kk' at 17.
  const auto ds = LoadErrors(Motor("signals:\n  x: \"sinn(t)\"\n  y: {value: \"3*kk\", unit: furlong}\n  z: {unit: m}\n"));
  EXPECT_THAT(Said(ds), ElementsAre("x: the formula 'sinn(t)' does not read: unknown function 'sinn' [expr.unknown_function]",
                                    "y: the unit 'furlong' is refused: 'furlong' is not a unit symbol (with an optional SI prefix) [unit.invalid]",
                                    "y: unknown parameter 'kk' [param.unknown]",
                                    "z: a signal given as a mapping needs 'value': its formula [key.missing]"));
  EXPECT_EQ(ds[0].where.line, 9);
  EXPECT_EQ(ds[0].where.column, 7);
  EXPECT_EQ(ds[0].hint, "did you mean 'sin'?");
  EXPECT_EQ(ds[2].where.column, 17);
  EXPECT_EQ(ds[2].hint, "did you mean 'K'?");
}

}  // namespace
}  // namespace multibond
