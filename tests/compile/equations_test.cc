// FormatEquations: the symbolic state equations, their signs, LaTeX form and causal paths.
#include "multibond/compile/equations.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>

namespace multibond {
namespace {

SourceValue Value(double v) { return SourceValue{{TimeFunction::Constant(v)}}; }

/// Se force -> 1 j; j -> I mass; j -> C spring; j -> R damper (or with the C and R bonds reversed).
BondGraph MassSpringDamper(bool reversed = false, const std::string& mass = "mass") {
  BondGraph g("msd");
  g.AddSe("force", Value(3.0));
  g.AddJunction("j", ElementKind::kOne);
  g.AddI(mass, Param::Scalar(2.0));
  g.AddC("spring", Param::Scalar(100.0));
  g.AddR("damper", Param::Scalar(0.5));
  g.Connect("force", "j");
  g.Connect("j", mass);
  if (reversed) {
    g.Connect("spring", "j");
    g.Connect("damper", "j");
  } else {
    g.Connect("j", "spring");
    g.Connect("j", "damper");
  }
  return g;
}

/// Two inertias through a gear (ratio 2) and a compliant shaft (C and R on the relative speed):
/// Se torque -> 1 j1 (I J1) -> TF gear -> 0 z; z -> 1 rel (C shaft, R damp); z -> 1 j2 (I J2).
BondGraph GearPair() {
  BondGraph g("gear");
  g.AddSe("torque", Value(1.0));
  g.AddJunction("j1", ElementKind::kOne);
  g.AddI("J1", Param::Scalar(0.1));
  g.AddTF("gear", Param::Scalar(2.0));
  g.AddJunction("z", ElementKind::kZero);
  g.AddJunction("rel", ElementKind::kOne);
  g.AddC("shaft", Param::Scalar(1000.0));
  g.AddR("damp", Param::Scalar(0.3));
  g.AddJunction("j2", ElementKind::kOne);
  g.AddI("J2", Param::Scalar(0.4));
  g.Connect("torque", "j1");
  g.Connect("j1", "J1");
  g.Connect("j1", "gear");
  g.Connect("gear", "z");
  g.Connect("z", "rel");
  g.Connect("rel", "shaft");
  g.Connect("rel", "damp");
  g.Connect("z", "j2");
  g.Connect("j2", "J2");
  return g;
}

std::vector<std::string> Lines(const std::string& s) {
  std::vector<std::string> out;
  std::istringstream in(s);
  for (std::string line; std::getline(in, line);) out.push_back(line);
  return out;
}

/// The line that starts with `prefix`, or "" if none.
std::string LineStarting(const std::string& text, const std::string& prefix) {
  for (const std::string& l : Lines(text))
    if (l.rfind(prefix, 0) == 0) return l;
  return "";
}

int Count(const std::string& text, const std::string& what) {
  int n = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + what.size())) ++n;
  return n;
}

TEST(EquationsTest, MassSpringDamperText) {
  const auto m = CompiledModel::Compile(MassSpringDamper());
  const std::string text = FormatEquations(*m, EquationFormat::kText);
  EXPECT_NE(text.find("d(mass.p)/dt"), std::string::npos) << text;
  for (const char* sym : {"force(t)", "spring.K", "spring.q", "mass.p", "mass.I", "damper.R"})
    EXPECT_NE(text.find(sym), std::string::npos) << sym << "\n" << text;
  // Newton: the force pushes, the spring and the damper pull back.
  EXPECT_EQ(LineStarting(text, "d(mass.p)/dt"),
            "d(mass.p)/dt = force(t) - spring.K spring.q - damper.R * mass.p/mass.I")
      << text;
  EXPECT_EQ(LineStarting(text, "d(spring.q)/dt"), "d(spring.q)/dt = mass.p/mass.I") << text;
  // Causal paths, each leaf to the state's element.
  EXPECT_NE(text.find("  path: Se 'force' -> 1 'j' -> I 'mass'\n"), std::string::npos) << text;
  EXPECT_NE(text.find("  path: C 'spring' -> 1 'j' -> I 'mass'\n"), std::string::npos) << text;
  EXPECT_NE(text.find("  path: I 'mass' -> 1 'j' -> R 'damper' -> 1 'j' -> I 'mass'\n"), std::string::npos) << text;
  EXPECT_NE(text.find("  path: I 'mass' -> 1 'j' -> C 'spring'\n"), std::string::npos) << text;
  // The energy account is mentioned, not written out.
  EXPECT_NE(text.find("energy account"), std::string::npos);
  EXPECT_NE(text.find("force.work"), std::string::npos);
  EXPECT_NE(text.find("damper.dissipated"), std::string::npos);
  EXPECT_EQ(text.find("d(force.work)/dt"), std::string::npos);
  EXPECT_EQ(Count(text, "/dt ="), 2) << text;
}

