// The identifier grammar of names (core/identifier.h).

#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "multibond/core/identifier.h"

namespace multibond {
namespace {

using ::testing::HasSubstr;

TEST(Identifier, AcceptsLettersDigitsAndUnderscore) {
  for (const char* name : {"mass", "J1", "_x", "mesh_GA", "G"}) EXPECT_EQ(IdentifierProblem(name), "") << name;
  EXPECT_EQ(IdentifierProblem(std::string(kMaxNameLength, 'a')), "");
}

TEST(Identifier, RefusesWhatCollidesWithColumnsOrBonds) {
  EXPECT_THAT(IdentifierProblem("spring.q"), HasSubstr("'.'"));
  EXPECT_THAT(IdentifierProblem("a->b"), HasSubstr("'-'"));
  EXPECT_THAT(IdentifierProblem("my mass"), HasSubstr("a space"));
  EXPECT_THAT(IdentifierProblem(""), HasSubstr("empty"));
  EXPECT_THAT(IdentifierProblem("1st"), HasSubstr("starts with a digit"));
  EXPECT_EQ(IdentifierProblem("1", true), "");  // a component name
  EXPECT_THAT(IdentifierProblem(std::string(kMaxNameLength + 1, 'a')), HasSubstr("at most 64"));
}

TEST(Identifier, RefusesWhatAnInterpreterWouldRead) {
  for (const char* name : {"a`id`", "$(id)", "a\"b", "a'b", "a\\b", "a\nb", "a;b", "<b>", "caf\xc3\xa9", "a\x7f"})
    EXPECT_NE(IdentifierProblem(name), "") << name;
}

TEST(Identifier, SuggestsAnIdentifier) {
  EXPECT_EQ(SuggestIdentifier("spring.q"), "spring_q");
  EXPECT_EQ(SuggestIdentifier("my mass"), "my_mass");
  EXPECT_EQ(SuggestIdentifier("a->b"), "a_b");
  EXPECT_EQ(SuggestIdentifier("2nd"), "_2nd");
  EXPECT_EQ(IdentifierProblem(SuggestIdentifier(std::string(200, 'x') + ".y")), "");
}

TEST(Identifier, PrintableExcerptHidesControlBytes) {
  EXPECT_EQ(PrintableExcerpt("a\nb\x1b"), "a?b?");
  EXPECT_EQ(PrintableExcerpt(std::string(100, 'a'), 10), std::string(10, 'a') + "...");
}

}  // namespace
}  // namespace multibond
