// UTF-8 checks (core/utf8.h): the text check of model files, and the escaping of text that is
// not UTF-8 (paths, arguments) so that the original bytes can be read back.

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

TEST(Utf8, ValidTextIsValidAndUnchanged) {
  for (const std::string s : {"", "plain", "µm, °, Ω", "\xF0\x9F\x98\x80 (U+1F600)", "back\\slash"}) {
    EXPECT_EQ(FindInvalidUtf8(s), std::string::npos) << s;
    EXPECT_EQ(EscapeInvalidUtf8(s), s);
  }
}

TEST(Utf8, EveryInvalidFormIsFoundAtItsFirstByte) {
  EXPECT_EQ(FindInvalidUtf8("caf\xE9"), 3u);             // Latin-1
  EXPECT_EQ(FindInvalidUtf8("a\xC0\xAF"), 1u);           // overlong '/'
  EXPECT_EQ(FindInvalidUtf8("a\xE0\x80\xAF"), 1u);       // overlong, three bytes
  EXPECT_EQ(FindInvalidUtf8("ab\xED\xA0\x80"), 2u);      // a surrogate
  EXPECT_EQ(FindInvalidUtf8("\xF4\x90\x80\x80"), 0u);    // above U+10FFFF
  EXPECT_EQ(FindInvalidUtf8("x\xE2\x82"), 1u);           // cut short
  EXPECT_EQ(FindInvalidUtf8("\x80"), 0u);                // a lone continuation byte
  EXPECT_EQ(FindInvalidUtf8("ok\xFF"), 2u);
}

TEST(Utf8, InvalidBytesAreEscapedRecoverably) {
  EXPECT_EQ(EscapeInvalidUtf8("caf\xE9.yaml"), "caf\\xE9.yaml");
  // A backslash beside an escape is doubled, so "\xE9" typed as text is not read as a byte.
  EXPECT_EQ(EscapeInvalidUtf8("a\\xE9\xFF"), "a\\\\xE9\\xFF");
  EXPECT_EQ(EscapeInvalidUtf8("\xC3\xA9\xC3"), "\xC3\xA9\\xC3");
}

}  // namespace
}  // namespace multibond