TEST(EquationsTest, NoEnergyLineWithoutEnergyAccount) {
  CompileOptions options;
  options.energy_account = false;
  const auto m = CompiledModel::Compile(MassSpringDamper(), options);
  const std::string text = FormatEquations(*m, EquationFormat::kText);
  EXPECT_EQ(text.find("energy account"), std::string::npos) << text;
}

// With the C and R bonds pointing into the junction (sigma = -1 at C and R) the physics, and so
// the equation, is the same; the numbers of the plan agree with it.
TEST(EquationsTest, SignsDoNotDependOnBondDirection) {
  const auto m = CompiledModel::Compile(MassSpringDamper(/*reversed=*/true));
  const std::string text = FormatEquations(*m, EquationFormat::kText);
  EXPECT_EQ(LineStarting(text, "d(mass.p)/dt"),
            "d(mass.p)/dt = force(t) - spring.K spring.q - damper.R * mass.p/mass.I")
      << text;
  EXPECT_EQ(LineStarting(text, "d(spring.q)/dt"), "d(spring.q)/dt = mass.p/mass.I") << text;

  // dp/dt = F - K q - R p / m at p = 4, q = 0.01.
  Eigen::VectorXd x = m->MakeInitialState();
  Workspace ws = m->MakeWorkspace();
  x(0) = 4.0;   // mass.p
  x(1) = 0.01;  // spring.q
  Eigen::VectorXd xdot(m->num_states());
  m->CalcDerivatives(0.0, x.data(), xdot.data(), ws);
  EXPECT_NEAR(xdot(0), 3.0 - 100.0 * 0.01 - 0.5 * 4.0 / 2.0, 1e-12);
  EXPECT_NEAR(xdot(1), 4.0 / 2.0, 1e-12);
}

TEST(EquationsTest, LatexIsEscapedAndAligned) {
  const auto m = CompiledModel::Compile(MassSpringDamper(false, "big_mass"));
  const std::string tex = FormatEquations(*m, EquationFormat::kLatex);
  EXPECT_NE(tex.find("\\dot{p}_{\\mathrm{big\\_mass}} &= "), std::string::npos) << tex;
  EXPECT_NE(tex.find("\\dot{q}_{\\mathrm{spring}} &= "), std::string::npos) << tex;
  EXPECT_NE(tex.find("K_{\\mathrm{spring}} \\, q_{\\mathrm{spring}}"), std::string::npos) << tex;
  EXPECT_NE(tex.find("I_{\\mathrm{big\\_mass}}^{-1}"), std::string::npos) << tex;
  EXPECT_NE(tex.find("% path: Se 'force' -> 1 'j' -> I 'big_mass'"), std::string::npos) << tex;
  int rows = 0;
  for (const std::string& l : Lines(tex)) {
    if (l.rfind("%", 0) == 0) continue;  // comments are not typeset
    ++rows;
    EXPECT_EQ(Count(l, "&="), 1) << l;
    EXPECT_EQ(l.find("*"), std::string::npos) << l;
    EXPECT_EQ(l.find("d("), std::string::npos) << l;
    // Every '_' is an escaped one or a subscript.
    for (size_t k = 0; k < l.size(); ++k) {
      if (l[k] == '_') {
        EXPECT_TRUE((k > 0 && l[k - 1] == '\\') || (k + 1 < l.size() && l[k + 1] == '{')) << l;
      }
    }
  }
  EXPECT_EQ(rows, 2);
  // Rows are separated by \\, the last one is not terminated.
  EXPECT_EQ(Count(tex, "\\\\\n"), 1) << tex;
}

