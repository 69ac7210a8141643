// The public Model: loading, diagnostics, parameters, building and one run, asserted on physics.

#include <algorithm>
#include <cmath>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <multibond/multibond.h>

#include "api/msd.h"

namespace multibond {
namespace {

using ::testing::HasSubstr;

BuildOptions Interpreted() {
  BuildOptions b;
  b.jit = "off";
  return b;
}

TEST(ApiModel, MassSpringDamperFollowsTheClosedForm) {
  Model model = Model::FromString(test::MassSpringDamper());
  model.Build(Interpreted());
  const Results r = model.Simulate();  // the file's simulation: section: 2 s, dt 0.01, rtol 1e-10
  ASSERT_TRUE(r.ok()) << r.summary().message;
  ASSERT_EQ(r.rows(), 201u);
  const auto t = r.times();
  const auto x = r.column("spring.q");
  for (size_t i = 0; i < r.rows(); i += 20) EXPECT_NEAR(x[i], test::Position(t[i]), 1e-9) << "t = " << t[i];
  // The declared output is the mass's velocity: p / m.
  EXPECT_DOUBLE_EQ(r.column("velocity").back(), r.column("mass.p").back() / 1.0);
  EXPECT_LT(std::abs(r.summary().energy_residual), 1e-6);
}

TEST(ApiModel, TheFilesParametersAreGivenValuesWhenLoading) {
  // The model with named parameters: k and the force from them; k = 400 given when loading.
  std::string yaml = test::MassSpringDamper();
  yaml.replace(yaml.find("elements:"), 0, "parameters: {k: 100.0, F: k/100}\n");
  yaml.replace(yaml.find("effort: 1.000000"), 16, "effort: F");
  yaml.replace(yaml.find("stiffness: 100.000000"), 21, "stiffness: k");
  Model model = Model::FromString(yaml, "msd.yaml", {}, {{"k", "2*200"}});
  EXPECT_EQ(model.parameter_names(), (std::vector<std::string>{"k", "F"}));
  EXPECT_EQ(model.parameter("k"), 400.0);
  EXPECT_EQ(model.parameter("F"), 4.0);  // follows k
  model.Build(Interpreted());
  const Results r = model.Simulate();
  ASSERT_TRUE(r.ok()) << r.summary().message;
  const auto t = r.times();
  const auto x = r.column("spring.q");
  for (size_t i = 0; i < r.rows(); i += 20) EXPECT_NEAR(x[i], test::Position(t[i], 400.0, 4.0), 1e-9) << "t = " << t[i];
  // A name the file does not declare, and one the model does not have.
  try {
    (void)Model::FromString(yaml, "msd.yaml", {}, {{"kk", "1"}});
    ADD_FAILURE() << "an unknown parameter was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("did you mean 'k'?"));
  }
  EXPECT_THROW((void)model.parameter("kk"), std::invalid_argument);
}

TEST(ApiModel, OptionsOverTheFileOverTheDefaults) {
  Model model = Model::FromString(test::MassSpringDamper());
  SimulationOptions o;
  o.t_end = 0.5;  // given: over the file's 2 s; the file's dt 0.01 stays
  o.solver = "rk4";
  o.step = 1e-3;
  const Results r = model.Simulate(o);
  ASSERT_TRUE(r.ok()) << r.summary().message;
  EXPECT_EQ(r.rows(), 51u);
  EXPECT_DOUBLE_EQ(r.times().back(), 0.5);
  EXPECT_NEAR(r.column("spring.q").back(), test::Position(0.5), 1e-9);  // RK4 at h = 1 ms: error ~ h^4
}

TEST(ApiModel, TheEventLimitIsAnOptionOverTheFile) {
  // The stick-slip example has 2 events per 0.8008 s period: 2,500 over 1,000 s. A limit of 2 per
  // second (2,000 in all) stops the run as an event storm; the file's default (1e4) does not.
  Model model = Model::FromFile(std::string(MULTIBOND_SOURCE_DIR) + "/examples/events/stick_slip.yaml");
  SimulationOptions o;
  o.t_end = 1000.0;
  o.dt = 0.5;
  o.max_events_per_second = 2.0;
  const Results stormy = model.Simulate(o);
  EXPECT_FALSE(stormy.ok());
  EXPECT_THAT(stormy.summary().message, HasSubstr("event storm"));
  o.max_events_per_second.reset();
  EXPECT_TRUE(model.Simulate(o).ok());
}

TEST(ApiModel, SetParameterChangesThePhysics) {
  Model model = Model::FromString(test::MassSpringDamper());
  model.SetParameter("spring", 400.0);
  model.SetParameter("force", 3.0);  // a source's constant value
  const Results r = model.Simulate();
  ASSERT_TRUE(r.ok()) << r.summary().message;
  for (const double t : {0.13, 0.77, 2.0}) EXPECT_NEAR(r.At("spring.q", t), test::Position(t, 400.0, 3.0), 2e-5) << "t = " << t;
  EXPECT_NEAR(r.column("spring.q").back(), test::Position(2.0, 400.0, 3.0), 1e-9);
}

TEST(ApiModel, SetParameterUnbuildsAndTheNextBuildChecksTheValue) {
  Model model = Model::FromString(test::MassSpringDamper(), "msd.yaml");
  model.Build(Interpreted());
  model.SetParameter("mass", -1.0);
  EXPECT_FALSE(model.built());
  try {
    model.Build(Interpreted());
    FAIL() << "a negative inertia was accepted";
  } catch (const ModelError& e) {
    ASSERT_FALSE(e.diagnostics().empty());
    const Diagnostic& d = e.diagnostics().front();
    EXPECT_EQ(d.code, "param.range");
    EXPECT_EQ(d.element, "mass");
    EXPECT_EQ(d.where.file, "msd.yaml");
    EXPECT_EQ(d.where.line, 5);  // where the element was written
  }
}

TEST(ApiModel, SetParameterTakesAMatrixAndInitialValues) {
  Model model = Model::FromString(test::MassSpringDamper(100.0, 0.0));
  const double k[] = {25.0};
  model.SetParameter("spring", k, 1, 1);
  const double q0[] = {0.02};
  model.SetInitial("spring", q0);  // released from x = 0.02 m with no force: free damped oscillation
  const Results r = model.Simulate();
  ASSERT_TRUE(r.ok());
  const double w0 = 5.0, zeta = 0.2, wd = w0 * std::sqrt(1 - zeta * zeta);
  const double x = 0.02 * std::exp(-zeta * w0 * 2.0) * (std::cos(wd * 2.0) + zeta * w0 / wd * std::sin(wd * 2.0));
  EXPECT_NEAR(r.column("spring.q").back(), x, 1e-9);
}

TEST(ApiModel, UnknownNamesAreRefusedWithADidYouMean) {
  Model model = Model::FromString(test::MassSpringDamper());
  try {
    model.SetParameter("sprng", 1.0);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("no element called 'sprng' (did you mean 'spring'?)"));
  }
  EXPECT_THROW(model.SetParameter("j", 1.0), std::invalid_argument);  // a junction has no parameter
  EXPECT_THROW(model.SetParameter("spring", std::vector<double>{1, 2, 3}, 2, 2), std::invalid_argument);
  EXPECT_THROW(model.Build(BuildOptions{"sometimes", {}, {}}), std::invalid_argument);
  SimulationOptions o;
  o.solver = "euler";
  EXPECT_THROW(model.Simulate(o), std::invalid_argument);
}

TEST(ApiModel, ABadModelGivesLocatedDiagnosticsWithCodes) {
  const std::string yaml =
      "model: bad\n"
      "elements:\n"
      "  mass: {type: I, inertia: 1.0}\n"
      "  spring: {type: Q, stiffness: 100.0}\n"
      "bonds: [mass -> spring]\n";
  try {
    Model::FromString(yaml, "bad.yaml");
    FAIL() << "an unknown element type was accepted";
  } catch (const ModelError& e) {
    ASSERT_FALSE(e.diagnostics().empty());
    const Diagnostic& d = e.diagnostics().front();
    EXPECT_EQ(d.where.file, "bad.yaml");
    EXPECT_EQ(d.where.line, 4);
    EXPECT_GT(d.where.column, 0);
    EXPECT_EQ(d.element, "spring");
    EXPECT_THAT(d.ToString(), HasSubstr("bad.yaml:4:"));
  }
}

TEST(ApiModel, ACausalityConflictIsLocatedAndCoded) {
  const std::string yaml =
      "model: conflict\n"
      "domain: translation\n"
      "elements:\n"
      "  a: {type: Se, effort: 1.0}\n"
      "  b: {type: Se, effort: 2.0}\n"
      "  n: {type: \"0\"}\n"
      "bonds: [a -> n, b -> n]\n";
  Model model = Model::FromString(yaml, "conflict.yaml");
  try {
    model.Build(Interpreted());
    FAIL() << "two efforts imposed on one 0-junction were accepted";
  } catch (const ModelError& e) {
    ASSERT_FALSE(e.diagnostics().empty());
    const Diagnostic& d = e.diagnostics().front();
    EXPECT_EQ(d.code.rfind("causality.", 0), 0u) << d.code;
    EXPECT_EQ(d.where.file, "conflict.yaml");
    EXPECT_GE(d.where.line, 4);
    EXPECT_GT(d.where.column, 0);
    EXPECT_FALSE(d.element.empty());
    EXPECT_FALSE(d.message.empty());
  }
}

TEST(ApiModel, AMissingFileIsAnIoDiagnostic) {
  try {
    Model::FromFile("/nonexistent/model.yaml");
    FAIL();
  } catch (const ModelError& e) {
    ASSERT_FALSE(e.diagnostics().empty());
    EXPECT_EQ(e.diagnostics().front().code.rfind("io.", 0), 0u) << e.diagnostics().front().code;
  }
}

TEST(ApiModel, LoadsTheExampleFileAndNamesItsColumns) {
  Model model = Model::FromFile(MULTIBOND_SOURCE_DIR "/examples/mass_spring_damper.yaml");
  EXPECT_EQ(model.name(), "mass_spring_damper");
  model.Build(Interpreted());
  EXPECT_EQ(model.rhs_engine().rfind("interpreter", 0), 0u);
  EXPECT_THAT(model.state_names(), ::testing::ElementsAre("mass.p", "spring.q", ::testing::_, ::testing::_));
  const std::vector<std::string> columns = model.column_names();
  EXPECT_EQ(columns.front(), "time");
  EXPECT_THAT(columns, ::testing::Contains("spring_force"));
  EXPECT_THAT(columns, ::testing::Contains("energy.residual"));
}

TEST(ApiModel, TheStepLimitBoundsARun) {
  InputLimits limits;
  limits.steps = 1000;
  Model model = Model::FromString(test::MassSpringDamper(), "<string>", limits);
  SimulationOptions o;
  o.solver = "rk4";
  o.step = 1e-4;  // 2 s / 1e-4 = 20,000 fixed steps > 1000
  try {
    model.Simulate(o);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("more than the limit"));
  }
}

