// The kinks of formulas (compile/kinks.h): each non-smooth function's switching functions, the
// table's classification (of time alone: time events; else event functions), and the time events
// found ahead of a run, against the exact roots.

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "multibond/compile/kinks.h"
#include "multibond/core/expression.h"

namespace multibond {
namespace {

expr::NodePtr Tree(const std::string& text) {
  const expr::ParseResult r = expr::Parse(text);
  EXPECT_FALSE(r.error) << text;
  return r.root;
}

/// The switching functions of a formula's top node, as formulas.
std::vector<std::string> Switching(const std::string& text) {
  std::vector<std::string> out;
  for (const expr::NodePtr& g : SwitchingFunctions(*Tree(text))) out.push_back(expr::Format(*g));
  return out;
}

TEST(SwitchingFunctions, AreTheArgumentsWhoseSignChoosesTheBranch) {
  EXPECT_EQ(Switching("abs(x - 1)"), std::vector<std::string>{"x - 1"});
  EXPECT_EQ(Switching("sign(q)"), std::vector<std::string>{"q"});
  EXPECT_EQ(Switching("max(f, 0)"), std::vector<std::string>{"f - 0"});
  EXPECT_EQ(Switching("min(a, 2*b)"), std::vector<std::string>{"a - 2*b"});
  EXPECT_EQ(Switching("clamp(x, lo, hi)"), (std::vector<std::string>{"x - lo", "x - hi"}));
  EXPECT_EQ(Switching("x < 1"), std::vector<std::string>{"x - 1"});
  EXPECT_EQ(Switching("a != b"), std::vector<std::string>{"a - b"});
  EXPECT_EQ(Switching("if(t >= 0.5, 1, 0)"), std::vector<std::string>{});  // its comparison is its own node
  EXPECT_EQ(Switching("if(u, 1, 0)"), std::vector<std::string>{"u"});       // a number as a truth value
  EXPECT_EQ(Switching("u and x > 0"), std::vector<std::string>{"u"});
  EXPECT_EQ(Switching("not v"), std::vector<std::string>{"v"});
  for (const char* smooth : {"sin(x)", "x^2", "smoothabs(x, 1e-3)", "smoothsign(x, 1e-3)", "hypot(x, y)", "a + b", "x"})
    EXPECT_TRUE(Switching(smooth).empty()) << smooth;
}

/// A kink whose switching function is `text`, of t and x[0].
KinkTable::Kink Kink(const std::string& owner, const std::string& text) {
  KinkTable::Kink k;
  k.owner = owner;
  k.what = "the effort of " + owner;
  k.formula = text;
  k.function = text;
  k.program = expr::CompileProgram(*Tree(text), [](const expr::Node& n) -> expr::Input {
    if (n.name == "t") return {expr::Input::In::kTime, 0, 0.0};
    if (n.name == "x") return {expr::Input::In::kState, 0, 0.0};
    return {expr::Input::In::kConstant, 0, 2.0};  // any other name: a parameter of value 2
  });
  return k;
}

TEST(KinkTable, SortsTimeEventsFromEventFunctionsAndDropsConstantsAndRepeats) {
  KinkTable table;
  table.Add(Kink("push", "t - 0.5"));
  table.Add(Kink("push", "t - 0.5"));     // the same formula compiled twice: once
  table.Add(Kink("other", "t - 0.5"));    // another owner's: its own
  table.Add(Kink("spring", "x - 1"));
  table.Add(Kink("spring", "k - 1"));     // of a parameter only: never changes
  ASSERT_EQ(table.kinks().size(), 3u);
  EXPECT_TRUE(table.kinks()[0].time_only);
  ASSERT_EQ(table.num_roots(), 1);
  EXPECT_EQ(table.root_kink(0).owner, "spring");
  const double x[] = {1.25};
  double g = 0.0;
  table.Roots(0.0, x, nullptr, &g);
  EXPECT_EQ(g, 0.25);
}

TEST(KinkTable, FindsEachSignChangeOfTimeToTheDouble) {
  KinkTable table;
  table.Add(Kink("push", "(t - 0.5)/0.1 - 1"));  // exactly 0 at 0.6 (rounded: the first double at or past it)
  table.Add(Kink("wave", "sin(2*pi*7*t)"));      // pi as a parameter of 2: sin(28 t), roots k pi / 28
  const std::vector<TimeEvent> events = table.TimeEvents(0.0, 1.0, 0.01);
  std::vector<double> push, wave;
  for (const TimeEvent& e : events) {
    EXPECT_EQ(e.kind, "kink");
    (e.element == "push" ? push : wave).push_back(e.time);
  }
  ASSERT_EQ(push.size(), 1u);
  EXPECT_NEAR(push[0], 0.6, 2e-16);
  EXPECT_GE((push[0] - 0.5) / 0.1 - 1, 0.0);  // on the new side (or at zero) at the event
  ASSERT_EQ(wave.size(), 8u);                  // k pi / 28 < 1 for k = 1 .. 8
  for (size_t k = 0; k < wave.size(); ++k) EXPECT_NEAR(wave[k], (k + 1) * std::numbers::pi / 28, 1e-15) << k;
  for (size_t k = 1; k < events.size(); ++k) EXPECT_LE(events[k - 1].time, events[k].time);
}

TEST(KinkTable, FindsTwoCrossingsBetweenTwoSamplesAtTheExtremum) {
  // (t - 0.4321)^2 - 1e-10: below zero only within 1e-5 of 0.4321, far inside one sample interval.
  KinkTable table;
  table.Add(Kink("dip", "(t - 0.4321)^2 - 1e-10"));
  const std::vector<TimeEvent> events = table.TimeEvents(0.0, 1.0, 0.1);
  ASSERT_EQ(events.size(), 2u);
  EXPECT_NEAR(events[0].time, 0.4321 - 1e-5, 1e-12);
  EXPECT_NEAR(events[1].time, 0.4321 + 1e-5, 1e-12);
}

TEST(KinkTable, ATouchWithoutCrossingAndAStartOnZeroAreNoEvents) {
  KinkTable table;
  table.Add(Kink("touch", "(t - 0.25)^2"));  // zero at 0.25 only, positive on both sides
  table.Add(Kink("start", "t"));             // zero at the start, then positive
  EXPECT_TRUE(table.TimeEvents(0.0, 1.0, 0.01).empty());
}

}  // namespace
}  // namespace multibond