TEST(EquationsTest, GearPairHasTransformerTerms) {
  const auto m = CompiledModel::Compile(GearPair());
  const std::string text = FormatEquations(*m, EquationFormat::kText);
  // The coupling torque is reflected through the gear; the shaft twists with r w1 - w2.
  EXPECT_EQ(LineStarting(text, "d(J1.p)/dt"),
            "d(J1.p)/dt = torque(t) - gear.r * (shaft.K shaft.q + damp.R * (gear.r * J1.p/J1.I - J2.p/J2.I))")
      << text;
  EXPECT_EQ(LineStarting(text, "d(J2.p)/dt"),
            "d(J2.p)/dt = shaft.K shaft.q + damp.R * (gear.r * J1.p/J1.I - J2.p/J2.I)")
      << text;
  EXPECT_EQ(LineStarting(text, "d(shaft.q)/dt"), "d(shaft.q)/dt = gear.r * J1.p/J1.I - J2.p/J2.I") << text;
  EXPECT_EQ(text.find("^T"), std::string::npos) << "a scalar ratio needs no transpose\n" << text;
  EXPECT_NE(text.find("  path: C 'shaft' -> 1 'rel' -> 0 'z' -> TF 'gear' -> 1 'j1' -> I 'J1'\n"), std::string::npos)
      << text;
  EXPECT_NE(text.find("  path: I 'J1' -> 1 'j1' -> TF 'gear' -> 0 'z' -> 1 'rel' -> C 'shaft'\n"), std::string::npos)
      << text;
  EXPECT_NE(text.find("  path: I 'J2' -> 1 'j2' -> 0 'z' -> 1 'rel' -> C 'shaft'\n"), std::string::npos) << text;

  const std::string tex = FormatEquations(*m, EquationFormat::kLatex);
  EXPECT_NE(tex.find("\\dot{q}_{\\mathrm{shaft}} &= r_{\\mathrm{gear}} \\, I_{\\mathrm{J1}}^{-1} \\, p_{\\mathrm{J1}} - "
                     "I_{\\mathrm{J2}}^{-1} \\, p_{\\mathrm{J2}}"),
            std::string::npos)
      << tex;
  EXPECT_NE(tex.find("r_{\\mathrm{gear}} \\, \\left("), std::string::npos) << tex;
}

// A matrix ratio keeps its transposes: e1 = r^T e2.
TEST(EquationsTest, MatrixTransformerShowsTranspose) {
  BondGraph g("lever");
  g.AddSe("push", Value(1.0));
  g.AddJunction("a", ElementKind::kOne);
  g.AddI("m1", Param::Scalar(1.0));
  Eigen::MatrixXd r(1, 1);
  r << 3.0;
  g.AddTF("arm", Param::Matrix(r));
  g.AddJunction("b", ElementKind::kZero);
  g.AddC("k", Param::Scalar(10.0));
  g.Connect("push", "a");
  g.Connect("a", "m1");
  g.Connect("a", "arm");
  g.Connect("arm", "b");
  g.Connect("b", "k");
  const auto m = CompiledModel::Compile(g);
  const std::string text = FormatEquations(*m, EquationFormat::kText);
  EXPECT_EQ(LineStarting(text, "d(m1.p)/dt"), "d(m1.p)/dt = push(t) - arm.r^T * k.K k.q") << text;
  EXPECT_EQ(LineStarting(text, "d(k.q)/dt"), "d(k.q)/dt = arm.r * m1.p/m1.I") << text;
  const std::string tex = FormatEquations(*m, EquationFormat::kLatex);
  EXPECT_NE(tex.find("r_{\\mathrm{arm}}^{\\top} \\, K_{\\mathrm{k}}"), std::string::npos) << tex;
}

// A rotating body: rotated inertia, a resistor bond pointing out of the R, an orientation state
// and a position-like integral.
TEST(EquationsTest, AuxiliaryStatesAndRotatedInertia) {
  BondGraph g("body");
  g.AddSe("torque", Value(1.0), 3);
  g.AddJunction("A.w", ElementKind::kOne, 3);
  const int j = g.AddI("A.J", Param::Matrix(Eigen::Matrix3d(Eigen::Vector3d(1, 2, 3).asDiagonal())), 3);
  g.element(j).rotation = "A.R";
  g.AddR("A.b", Param::Scalar(0.1), 3);
  g.Connect("torque", "A.w");
  g.Connect("A.w", "A.J");
  g.Connect("A.b", "A.w");
  AuxState rot;
  rot.name = "A.R";
  rot.kind = AuxState::Kind::kOrientation;
  rot.of = "A.w";
  g.AddAux(rot);
  AuxState angle;
  angle.name = "A.angle";
  angle.of = "A.w";
  g.AddAux(angle);
  const auto m = CompiledModel::Compile(g);
  const std::string text = FormatEquations(*m, EquationFormat::kText);
  const std::string flow = "A.R inv(A.J.Ib) A.R^T A.J.p";
  EXPECT_EQ(LineStarting(text, "d(A.J.p)/dt"), "d(A.J.p)/dt = torque(t) - A.b.R * " + flow) << text;
  EXPECT_EQ(LineStarting(text, "d(A.R)/dt"), "d(A.R)/dt = [w x] A.R,  w = " + flow) << text;
  EXPECT_EQ(LineStarting(text, "d(A.angle)/dt"), "d(A.angle)/dt = " + flow) << text;
  EXPECT_NE(text.find("  path: I 'A.J' -> 1 'A.w'\n"), std::string::npos) << text;
  const std::string tex = FormatEquations(*m, EquationFormat::kLatex);
  EXPECT_NE(tex.find("[\\omega \\times]"), std::string::npos) << tex;
  EXPECT_NE(tex.find("\\mathrm{A.R}^{\\top}"), std::string::npos) << tex;
}