// Dropped from 1 m with restitution 0.8: impacts at t1 = sqrt(2 h0 / g), then every 2 e^k v1 / g.
TEST(ApiResults, TheEventsOfARunAreItsImpactsInTimeOrder) {
  Model model = Model::FromFile(std::string(MULTIBOND_SOURCE_DIR) + "/examples/events/bouncing_ball.yaml");
  SimulationOptions o;
  o.t_end = 2.0;
  const Results r = model.Simulate(o);
  ASSERT_TRUE(r.ok()) << r.summary().message;
  std::vector<double> impacts;
  for (const Event& e : r.summary().events) {
    EXPECT_EQ(e.element, "ground");
    if (e.kind == "impact") impacts.push_back(e.time);
  }
  ASSERT_GE(impacts.size(), 3u);
  const double g = 9.81, v1 = std::sqrt(2 * g * 1.0);
  double t = std::sqrt(2 * 1.0 / g);
  for (size_t k = 0; k < 3; ++k) {
    EXPECT_NEAR(impacts[k], t, 1e-6) << "impact " << k;
    t += 2 * std::pow(0.8, static_cast<double>(k + 1)) * v1 / g;
  }
  EXPECT_TRUE(std::is_sorted(impacts.begin(), impacts.end()));
}

}  // namespace
}  // namespace multibond
