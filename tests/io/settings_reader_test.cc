// The `simulation:` section's event settings: read, defaulted, and refused out of range with a
// located diagnostic (param.range) at the value.

#include <optional>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "multibond/io/model_loader.h"

namespace multibond {
namespace {

using ::testing::HasSubstr;

const char* kModel = R"(model: m
domain: translation
elements:
  force: {type: Se, effort: 1.0}
  mass:  {type: I, inertia: 1.0}
  j:     {type: "1"}
bonds:
  - force -> j
  - j -> mass
)";

std::vector<Diagnostic> Errors(const std::string& simulation) {
  try {
    (void)LoadModelString(std::string(kModel) + simulation, "m.yaml");
  } catch (const ModelError& e) {
    return e.diagnostics();
  }
  ADD_FAILURE() << "expected a ModelError for: " << simulation;
  return {};
}

TEST(SettingsReader, ReadsTheEventSettings) {
  const LoadedModel lm = LoadModelString(std::string(kModel) + "simulation: {event_rest_time: 0.25, max_events_per_second: 50}\n");
  EXPECT_EQ(lm.simulation.event_rest_time, std::optional<double>(0.25));
  EXPECT_EQ(lm.simulation.max_events_per_second, std::optional<double>(50.0));
  // 0 is the built-in choice of rest time (a millionth of the run), and allowed.
  EXPECT_EQ(LoadModelString(std::string(kModel) + "simulation: {event_rest_time: 0}\n").simulation.event_rest_time, std::optional<double>(0.0));
  const LoadedModel none = LoadModelString(std::string(kModel) + "simulation: {t_end: 2}\n");
  EXPECT_FALSE(none.simulation.event_rest_time.has_value());
  EXPECT_FALSE(none.simulation.max_events_per_second.has_value());
}

TEST(SettingsReader, RefusesEventSettingsOutOfRangeAtTheValue) {
  for (const auto& [simulation, message] : std::vector<std::pair<std::string, std::string>>{
           {"simulation: {t_end: 2, event_rest_time: -1.0e-3}\n", "event_rest_time must be >= 0 (got -0.001)"},
           {"simulation: {t_end: 2, max_events_per_second: 0}\n", "max_events_per_second must be > 0 (got 0)"},
           {"simulation: {t_end: 2, max_events_per_second: -3}\n", "max_events_per_second must be > 0 (got -3)"}}) {
    const std::vector<Diagnostic> ds = Errors(simulation);
    ASSERT_EQ(ds.size(), 1u) << simulation;
    EXPECT_EQ(ds[0].code, "param.range") << simulation;
    EXPECT_EQ(ds[0].element, "simulation");
    EXPECT_THAT(ds[0].message, HasSubstr(message));
    EXPECT_EQ(ds[0].where.line, 10) << simulation;
    EXPECT_EQ(static_cast<size_t>(ds[0].where.column), simulation.rfind(' ') + 2) << simulation;  // the value, after the last space
  }
  // A value that is no finite number is said once, by the number reader.
  const std::vector<Diagnostic> ds = Errors("simulation: {max_events_per_second: .inf}\n");
  ASSERT_EQ(ds.size(), 1u);
  EXPECT_THAT(ds[0].message, HasSubstr("is not a finite number"));
  // A misspelt key is an unknown key with a did-you-mean.
  const std::vector<Diagnostic> typo = Errors("simulation: {event_rest: 0.1}\n");
  ASSERT_EQ(typo.size(), 1u);
  EXPECT_THAT(typo[0].ToString(), HasSubstr("event_rest_time"));
}

}  // namespace
}  // namespace multibond