/// mass on j0, and a chain of 1-junctions j0 - j1 - ... - jn each with a source and a spring: the
/// effort reaching the mass nests n sums deep.
BondGraph Chain(int n) {
  BondGraph g("chain");
  g.AddI("mass", Param::Scalar(1.0));
  for (int k = 0; k <= n; ++k) {
    const std::string j = fmt::format("j{}", k), s = fmt::format("s{}", k), c = fmt::format("c{}", k);
    g.AddJunction(j, ElementKind::kOne);
    g.AddSe(s, Value(1.0));
    g.AddC(c, Param::Scalar(1.0));
    g.Connect(s, j);
    g.Connect(j, c);
    g.Connect(fmt::format("j{}", std::max(k - 1, 0)), k == 0 ? "mass" : j);
  }
  return g;
}

TEST(EquationsTest, BigExpressionsAreCutAtJunctionVariables) {
  const auto m = CompiledModel::Compile(Chain(100));
  const std::string text = FormatEquations(*m, EquationFormat::kText);
  const std::vector<std::string> lines = Lines(text);
  const auto eq = std::find_if(lines.begin(), lines.end(), [](const std::string& l) { return l.rfind("d(mass.p)/dt", 0) == 0; });
  ASSERT_NE(eq, lines.end()) << text;
  // Bounded: about 60 symbols, then a junction variable listed under "where:".
  EXPECT_LE(Count(*eq, "(t)") + Count(*eq, ".q"), 70) << *eq;
  EXPECT_NE(eq->find("s0(t) - c0.K c0.q + s1(t) - c1.K c1.q"), std::string::npos) << *eq;
  ASSERT_NE(eq + 1, lines.end());
  EXPECT_EQ(*(eq + 1), "  where:");
  // Every leaf of the expression appears exactly once over the equation and its intermediates.
  std::string block;
  for (auto it = eq; it != lines.end() && !it->empty(); ++it) block += *it + "\n";
  for (int k = 0; k <= 100; ++k) EXPECT_EQ(Count(block, fmt::format("s{}(t)", k)), 1) << k << "\n" << block;
  // The intermediates are listed in evaluation order (inputs first): in this chain each one is
  // used by the next, and the last by the equation.
  std::vector<std::string> names, defs;
  for (auto it = eq + 2; it != lines.end() && it->rfind("    ", 0) == 0; ++it) {
    const std::string name = it->substr(4, it->find(" = ") - 4);
    EXPECT_NE(name.find("->"), std::string::npos) << *it;  // bond-named effort between two 1-junctions
    names.push_back(name);
    defs.push_back(it->substr(it->find(" = ")));
  }
  ASSERT_GE(names.size(), 1u) << block;
  for (size_t k = 0; k + 1 < names.size(); ++k) EXPECT_NE(defs[k + 1].find(names[k]), std::string::npos) << block;
  EXPECT_NE(eq->find(names.back()), std::string::npos) << block;
  // 2 * 101 leaves: 12 paths shown, the rest counted.
  EXPECT_NE(block.find("  path: ... and 190 more\n"), std::string::npos) << block;
  EXPECT_EQ(Count(block, "  path: Se") + Count(block, "  path: C"), 12) << block;
}

TEST(EquationsTest, Deterministic) {
  const auto a = CompiledModel::Compile(GearPair());
  const auto b = CompiledModel::Compile(GearPair());
  EXPECT_EQ(FormatEquations(*a, EquationFormat::kText), FormatEquations(*b, EquationFormat::kText));
  EXPECT_EQ(FormatEquations(*a, EquationFormat::kLatex), FormatEquations(*a, EquationFormat::kLatex));
}

}  // namespace
}  // namespace multibond
