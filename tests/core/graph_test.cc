// The editable bond graph (core/graph.h): adding elements under unique names, and the room a
// builder that knows its size reserves.

#include <string>

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "multibond/core/graph.h"

namespace multibond {
namespace {

using ::testing::HasSubstr;

TEST(BondGraph, AddIndexesEachNameAndRefusesASecondElementOfTheSameName) {
  BondGraph g;
  EXPECT_EQ(g.AddI("a", Param::Scalar(1.0)), 0);
  g.element(0).where = {"m.yaml", 3, 5};
  EXPECT_EQ(g.AddJunction("j", ElementKind::kOne), 1);
  Element again = g.element(0);
  again.where = {"m.yaml", 7, 5};
  try {
    g.Add(again);
    ADD_FAILURE() << "a duplicate name is accepted";
  } catch (const ModelError& e) {
    ASSERT_EQ(e.diagnostics().size(), 1u);
    const Diagnostic& d = e.diagnostics().front();
    EXPECT_EQ(d.message, "duplicate element name");
    EXPECT_EQ(d.element, "a");
    EXPECT_EQ(d.where.line, 7);
    ASSERT_EQ(d.details.size(), 1u);
    EXPECT_THAT(d.details.front(), HasSubstr("m.yaml:3:5"));
  }
  // The refused element changed nothing.
  EXPECT_EQ(g.num_elements(), 2);
  EXPECT_EQ(g.Find("a"), 0);
  EXPECT_EQ(g.Find("j"), 1);
  EXPECT_EQ(g.element(0).where.line, 3);
  EXPECT_EQ(g.AddJunction("k", ElementKind::kZero), 2);
}

TEST(BondGraph, ReservedRoomIsUsedWithoutMovingTheElementsOrBonds) {
  BondGraph g;
  const int n = 1000;
  g.Reserve(n, n - 1);
  g.AddJunction("j0", ElementKind::kOne);
  g.AddJunction("j1", ElementKind::kOne);
  g.Connect("j0", "j1");
  const Element* first = &g.elements().front();
  const Bond* first_bond = &g.bonds().front();
  for (int i = 2; i < n; ++i) {
    g.AddJunction(fmt::format("j{}", i), ElementKind::kOne);
    g.Connect(fmt::format("j{}", i - 1), fmt::format("j{}", i));
  }
  EXPECT_EQ(&g.elements().front(), first);  // never moved: the room was there
  EXPECT_EQ(&g.bonds().front(), first_bond);
  EXPECT_EQ(g.num_bonds(), n - 1);
  EXPECT_EQ(g.Find("j999"), 999);
  g.Reserve(-1, -1);  // nothing (a count below zero is no count)
  EXPECT_EQ(g.num_elements(), n);
}

}  // namespace
}  // namespace multibond
