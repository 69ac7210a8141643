// The text check of model files (core/utf8.h).

#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "multibond/core/utf8.h"

namespace multibond {
namespace {

using ::testing::HasSubstr;

TEST(Utf8, AcceptsUtf8WithTabsAndLineEnds) {
  EXPECT_FALSE(FindTextProblem("model: m\r\n\tx: \"caf\xc3\xa9 \xe2\x82\xac \xf0\x9f\x98\x80\"\n").found());
  EXPECT_FALSE(FindTextProblem("\xef\xbb\xbfmodel: m").found());  // a byte order mark is UTF-8
  EXPECT_FALSE(FindTextProblem("").found());
}

TEST(Utf8, FindsTheFirstBadByte) {
  EXPECT_EQ(FindTextProblem("ab\xff").offset, 2u);
  EXPECT_THAT(FindTextProblem("ab\xff").what, HasSubstr("0xff"));
  EXPECT_EQ(FindTextProblem("caf\xe9!").offset, 3u);       // Latin-1
  EXPECT_EQ(FindTextProblem("x\xc0\xaf").offset, 1u);       // overlong '/'
  EXPECT_EQ(FindTextProblem("x\xe0\x80\xaf").offset, 1u);   // overlong, 3 bytes
  EXPECT_EQ(FindTextProblem("x\xed\xa0\x80").offset, 1u);   // a surrogate
  EXPECT_EQ(FindTextProblem("x\xf4\x90\x80\x80").offset, 1u);  // above U+10FFFF
  EXPECT_EQ(FindTextProblem("x\xe2\x82").offset, 1u);       // cut short at the end
  EXPECT_EQ(FindTextProblem("x\xc3(").offset, 1u);          // a continuation byte missing
  EXPECT_EQ(FindTextProblem("\x80").offset, 0u);            // a lone continuation byte
}

TEST(Utf8, FindsControlCharacters) {
  EXPECT_EQ(FindTextProblem(std::string("a\0b", 3)).offset, 1u);
  EXPECT_THAT(FindTextProblem("a\x1b[31m").what, HasSubstr("control character 0x1b"));
  EXPECT_EQ(FindTextProblem("a\x7f").offset, 1u);
}

}  // namespace
}  // namespace multibond
