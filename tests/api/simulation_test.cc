// The public Simulation: stepping, reading values, setting inputs and the state.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <multibond/multibond.h>

#include "api/msd.h"

namespace multibond {
namespace {

Model Built(const std::string& yaml) {
  Model model = Model::FromString(yaml);
  BuildOptions b;
  b.jit = "off";
  model.Build(b);
  return model;
}

TEST(ApiSimulation, AdvanceToTheOutputTimesGivesTheRunsNumbers) {
  Model model = Built(test::MassSpringDamper());
  const Results run = model.Simulate();
  Simulation sim = model.Start();
  EXPECT_EQ(sim.time(), 0.0);
  const auto t = run.times();
  for (size_t k = 1; k < run.rows(); ++k) {
    const bool last = k + 1 == run.rows();
    sim.AdvanceTo(last ? 2.0 : static_cast<double>(k) * 0.01);  // the run's output times: t_start + k dt, then t_end
    ASSERT_EQ(sim.time(), t[k]);
    // The same integrator called the same way: the same numbers, to the last bit.
    ASSERT_EQ(sim.Value("spring.q"), run.column("spring.q")[k]) << "t = " << t[k];
    ASSERT_EQ(sim.Value("mass.p"), run.column("mass.p")[k]);
    ASSERT_EQ(sim.Value("velocity"), run.column("velocity")[k]);
  }
  EXPECT_NEAR(sim.Value("spring.q"), test::Position(2.0), 1e-9);
}

TEST(ApiSimulation, CoarseStepsAgreeWithTheClosedForm) {
  Model model = Built(test::MassSpringDamper());
  Simulation sim = model.Start();
  for (const double t : {0.3, 0.31, 1.0, 1.7, 2.5}) {
    sim.AdvanceTo(t);
    EXPECT_NEAR(sim.Value("spring.q"), test::Position(t), 1e-9) << "t = " << t;
    EXPECT_NEAR(sim.Value("spring.e"), 100.0 * test::Position(t), 1e-7);  // an effort read by name
  }
  EXPECT_EQ(sim.state_names(), model.state_names());
  EXPECT_EQ(sim.state().size(), sim.state_names().size());
}

TEST(ApiSimulation, ResetStartsAgainFromTheInitialState) {
  Model model = Built(test::MassSpringDamper());
  Simulation sim = model.Start();
  sim.AdvanceTo(1.0);
  const double x1 = sim.Value("spring.q");
  sim.AdvanceTo(1.5);
  sim.Reset();
  EXPECT_EQ(sim.time(), 0.0);
  EXPECT_EQ(sim.Value("spring.q"), 0.0);
  sim.AdvanceTo(1.0);
  EXPECT_EQ(sim.Value("spring.q"), x1);
}

TEST(ApiSimulation, SetInputHoldsASourceFromNowOn) {
  Model model = Built(test::MassSpringDamper());
  Simulation sim = model.Start();
  EXPECT_THAT(sim.input_names(), ::testing::ElementsAre("force"));
  sim.SetInput("force", 2.0);  // at t = 0: the response to a 2 N step
  sim.AdvanceTo(1.0);
  EXPECT_NEAR(sim.Value("spring.q"), test::Position(1.0, 100.0, 2.0), 1e-9);
  // Released at t = 1 (force 0): from then on the free response from the state at t = 1, which
  // is the 2 N step response minus a 2 N step response delayed by 1 s (superposition).
  sim.SetInput("force", 0.0);
  sim.AdvanceTo(1.8);
  EXPECT_NEAR(sim.Value("spring.q"), test::Position(1.8, 100.0, 2.0) - test::Position(0.8, 100.0, 2.0), 1e-9);
  sim.Reset();  // the model's own input again: 1 N
  sim.AdvanceTo(1.0);
  EXPECT_NEAR(sim.Value("spring.q"), test::Position(1.0), 1e-9);
  EXPECT_THROW(sim.SetInput("spring", 1.0), std::invalid_argument);
}

TEST(ApiSimulation, SetStateRestartsFromThatState) {
  Model model = Built(test::MassSpringDamper(100.0, 0.0));
  Simulation sim = model.Start();
  std::vector<double> x = sim.state();
  x[1] = 0.02;  // spring.q: released from 2 cm
  sim.SetState(x);
  sim.AdvanceTo(2.0);
  const double w0 = 10.0, zeta = 0.1, wd = w0 * std::sqrt(1 - zeta * zeta);
  EXPECT_NEAR(sim.Value("spring.q"), 0.02 * std::exp(-zeta * w0 * 2.0) * (std::cos(wd * 2.0) + zeta * w0 / wd * std::sin(wd * 2.0)), 1e-9);
  EXPECT_THROW(sim.SetState(std::vector<double>{1.0}), std::invalid_argument);
}

TEST(ApiSimulation, RefusesGoingBackAndUnknownNames) {
  Model model = Built(test::MassSpringDamper());
  Simulation sim = model.Start();
  sim.AdvanceTo(0.5);
  EXPECT_THROW(sim.AdvanceTo(0.4), std::invalid_argument);
  try {
    (void)sim.Value("sprin.q");
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("did you mean 'spring.q'?"));
  }
}

TEST(ApiSimulation, VectorsAreReadWholeOrByComponent) {
  const std::string yaml =
      "model: planar_mass\n"
      "domain: translation\n"
      "elements:\n"
      "  push: {type: Se, effort: [1.0, 2.0]}\n"
      "  mass: {type: I, inertia: 2.0}\n"
      "  j:    {type: \"1\", components: [x, y]}\n"
      "bonds: [push -> j, j -> mass]\n";
  Model model = Built(yaml);
  Simulation sim = model.Start();
  sim.AdvanceTo(1.0);  // p = F t
  EXPECT_THAT(sim.Values("mass.p"), ::testing::ElementsAre(::testing::DoubleNear(1.0, 1e-9), ::testing::DoubleNear(2.0, 1e-9)));
  EXPECT_NEAR(sim.Value("j.f.y"), 1.0, 1e-9);  // v = p / m
  EXPECT_THROW((void)sim.Value("mass.p"), std::invalid_argument);  // two components: ask for one
}

}  // namespace
}  // namespace multibond
