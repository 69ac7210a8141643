// SCAP: priorities, propagation through junctions and two-ports, and the explanation of conflicts.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "multibond/causality/causality.h"

namespace multibond {
namespace {

using ::testing::HasSubstr;

struct Analysed {
  BondGraph g;
  Structure s;
  CausalAssignment c;
};

Analysed Analyse(BondGraph g) {
  DiagnosticSink sink;
  Structure s = AnalyzeStructure(g, "", sink);
  EXPECT_FALSE(sink.has_errors()) << (sink.diagnostics().empty() ? "" : sink.diagnostics()[0].ToString());
  CausalAssignment c = AssignCausality(g, s);
  return {std::move(g), std::move(s), std::move(c)};
}

SourceValue One() { return {{TimeFunction::Constant(1.0)}}; }

TEST(Causality, EffortSourceDrivesInertiaInIntegralCausality) {
  BondGraph g;
  g.AddSe("se", One());
  g.AddJunction("j", ElementKind::kOne);
  g.AddI("m", Param::Scalar(1));
  g.AddR("r", Param::Scalar(1));
  g.Connect("se", "j");
  g.Connect("j", "m");
  g.Connect("j", "r");
  const Analysed a = Analyse(std::move(g));
  EXPECT_TRUE(a.c.integral());
  EXPECT_TRUE(a.c.diagnostics.empty());
  EXPECT_TRUE(a.c.EffortInto(a.g, 1, a.g.Find("m")));   // I receives effort: integral
  EXPECT_FALSE(a.c.EffortInto(a.g, 2, a.g.Find("r")));  // R receives flow: resistance causality
  EXPECT_EQ(a.c.reason[2].why, CausalAssignment::Why::kPropagated);  // decided by the junction
}

TEST(Causality, TwoFlowSourcesOnAOneJunctionConflict) {
  BondGraph g;
  g.AddSf("a", One());
  g.AddSf("b", One());
  g.AddJunction("j", ElementKind::kOne);
  g.AddR("r", Param::Scalar(1));
  g.Connect("a", "j");
  g.Connect("b", "j");
  g.Connect("j", "r");
  const Analysed a = Analyse(std::move(g));
  ASSERT_TRUE(a.c.has_errors());
  const Diagnostic& d = a.c.diagnostics[0];
  EXPECT_EQ(d.code, "causality.conflict");
  EXPECT_EQ(d.message, "causal conflict: Sf 'b' and Sf 'a' both impose the flow on 1 'j'");
  ASSERT_EQ(d.details.size(), 1u);
  EXPECT_THAT(d.details[0], HasSubstr("Sf 'a' -> 1 'j'"));
}

TEST(Causality, ParallelCapacitorsGiveDerivativeCausalityWithHint) {
  BondGraph g;
  g.AddSf("src", One());
  g.AddJunction("n", ElementKind::kZero);
  g.AddC("c1", Param::Scalar(1));
  g.AddC("c2", Param::Scalar(2));
  g.Connect("src", "n");
  g.Connect("n", "c1");
  g.Connect("n", "c2");
  const Analysed a = Analyse(std::move(g));
  ASSERT_EQ(a.c.derivative.size(), 1u);
  EXPECT_EQ(a.g.element(a.c.derivative[0]).name, "c2");
  const Diagnostic& d = a.c.diagnostics.back();
  EXPECT_THAT(d.message, HasSubstr("derivative causality at C 'c2': its effort is fixed by C 'c1'"));
  EXPECT_THAT(d.details[0], HasSubstr("C 'c1' -> 0 'n' -> C 'c2'"));
  EXPECT_THAT(d.hint, HasSubstr("merge the two compliances"));
}

TEST(Causality, GyratorTurnsAnEffortSourceIntoAFlowSource) {
  // Se -> GY -> I: the gyrator imposes a flow on the inertia (derivative); on a C it is integral.
  for (const auto& [storage, integral] : {std::pair{ElementKind::kI, false}, std::pair{ElementKind::kC, true}}) {
    BondGraph g;
    g.AddSe("se", One());
    g.AddGY("gy", Param::Scalar(2));
    if (storage == ElementKind::kI) g.AddI("s", Param::Scalar(1));
    else g.AddC("s", Param::Scalar(1));
    g.Connect("se", "gy");
    g.Connect("gy", "s");
    const Analysed a = Analyse(std::move(g));
    EXPECT_EQ(a.c.integral(), integral) << KindName(storage);
  }
}

TEST(Causality, NonSquareTransformerWorksOneWayOnly) {
  // A 1x2 selection TF: flow can only pass from the 2-dimensional side to the scalar side.
  Eigen::MatrixXd sel(1, 2);
  sel << 0, 1;
  {
    BondGraph g;
    g.AddSf("v", {{TimeFunction::Constant(1.0), TimeFunction::Constant(2.0)}}, 2);
    g.AddJunction("j", ElementKind::kOne);
    g.AddTF("pick", Param::Matrix(sel));
    g.AddR("r", Param::Scalar(3));
    g.Connect("v", "j");
    g.Connect("j", "pick");
    g.Connect("pick", "r");
    const Analysed a = Analyse(std::move(g));
    EXPECT_TRUE(a.c.integral());
    EXPECT_FALSE(a.c.has_errors());
    EXPECT_EQ(a.c.reason[1].why, CausalAssignment::Why::kForcedTwoPort);
  }
  {
    // The scalar side holds an inertia in integral causality: it would have to push its flow
    // backwards through the selection: a conflict, explained.
    BondGraph g;
    g.AddSf("v", {{TimeFunction::Constant(1.0), TimeFunction::Constant(2.0)}}, 2);
    g.AddJunction("j", ElementKind::kOne);
    g.AddTF("pick", Param::Matrix(sel));
    g.AddI("m", Param::Scalar(3));
    g.Connect("v", "j");
    g.Connect("j", "pick");
    g.Connect("pick", "m");
    const Analysed a = Analyse(std::move(g));
    EXPECT_FALSE(a.c.integral());
    EXPECT_EQ(a.g.element(a.c.derivative.at(0)).name, "m");
  }
}

TEST(Causality, PathsAreDeterministicAndStartAtTheOrigin) {
  BondGraph g;
  g.AddSf("drive", One());
  g.AddJunction("a", ElementKind::kOne);
  g.AddTF("tf", Param::Scalar(0.5));
  g.AddJunction("b", ElementKind::kOne);
  g.AddI("load", Param::Scalar(1));
  g.Connect("drive", "a");
  g.Connect("a", "tf");
  g.Connect("tf", "b");
  g.Connect("b", "load");
  const Analysed a = Analyse(std::move(g));
  ASSERT_EQ(a.c.derivative.size(), 1u);
  EXPECT_EQ(FormatPath(a.g, a.c.PathTo(3)), "Sf 'drive' -> 1 'a' -> TF 'tf' -> 1 'b'");
  EXPECT_THAT(a.c.diagnostics[0].message, HasSubstr("its flow is fixed by TF 'tf' from Sf 'drive'"));
}

}  // namespace
}  // namespace multibond
